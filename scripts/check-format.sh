#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# Every tracked C++ file is formatted as .clang-format says (clang-format 14, from scripts/install-deps.sh).
# Usage: scripts/check-format.sh [--fix]   (--fix rewrites the files in place; without it: exit 1 and the
# first differences when a file is not formatted).
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."
format=$(command -v clang-format-14 || command -v clang-format || true)
if [[ -z "$format" ]]; then
  echo "check-format: clang-format not found (Debian: apt-get install clang-format)" >&2
  exit 2
fi
if git rev-parse --is-inside-work-tree >/dev/null 2>&1; then
  mapfile -t files < <(git ls-files '*.cpp' '*.hpp' '*.h' '*.cc' | grep -v '^tests/fuzz/corpus')
else
  mapfile -t files < <(find include src apps tests python -name '*.cpp' -o -name '*.hpp' -o -name '*.h' | grep -v 'corpus')
fi
if [[ "${1:-}" == --fix ]]; then
  "$format" -i --style=file "${files[@]}"
  exit 0
fi
bad=0
for f in "${files[@]}"; do
  if ! diff -u "$f" <("$format" --style=file "$f") > /tmp/check-format.$$ 2>&1; then
    echo "check-format: $f is not formatted (scripts/check-format.sh --fix):"
    head -20 /tmp/check-format.$$
    bad=1
  fi
done
rm -f /tmp/check-format.$$
exit $bad
