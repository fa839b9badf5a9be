#!/usr/bin/env python3
# SPDX-License-Identifier: Apache-2.0
"""scripts/check-file-sizes.py on small temporary trees (not git checkouts, so every file is scanned): files at
their limits pass; one line over in src/ or include/ fails naming the file, its lines and the limit; files
elsewhere and of other kinds are not limited.

Usage: test_check_file_sizes.py PATH/TO/check-file-sizes.py
"""
import os
import subprocess
import sys
import tempfile
import unittest

SCRIPT = None


def write_lines(root, rel, count):
    path = os.path.join(root, rel)
    os.makedirs(os.path.dirname(path), exist_ok=True)
    with open(path, 'w', encoding='utf-8') as f:
        f.write(''.join(f'// {i}\n' for i in range(count)))


def run(root):
    r = subprocess.run([sys.executable, SCRIPT, '--root', root], capture_output=True, text=True, check=False)
    return r.returncode, r.stdout


class FileSizes(unittest.TestCase):
    def test_files_at_their_limits_pass(self):
        with tempfile.TemporaryDirectory() as root:
            write_lines(root, 'src/scene/a.cpp', 600)
            write_lines(root, 'src/scene/a.hpp', 600)
            write_lines(root, 'include/hapticopt/b.hpp', 800)
            write_lines(root, 'tests/scene/long_test.cpp', 5000)
            write_lines(root, 'src/scene/README.md', 5000)
            self.assertEqual(run(root), (0, ''))

    def test_one_line_over_fails_naming_the_file(self):
        for rel, limit in (('src/scene/a.cpp', 600), ('src/daemon/b.hpp', 600), ('include/hapticopt/c.hpp', 800)):
            with self.subTest(rel=rel), tempfile.TemporaryDirectory() as root:
                write_lines(root, rel, limit + 1)
                code, out = run(root)
                self.assertEqual(code, 1)
                self.assertEqual(out.strip(), f'{rel}: {limit + 1} lines > {limit}')


if __name__ == '__main__':
    SCRIPT = sys.argv.pop(1)
    unittest.main()
