#!/usr/bin/env python3
# SPDX-License-Identifier: Apache-2.0
"""Every repository path cited in the tracked sources, scripts and docs exists.

A citation is a word that starts with one of the repository's top-level folders or src/'s folders (src/,
include/, apps/, tests/, docs/, scripts/, config/, python/, .ci/) followed by a path whose last part names a
file (it has a dot or a glob) or ends with "/": `src/server/server.cpp`, `tests/common/run_child.*`,
`src/daemon/recorder*`, `docs/protocol.md`, `tests/common/`. It resolves against the repository root, src/,
include/ or the citing file's folder (sources include "config/options.hpp" from src/), against the tracked files
and their folders only: a file that exists in this checkout but is not tracked (a build product, an untracked
draft) is dangling, as it is in a clean clone. Globs (`*`) and brace lists (`{a,b}`) are expanded. Not
citations: paths in URLs, in a build tree (after `build`, or through a folder named `build`), and paths of an
upstream project named on the same or the previous line (UPSTREAM), and templates with a placeholder
(`src/{name}/`, a brace group without a comma). tests/layout/ (the layout checks' own tests, which build
trees with dangling paths on purpose) is not scanned. Usage: check-cited-paths.py [REPO_ROOT] — exit 1 and one line per dangling
citation (file:line: path), exit 0 when every citation resolves.
"""
import os
import re
import subprocess
import sys

TOP = ("src", "include", "apps", "tests", "docs", "scripts", "config", "python", ".ci")
CITATION = re.compile(r"(?<![\w./-])((?:%s)/[\w./*{},+-]*[\w*}/])" % "|".join(re.escape(t) for t in TOP))
UPSTREAM = ("libnifalcon", "libusb's", "upstream")
SCANNED = re.compile(r"\.(cpp|hpp|h|py|sh|md|cmake|txt|toml|in|service|rules)$|(^|/)(CMakeLists\.txt|run)$")


def expand(path):
    m = re.search(r"\{([^{}]*)\}", path)
    if not m:
        return [path]
    out = []
    for alt in m.group(1).split(","):
        out += expand(path[: m.start()] + alt + path[m.end():])
    return out


def names_a_file(cited):
    last = cited.rstrip("/").rsplit("/", 1)[-1]
    return cited.endswith("/") or "." in last or "*" in last or "}" in last


def resolves(tracked, citing_dir, cited):
    """tracked: the tracked files and every folder above them, as "a/b/c" and "a/b/"."""
    for base in ("", "src/", "include/", citing_dir + "/" if citing_dir else ""):
        for path in expand(cited):
            full = os.path.normpath(base + path) + ("/" if path.endswith("/") else "")
            if "*" in path:
                pattern = re.compile("[^/]*".join(re.escape(p) for p in full.split("*")) + "/?")
                if any(pattern.fullmatch(t) for t in tracked):
                    return True
            elif full in tracked or full + "/" in tracked:
                return True
    return False


def with_folders(files):
    out = set(files)
    for f in files:
        parts = f.split("/")
        for i in range(1, len(parts)):
            out.add("/".join(parts[:i]) + "/")
    return sorted(out)


def tracked_files(root):
    """git ls-files; without git (a source tarball), every file under root outside build trees and .git."""
    try:
        listed = subprocess.run(["git", "-C", root, "ls-files"], capture_output=True, text=True, check=True).stdout
        if listed:
            return listed.split()
    except (OSError, subprocess.CalledProcessError):
        pass
    out = []
    for folder, dirs, names in os.walk(root):
        dirs[:] = [d for d in dirs if d != ".git" and not d.startswith("build")]
        out += [os.path.relpath(os.path.join(folder, n), root) for n in names]
    return out


def main():
    root = os.path.abspath(sys.argv[1] if len(sys.argv) > 1 else os.path.join(os.path.dirname(__file__), ".."))
    files = tracked_files(root)
    tracked = with_folders(files)
    tracked_set = set(tracked)
    dangling = []
    for rel in files:
        if not SCANNED.search(rel) or rel.startswith(("tests/fuzz/corpus", "tests/layout/")):
            continue
        try:
            with open(os.path.join(root, rel), encoding="utf-8") as f:
                lines = f.readlines()
        except (OSError, UnicodeDecodeError):
            continue
        for number, line in enumerate(lines, 1):
            previous = lines[number - 2] if number > 1 else ""
            for m in CITATION.finditer(line):
                cited = m.group(1).rstrip(".,;:")
                before = line[: m.start(1)]
                if not names_a_file(cited) or re.search(r"(https?://|build)\S*$", before) or re.search(r"\{[^,{}]*\}", cited):
                    continue
                if "build" in cited.split("/"):
                    continue
                if any(u in before or u in previous for u in UPSTREAM):
                    continue
                if not resolves(tracked if "*" in cited else tracked_set, os.path.dirname(rel), cited):
                    dangling.append(f"{rel}:{number}: {cited}")
    for d in dangling:
        print(d)
    if dangling:
        print(f"check-cited-paths: {len(dangling)} cited path(s) not in the repository", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
