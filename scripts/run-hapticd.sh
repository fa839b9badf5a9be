#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# Install what is missing, build the daemon (release preset, build/release) and run it on the
# simulated device for 3 s with the CE2-optimal wall. Extra arguments are passed on to hapticd
# (e.g. `--criterion CE1+OV`, `--duration 10`, `--trace wall.csv`).
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."

scripts/install-deps.sh

cmake --preset release
cmake --build --preset release -j"$(nproc)" --target hapticd

exec build/release/apps/hapticd/hapticd --criterion CE2 --duration 3 "$@"
