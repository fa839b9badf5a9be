#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# Renders docs/figures/scope.png (docs/scope.md) with hapticd-scope from a real run: hapticd --serve on the
# 3-axis simulated device (the simulated hand at rest in the workspace centre) at its real 1 kHz rate, a
# Python client changing the scene on a timetable, the scope headless over the last 7 s.
#   t = 1.0 s  plane 1: normal -x, surface at x = -5 mm, CE2 (appears around the handle, pushes it out)
#   t = 2.5 s  field 2: 1 N towards +y within 10 cm of the centre (the hand's k_H = 200 N/m yields 5 mm)
#   t = 4.0 s  plane 3: normal -y, surface at y = +3 mm, K = 2000 N/m, B = 10 N s/m (the handle is behind it)
#   t = 5.5 s  plane 1 removed (the hand pulls the handle back to x = 0)
# Usage: scripts/scope-figure.sh [OUT.png] (default docs/figures/scope.png); HAPTICD_BINARY as for the tests.
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."
out=${1:-docs/figures/scope.png}
# shellcheck source=scripts/figure-daemon.sh
source scripts/figure-daemon.sh
start_figure_daemon scope-figure
"$python" - "$work/hapticd.sock" <<'PY' &
import sys, time
from hapticd_client import Client, field, plane
with Client.connect(socket_path=sys.argv[1], client="scope-figure") as c:
    t0 = time.monotonic()
    def at(t):
        time.sleep(max(0.0, t0 + t - time.monotonic()))
    at(1.0); wall_x = c.add(plane(normal=(-1, 0, 0), offset=0.005, criterion="CE2"))
    at(2.5); c.add(field(center=(0, 0, 0), radius=0.1, force=(0, 1.0, 0)))
    at(4.0); c.add(plane(normal=(0, -1, 0), offset=-0.003, K=2000, B=10))
    at(5.5); c.remove(wall_x)
    at(60.0)
PY
scene=$!
"$python" -m hapticd_client.scope --shm "$shm" --out "$out" --data "$work/scope.npz" --window 7 --duration 7 \
          --every 10 --size 1200x800
"$python" - "$work/scope.npz" <<'PY'
import sys, numpy as np
d = np.load(sys.argv[1])
print(f"scope-figure: {len(d['tick'])} samples, ticks {d['tick'][0]}..{d['tick'][-1]}, objects {list(d['object_ids'])}, "
      f"in contact in {d['in_contact'].sum(axis=0).tolist()} samples")
PY
