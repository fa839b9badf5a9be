#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# Sourced by the scope's figure scripts (scope-figure.sh, scope-mesh-figure.sh): `start_figure_daemon NAME` starts
# hapticd --serve on the 3-axis simulated device at normal priority, with its socket in a temporary directory ($work)
# and the state segment /hapticd-NAME-<pid> ($shm), waits for the socket, puts python/src on PYTHONPATH and arranges
# that on exit the scene's client ($scene, when set) is killed, the daemon stopped by SIGTERM and $work removed.
# Uses $HAPTICD_BINARY (default build/release/apps/hapticd/hapticd) and $HAPTICOPT_PYTHON (default /usr/bin/python3,
# set as $python).
start_figure_daemon() {
  hapticd=${HAPTICD_BINARY:-build/release/apps/hapticd/hapticd}
  python=${HAPTICOPT_PYTHON:-/usr/bin/python3}
  work=$(mktemp -d)
  shm=/hapticd-$1-$$
  "$hapticd" --config "" --no-walls --device sim3 --rt-priority 0 --serve --serve-socket "$work/hapticd.sock" \
             --serve-shm "$shm" >"$work/hapticd.log" 2>&1 &
  daemon=$!
  scene=""
  trap stop_figure_daemon EXIT
  for _ in $(seq 100); do [[ -S "$work/hapticd.sock" ]] && break; sleep 0.1; done
  export PYTHONPATH=$PWD/python/src${PYTHONPATH:+:$PYTHONPATH}
}
stop_figure_daemon() {
  [[ -n "$scene" ]] && kill "$scene" 2>/dev/null || true
  kill -TERM "$daemon" 2>/dev/null && wait "$daemon" || true
  rm -rf "$work"
}
