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
# `--quick` stops after step 2c. Exit status: non-zero as soon as a step fails. At the end, passed or not, a table
# of each stage's wall and CPU seconds (scripts/stage-times.sh; sanitize.sh adds its build and test stages).
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."
quick=0
[[ "${1:-}" == --quick ]] && quick=1
# shellcheck source=scripts/stage-times.sh
source scripts/stage-times.sh
stage_times_owner

stage "dependencies" scripts/install-deps.sh

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
# A stage's commands are chained with && (bash ignores set -e inside a command whose status is tested).
lint() {
  scripts/check-format.sh && python3 scripts/check-include-graph.py --root . && python3 scripts/check-file-sizes.py --root . &&
    python3 scripts/check-cited-paths.py .
}
stage "lint (format, include graph, file sizes, cited paths)" lint

stage "release: configure" cmake --preset release
stage "release: build" cmake --build --preset release -j"$(nproc)"
stage "release: ctest" ctest --preset release --output-on-failure -j2

sudo_unless_root=()
[[ $(id -u) -eq 0 ]] || sudo_unless_root=(sudo)
stage "Debian packages (cpack, lintian, install, run, purge)" \
  "${sudo_unless_root[@]}" scripts/test-debian-packages.sh build/release

stage "Python package (pip install ./python, pytest)" \
  env HAPTICOPT_CLI="$PWD/build/release/apps/hapticopt/hapticopt" scripts/test-python.sh

stage "ROS 2 node (pip install ./python[ros], pytest)" scripts/test-ros.sh

if [[ $quick -eq 0 ]]; then
  scripts/sanitize.sh all
  stage "fuzzing (bounded)" scripts/fuzz.sh "${HAPTICOPT_FUZZ_SECONDS:-15}"
fi

if command -v ccache >/dev/null 2>&1; then ccache --show-stats | grep -E 'Hits|Misses|Cache size' || true; fi
printf '\n=== build-and-test: all passed (%s) ===\n' "$(date +%H:%M:%S)"
