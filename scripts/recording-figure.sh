#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# Renders docs/figures/recording.png (docs/recording.md) from a real recording: hapticd --serve --record on the
# 3-axis simulated device (the simulated hand at rest in the workspace centre) at its real 1 kHz rate for 7 s,
# a Python client changing the scene on the timetable of scripts/scope-figure.sh, then hapticd --replay of the
# file (it must reproduce every force: exit 0) and hapticd-scope --recording headless.
#   t = 1.0 s  plane 1: normal -x, surface at x = -5 mm, CE2
#   t = 2.5 s  field 2: 1 N towards +y within 10 cm of the centre
#   t = 4.0 s  plane 3: normal -y, surface at y = +3 mm, K = 2000 N/m, B = 10 N s/m
#   t = 5.5 s  plane 1 removed
# The client leaves at t = 6.5 s (a departure: its objects ramp out).
# Usage: scripts/recording-figure.sh [OUT.png] (default docs/figures/recording.png); HAPTICD_BINARY as for the tests.
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."
out=${1:-docs/figures/recording.png}
hapticd=${HAPTICD_BINARY:-build/release/apps/hapticd/hapticd}
python=${HAPTICOPT_PYTHON:-/usr/bin/python3}
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
"$hapticd" --config "" --no-walls --device sim3 --rt-priority 0 --mlock false --watchdog-overruns 1000000 \
           --watchdog-stall-periods 1000000 --serve --serve-socket "$work/hapticd.sock" --serve-shm "/hapticd-recording-figure-$$" \
           --duration 7 --record "$work/run.rec" >"$work/hapticd.log" 2>&1 &
daemon=$!
for _ in $(seq 100); do [[ -S "$work/hapticd.sock" ]] && break; sleep 0.1; done
export PYTHONPATH=$PWD/python/src${PYTHONPATH:+:$PYTHONPATH}
"$python" - "$work/hapticd.sock" <<'PY'
import sys, time
from hapticd_client import Client, field, plane
with Client.connect(socket_path=sys.argv[1], client="recording-figure") as c:
    t0 = time.monotonic()
    def at(t):
        time.sleep(max(0.0, t0 + t - time.monotonic()))
    at(1.0); wall_x = c.add(plane(normal=(-1, 0, 0), offset=0.005, criterion="CE2"))
    at(2.5); c.add(field(center=(0, 0, 0), radius=0.1, force=(0, 1.0, 0)))
    at(4.0); c.add(plane(normal=(0, -1, 0), offset=-0.003, K=2000, B=10))
    at(5.5); c.remove(wall_x)
    at(6.5)
PY
wait "$daemon"
grep -E "recorded|warning|error" "$work/hapticd.log" || true
"$hapticd" --replay "$work/run.rec" --quiet
"$python" -m hapticd_client.scope --recording "$work/run.rec" --out "$out" --size 1200x800
"$python" - "$work/run.rec" <<'PY'
import sys
from hapticd_client import recording
r = recording.load(sys.argv[1], verify_checksum=True)
print(f"recording-figure: {len(r.ticks)} ticks, {len(r.batches)} batches "
      f"({', '.join(f'{b.source} at tick {b.tick}' for b in r.batches)}), {r.end['dropped_ticks']} dropped")
PY
