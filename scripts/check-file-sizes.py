#!/usr/bin/env python3
# SPDX-License-Identifier: Apache-2.0
"""No source file outgrows the house limits, so each stays one concern (docs/architecture.md, "Layout").

Limits, in lines: a file of src/ (.cpp, .hpp) at most 600; a public header of include/ at most 800. The files are
the tracked ones (git ls-files) or, outside a git checkout, every file below the root. Usage:
check-file-sizes.py [--root REPO_ROOT] — exit 1 and one line per file over its limit (path: lines > limit), exit 0
otherwise.
"""
import argparse
import os
import subprocess
import sys

LIMITS = (("src/", (".cpp", ".hpp"), 600), ("include/", (".hpp", ".h"), 800))


def files_under(root):
    try:
        out = subprocess.run(["git", "-C", root, "ls-files", "--", "src", "include"], check=True,
                             capture_output=True, text=True).stdout
        return [line for line in out.splitlines() if line]
    except (OSError, subprocess.CalledProcessError):
        found = []
        for top in ("src", "include"):
            for folder, _, names in os.walk(os.path.join(root, top)):
                found += [os.path.relpath(os.path.join(folder, n), root) for n in names]
        return found


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--root", default=os.path.join(os.path.dirname(os.path.abspath(__file__)), os.pardir))
    root = parser.parse_args().root
    over = []
    for path in sorted(files_under(root)):
        for prefix, suffixes, limit in LIMITS:
            if path.startswith(prefix) and path.endswith(suffixes):
                with open(os.path.join(root, path), encoding="utf-8") as f:
                    lines = sum(1 for _ in f)
                if lines > limit:
                    over.append(f"{path}: {lines} lines > {limit}")
    for line in over:
        print(line)
    return 1 if over else 0


if __name__ == "__main__":
    sys.exit(main())
