#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# The whole test suite, ROUNDS times in a row, with two busy loops running beside it: the check that no test
# depends on an idle machine. Each round runs what CI's test stages run, on trees built beforehand (the release
# preset, scripts/sanitize.sh's asan and tsan trees): the release ctest, the Python package's and the ROS 2 node's
# pytest, and scripts/sanitize.sh all (its configure and build find nothing to do in a built tree; then the
# ASan + UBSan ctest and the TSan ctest). The loops are two shell processes spinning at normal priority, as many as
# the machine's cores on the 2-core CI machine; they are stopped when the script exits, passed, failed or
# interrupted. The first failing stage ends the run (exit status non-zero); the table of every stage's wall and CPU
# seconds is printed at the end (scripts/stage-times.sh).
# Usage: scripts/loaded-suite.sh [ROUNDS]   (default 3; build the trees first: cmake --build --preset release,
#        scripts/sanitize.sh all)
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."
rounds="${1:-3}"
if ! [[ "$rounds" =~ ^[1-9][0-9]*$ ]]; then
  echo "loaded-suite: ROUNDS must be a whole number >= 1, got '$rounds'" >&2
  exit 2
fi
for tree in build/release build/asan build/tsan; do
  if [[ ! -f "$tree/CTestTestfile.cmake" ]]; then
    echo "loaded-suite: $tree is not a built tree: build the release preset and run scripts/sanitize.sh all first" >&2
    exit 2
  fi
done
# shellcheck source=scripts/stage-times.sh
source scripts/stage-times.sh
stage_times_owner

spin() { while :; do :; done; }
busy=()
stop_busy() {
  if ((${#busy[@]})); then kill "${busy[@]}" 2>/dev/null || true; fi
  busy=()
}
# On exit: the loops first, then the stage table (stage_times_owner's EXIT trap, replaced here, called last so the
# script's exit status is the table's). set +e: under set -e the `(exit N)` that hands the status on would end the
# trap before the table.
on_exit() {
  local status=$?
  set +e
  stop_busy
  (exit "$status")
  _stage_print_table
}
trap on_exit EXIT
trap 'exit 130' INT TERM
spin &
busy+=("$!")
spin &
busy+=("$!")
echo "loaded-suite: busy loops ${busy[*]} beside $rounds round(s); load $(cut -d' ' -f1-3 /proc/loadavg)"

export HAPTICD_REQUIRE_SSHD="${HAPTICD_REQUIRE_SSHD:-1}"
for ((round = 1; round <= rounds; ++round)); do
  stage "round $round: release ctest" ctest --preset release --output-on-failure -j2
  stage "round $round: Python package pytest" \
    env HAPTICOPT_CLI="$PWD/build/release/apps/hapticopt/hapticopt" scripts/test-python.sh
  stage "round $round: ROS 2 node pytest" scripts/test-ros.sh
  # Its configure, build and ctest stages join this table under its own names (not wrapped in a stage of this
  # script's, which would count them twice in the total).
  echo "loaded-suite: round $round: scripts/sanitize.sh all"
  scripts/sanitize.sh all
  echo "loaded-suite: round $round of $rounds passed ($(date +%H:%M:%S), load $(cut -d' ' -f1-3 /proc/loadavg))"
done
echo "loaded-suite: all $rounds round(s) passed beside two busy loops"
