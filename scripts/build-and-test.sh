#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# The whole test suite (what CI runs through .ci/run):
#   1. install what is missing (scripts/install-deps.sh); lint (format, include graph, cited paths, file sizes) in seconds;
#   2. configure + build the `release` preset (build/release) and run ctest: every label
#      (core, paper, packaging, daemon, devices, identification, beyond, plots, stress, fuzz);
#   2a. the Debian packages from that tree: lintian, installed and run with the checkout hidden, purged
#       (scripts/test-debian-packages.sh, as root);
#   2b. the Python package: pip install ./python into build/python-venv, pytest python/tests (scripts/test-python.sh);
#   2c. the ROS 2 node: pip install "./python[ros]" into build/ros-venv, pytest python/ros_tests (scripts/test-ros.sh);
#   3. the same tests under ASan + UBSan, and the daemon's threaded tests under TSan (scripts/sanitize.sh);
#   4. each libFuzzer target for a bounded time over its corpus (scripts/fuzz.sh, clang).
# `--quick` stops after step 2c. Exit status: non-zero as soon as a step fails.
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."
quick=0
[[ "${1:-}" == --quick ]] && quick=1

step() { printf '\n=== build-and-test: %s (%s) ===\n' "$1" "$(date +%H:%M:%S)"; }

step "dependencies"
scripts/install-deps.sh

# A compiler cache outside the checkout (ccache's own directory, ~/.cache/ccache): a later run on the same machine
# compiles only what changed, in any clone (paths below the checkout are hashed relative to it; the build directory
# is not hashed). CMake takes the launcher from the environment for every tree this script and the sanitizer and
# fuzzing scripts configure. A machine without ccache builds as before.
if command -v ccache >/dev/null 2>&1; then
  export CCACHE_BASEDIR="$PWD" CCACHE_NOHASHDIR=1 CCACHE_MAXSIZE="${CCACHE_MAXSIZE:-10G}"
  export CMAKE_CXX_COMPILER_LAUNCHER=ccache CMAKE_C_COMPILER_LAUNCHER=ccache
  ccache --zero-stats >/dev/null
fi

# Lint first, so a style, layout or citation slip fails in seconds, before any compilation (the same checks run again
# as ctest's layout.* tests).
step "lint (format, include graph, cited paths, file sizes)"
scripts/check-format.sh
python3 scripts/check-include-graph.py --root .
python3 scripts/check-file-sizes.py --root .
python3 scripts/check-cited-paths.py .

step "release build"
cmake --preset release
cmake --build --preset release -j"$(nproc)"

step "ctest (release)"
ctest --preset release --output-on-failure -j2

step "Debian packages (cpack, lintian, install, run with the checkout hidden, purge)"
if [[ $(id -u) -eq 0 ]]; then
  scripts/test-debian-packages.sh build/release
else
  sudo scripts/test-debian-packages.sh build/release
fi

step "python package (pip install ./python, pytest python/tests)"
HAPTICOPT_CLI="$PWD/build/release/apps/hapticopt/hapticopt" scripts/test-python.sh

step "ROS 2 node (pip install ./python[ros] into its own venv, pytest python/ros_tests)"
scripts/test-ros.sh

if [[ $quick -eq 1 ]]; then
  exit 0
fi

step "sanitizers"
scripts/sanitize.sh all

step "fuzzing (bounded)"
scripts/fuzz.sh "${HAPTICOPT_FUZZ_SECONDS:-15}"

if command -v ccache >/dev/null 2>&1; then ccache --show-stats | grep -E 'Hits|Misses|Cache size' || true; fi
step "all passed"
