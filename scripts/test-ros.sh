#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# The ROS 2 node's test step (part of scripts/build-and-test.sh, after scripts/test-python.sh):
#   1. a venv of its own from Debian's python3, WITHOUT the system site packages: the ROS 2 wheels bring numpy 2,
#      which breaks Debian's scipy and matplotlib ("numpy.core.multiarray failed to import") in the venv of
#      scripts/test-python.sh; here numpy 2 is the only numpy;
#   2. pip install "./python[ros]" pytest: the distribution (its extension built with ccache) with rclpy and the
#      message packages as PyPI wheels (docs/ros.md, "Installing": what it costs);
#   3. pytest python/ros_tests against a hapticd the tests start (default build/release/apps/hapticd/hapticd),
#      on a ROS_DOMAIN_ID of this run's own and discovery on the loopback only.
# Exit status: non-zero when any step fails, including pytest's 5 (no test collected).
# Environment: HAPTICOPT_PYTHON (default /usr/bin/python3), HAPTICD_ROS_VENV (default build/ros-venv),
# HAPTICD_BINARY, ROS_DOMAIN_ID (default 1 + this shell's pid mod 100).
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."
python=${HAPTICOPT_PYTHON:-/usr/bin/python3}
venv=${HAPTICD_ROS_VENV:-build/ros-venv}
export HAPTICD_BINARY=${HAPTICD_BINARY:-$PWD/build/release/apps/hapticd/hapticd}
if [[ ! -x "$HAPTICD_BINARY" ]]; then
  echo "test-ros: $HAPTICD_BINARY is missing: build the release preset first" >&2
  exit 1
fi

if [[ ! -x "$venv/bin/python" ]]; then
  "$python" -m venv "$venv"
fi
if command -v ccache >/dev/null 2>&1; then
  export CMAKE_ARGS="${CMAKE_ARGS:-} -DCMAKE_CXX_COMPILER_LAUNCHER=ccache"
fi
start=$SECONDS
"$venv/bin/python" -m pip install --quiet --disable-pip-version-check "./python[ros]" "pytest>=7"
echo "test-ros: pip install ./python[ros] pytest took $((SECONDS - start)) s"

export ROS_DOMAIN_ID=${ROS_DOMAIN_ID:-$((1 + $$ % 100))}
export ROS_LOCALHOST_ONLY=1 ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST
export PYTHONDONTWRITEBYTECODE=1
echo "test-ros: ROS_DOMAIN_ID=$ROS_DOMAIN_ID, discovery on the loopback only"
status=0
# The tests import the installed packages (PYTHONPATH is not set).
"$venv/bin/python" -m pytest -q -p no:cacheprovider python/ros_tests || status=$?
if [[ $status -eq 5 ]]; then
  echo "test-ros: pytest collected no tests" >&2
fi
exit "$status"
