#!/usr/bin/env python3
# SPDX-License-Identifier: Apache-2.0
"""Checks that every #include "..." between src/ folders is allowed by the folders' CMake link interface.

The one source of truth is each src/<folder>/CMakeLists.txt: the hapticd_* / hapticopt_* / hapticd_client targets
named in its `target_link_libraries(<the folder's target> ...)` call(s) are the folders it may depend on (the
target of folder <f> is hapticd_<f>; svg/ is hapticopt_svg, client/ is hapticd_client, hapticopt/ is
hapticopt_compiled). The script fails, naming the file, the include and the rule, on
  * an include of another src/ folder that the including folder does not link,
  * a cycle between the folders' allowed dependencies,
  * any include from src/ of a header under apps/ (src/ never depends on apps/).
Headers of include/ (hapticopt/, hapticd/) and system headers are not checked.

Usage: check-include-graph.py [--root DIR]   (DIR: the repository; default: this script's parent's parent)
Exit status 0 when the graph is allowed, 1 otherwise.
"""
import argparse
import os
import re
import sys

INCLUDE = re.compile(r'^\s*#\s*include\s*"([^"]+)"', re.M)
LINK_CALL = re.compile(r'target_link_libraries\s*\(\s*([A-Za-z0-9_:]+)([^)]*)\)', re.S)
SOURCE_EXT = ('.cpp', '.hpp', '.h', '.cc', '.in')


def folder_target(folder):
    return {'svg': 'hapticopt_svg', 'client': 'hapticd_client', 'hapticopt': 'hapticopt_compiled'}.get(
        folder, 'hapticd_' + folder)


def read_allowed(src):
    """folder -> set of folders its CMake target links (only targets of src/ folders count)."""
    folders = sorted(d for d in os.listdir(src) if os.path.isdir(os.path.join(src, d)))
    target_to_folder = {folder_target(f): f for f in folders}
    allowed, errors = {}, []
    for f in folders:
        cmake = os.path.join(src, f, 'CMakeLists.txt')
        if not os.path.isfile(cmake):
            errors.append(f'src/{f}/: no CMakeLists.txt (each src/ folder is one target whose link interface is its '
                          f'charter)')
            allowed[f] = set()
            continue
        text = re.sub(r'#[^\n]*', '', open(cmake, encoding='utf-8').read())
        deps = set()
        for target, args in LINK_CALL.findall(text):
            if target != folder_target(f):
                continue
            for word in args.split():
                if word in target_to_folder and target_to_folder[word] != f:
                    deps.add(target_to_folder[word])
        allowed[f] = deps
    return allowed, errors


def find_cycle(graph):
    """One cycle of the folder graph as a list of folders, or None."""
    state = {}
    stack = []

    def visit(node):
        state[node] = 1
        stack.append(node)
        for nxt in sorted(graph.get(node, ())):
            if state.get(nxt) == 1:
                return stack[stack.index(nxt):] + [nxt]
            if state.get(nxt) is None:
                found = visit(nxt)
                if found:
                    return found
        stack.pop()
        state[node] = 2
        return None

    for node in sorted(graph):
        if state.get(node) is None:
            found = visit(node)
            if found:
                return found
    return None


def scan(root):
    src = os.path.join(root, 'src')
    apps = os.path.join(root, 'apps')
    allowed, errors = read_allowed(src)
    folders = set(allowed)
    app_headers = set()
    if os.path.isdir(apps):
        for dirpath, _, files in os.walk(apps):
            for name in files:
                if name.endswith(('.hpp', '.h')):
                    app_headers.add(name)
                    app_headers.add(os.path.relpath(os.path.join(dirpath, name), root))
                    app_headers.add(os.path.relpath(os.path.join(dirpath, name), apps))
    used = {f: set() for f in folders}
    for f in sorted(folders):
        for dirpath, _, files in os.walk(os.path.join(src, f)):
            for name in sorted(files):
                if not name.endswith(SOURCE_EXT):
                    continue
                path = os.path.join(dirpath, name)
                rel = os.path.relpath(path, root)
                here = os.path.dirname(path)
                text = open(path, encoding='utf-8', errors='replace').read()
                for inc in INCLUDE.findall(text):
                    head = inc.split('/')[0]
                    if inc.startswith('apps/') or (
                            '/' not in inc and not os.path.exists(os.path.join(here, inc)) and inc in app_headers) or (
                            head not in folders and inc in app_headers):
                        errors.append(f'{rel}: #include "{inc}": src/ must not depend on apps/ (a header of apps/)')
                        continue
                    if '/' not in inc or head not in folders or head == f:
                        continue
                    used[f].add(head)
                    if head not in allowed[f]:
                        errors.append(f'{rel}: #include "{inc}": src/{f}/ may not depend on src/{head}/ (its target '
                                      f'{folder_target(f)} does not link {folder_target(head)} in '
                                      f'src/{f}/CMakeLists.txt; allowed: {", ".join(sorted(allowed[f])) or "none"})')
    cycle = find_cycle(allowed)
    if cycle:
        errors.append('cycle between folders in the CMake link interface: ' + ' -> '.join(cycle))
    cycle = find_cycle(used)
    if cycle:
        errors.append('cycle between folders in the includes: ' + ' -> '.join(cycle))
    return allowed, errors


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--root', default=os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
    parser.add_argument('--print-graph', action='store_true', help='print each folder and what it may depend on')
    args = parser.parse_args()
    allowed, errors = scan(args.root)
    if args.print_graph:
        for f in sorted(allowed):
            print(f'{f}: {" ".join(sorted(allowed[f])) or "-"}')
    for e in errors:
        print('check-include-graph: ' + e, file=sys.stderr)
    if errors:
        print(f'check-include-graph: {len(errors)} violation(s)', file=sys.stderr)
        return 1
    print(f'check-include-graph: {len(allowed)} folders, includes within their charters, no cycle')
    return 0


if __name__ == '__main__':
    sys.exit(main())
