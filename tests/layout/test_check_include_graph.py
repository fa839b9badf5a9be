#!/usr/bin/env python3
# SPDX-License-Identifier: Apache-2.0
"""scripts/check-include-graph.py on small temporary trees: an allowed tree passes; a forbidden include, a cycle in
the link interface, an include cycle and a src/ -> apps/ include each fail with the file, the include and the rule.

Usage: test_check_include_graph.py PATH/TO/check-include-graph.py
"""
import os
import subprocess
import sys
import tempfile
import unittest

SCRIPT = None


def write(root, rel, text):
    path = os.path.join(root, rel)
    os.makedirs(os.path.dirname(path), exist_ok=True)
    with open(path, 'w', encoding='utf-8') as f:
        f.write(text)


def folder(root, name, links=(), includes=()):
    """src/<name>/ with a CMakeLists.txt linking `links` (folder names) and one .cpp including `includes`."""
    deps = ' '.join('hapticd_' + d for d in links)
    write(root, f'src/{name}/CMakeLists.txt',
          f'add_library(hapticd_{name} STATIC {name}.cpp)\n'
          + (f'target_link_libraries(hapticd_{name} PUBLIC {deps})\n' if deps else ''))
    write(root, f'src/{name}/{name}.hpp', '#pragma once\n')
    write(root, f'src/{name}/{name}.cpp',
          f'#include "{name}/{name}.hpp"\n' + ''.join(f'#include "{inc}"\n' for inc in includes)
          + '#include <vector>\n#include "hapticopt/parameters.hpp"\n')


def run(root):
    r = subprocess.run([sys.executable, SCRIPT, '--root', root], capture_output=True, text=True, check=False)
    return r.returncode, r.stderr


class CheckIncludeGraph(unittest.TestCase):
    def setUp(self):
        self.tmp = tempfile.TemporaryDirectory(prefix='include_graph_')
        self.root = self.tmp.name
        write(self.root, 'apps/tool/figure.hpp', '#pragma once\n')

    def tearDown(self):
        self.tmp.cleanup()

    def test_allowed_tree_passes(self):
        folder(self.root, 'common')
        folder(self.root, 'scene', links=['common'], includes=['common/common.hpp'])
        folder(self.root, 'daemon', links=['common', 'scene'], includes=['scene/scene.hpp', 'common/common.hpp'])
        code, err = run(self.root)
        self.assertEqual(code, 0, err)

    def test_include_outside_the_link_interface_fails(self):
        folder(self.root, 'common')
        folder(self.root, 'scene', links=['common'], includes=['common/common.hpp'])
        folder(self.root, 'daemon', links=['common'], includes=['scene/scene.hpp'])
        code, err = run(self.root)
        self.assertEqual(code, 1, err)
        self.assertIn('src/daemon/daemon.cpp: #include "scene/scene.hpp": src/daemon/ may not depend on src/scene/', err)
        self.assertIn('does not link hapticd_scene in src/daemon/CMakeLists.txt', err)

    def test_cycle_in_the_link_interface_fails(self):
        folder(self.root, 'config', links=['devices'])
        folder(self.root, 'devices', links=['config'])
        code, err = run(self.root)
        self.assertEqual(code, 1, err)
        self.assertIn('cycle between folders in the CMake link interface: config -> devices -> config', err)

    def test_include_cycle_fails(self):
        folder(self.root, 'config', links=['devices'], includes=['devices/devices.hpp'])
        folder(self.root, 'devices', includes=['config/config.hpp'])
        code, err = run(self.root)
        self.assertEqual(code, 1, err)
        self.assertIn('src/devices/devices.cpp: #include "config/config.hpp": src/devices/ may not depend on src/config/',
                      err)
        self.assertIn('cycle between folders in the includes: config -> devices -> config', err)

    def test_include_of_apps_fails(self):
        folder(self.root, 'experiment', includes=['figure.hpp'])
        folder(self.root, 'daemon', includes=['apps/tool/figure.hpp'])
        code, err = run(self.root)
        self.assertEqual(code, 1, err)
        self.assertIn('src/experiment/experiment.cpp: #include "figure.hpp": src/ must not depend on apps/', err)
        self.assertIn('src/daemon/daemon.cpp: #include "apps/tool/figure.hpp": src/ must not depend on apps/', err)

    def test_folder_without_target_fails(self):
        folder(self.root, 'common')
        write(self.root, 'src/loose/loose.cpp', '#include "common/common.hpp"\n')
        code, err = run(self.root)
        self.assertEqual(code, 1, err)
        self.assertIn('src/loose/: no CMakeLists.txt', err)


if __name__ == '__main__':
    if len(sys.argv) < 2:
        sys.exit(__doc__)
    SCRIPT = sys.argv.pop(1)
    unittest.main()
