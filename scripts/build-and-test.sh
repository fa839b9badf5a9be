#!/usr/bin/env bash
# Install dependencies, configure + build with the `release` preset
# (build/release) and run the whole test suite.  Exit status = ctest's.
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."

scripts/install-deps.sh

cmake --preset release
cmake --build --preset release -j"$(nproc)"

rc=0
ctest --preset release --output-on-failure -j2 || rc=$?
exit "$rc"
