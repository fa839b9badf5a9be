#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# The hapticopt Python package's test step (part of scripts/build-and-test.sh, after the release ctest):
#   1. a venv from Debian's python3 with the system site packages (numpy, scipy, matplotlib, pytest
#      from apt: scripts/install-deps.sh);
#   2. pip install ./python: an isolated PEP 517 build whose backend, scikit-build-core, pip fetches
#      from PyPI; CMake, Ninja, pybind11 and Eigen are Debian's;
#   3. pytest python/tests against the C++ CLI (default build/release/apps/hapticopt/hapticopt).
# Exit status: non-zero when any step fails, including pytest's 5 (no test collected).
# Environment: HAPTICOPT_PYTHON (default /usr/bin/python3), HAPTICOPT_PY_VENV (default build/python-venv),
# HAPTICOPT_CLI, HAPTICD_BINARY.
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."
python=${HAPTICOPT_PYTHON:-/usr/bin/python3}
venv=${HAPTICOPT_PY_VENV:-build/python-venv}
export HAPTICOPT_CLI=${HAPTICOPT_CLI:-$PWD/build/release/apps/hapticopt/hapticopt}
# The hapticd_client tests start this daemon (they skip only when it is missing: it must exist here).
export HAPTICD_BINARY=${HAPTICD_BINARY:-$PWD/build/release/apps/hapticd/hapticd}
if [[ ! -x "$HAPTICD_BINARY" || ! -x "$HAPTICOPT_CLI" ]]; then
  echo "test-python: $HAPTICD_BINARY or $HAPTICOPT_CLI is missing: build the release preset first" >&2
  exit 1
fi

if [[ ! -x "$venv/bin/python" ]]; then
  "$python" -m venv --system-site-packages "$venv"
fi
if command -v ccache >/dev/null 2>&1; then
  export CMAKE_ARGS="${CMAKE_ARGS:-} -DCMAKE_CXX_COMPILER_LAUNCHER=ccache"
fi
start=$SECONDS
"$venv/bin/python" -m pip install --quiet --disable-pip-version-check ./python
echo "test-python: pip install ./python took $((SECONDS - start)) s"

export PYTHONDONTWRITEBYTECODE=1 MPLBACKEND=Agg
status=0
"$venv/bin/python" -m pytest -q -p no:cacheprovider python/tests || status=$?
if [[ $status -eq 5 ]]; then
  echo "test-python: pytest collected no tests" >&2
fi
exit "$status"
