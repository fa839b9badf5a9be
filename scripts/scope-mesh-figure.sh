#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# Renders docs/figures/scope-mesh.png (docs/scope.md, "Mesh objects") with hapticd-scope from a real run:
# hapticd --serve on the 3-axis simulated device (the simulated hand, k_H = 200 N/m, at rest in the workspace
# centre) at its real 1 kHz rate, a Python client changing the scene on a timetable, the scope headless over the
# last 7 s. The mesh is soft (K = 200 N/m, B = 2 N s/m) so that the proxy and the handle part by millimetres.
#   t = 1.0 s  mesh 1: the box [-2 cm, 2 cm]^3 centred at x = -22 mm (its +x face at x = -2 mm), solid
#   t = 1.5 s  field 2: 2 N towards -x within 10 cm of the centre (the handle goes through the face's plane to
#              x = -(2 + 0.4) / 400 m = -6 mm: the hand and the mesh share it; the proxy stays at -2 mm)
#   t = 3.0 s  field 3: 1 N towards +y (the handle slides 5 mm along the face; the frictionless proxy with it)
#   t = 4.5 s  field 2 removed (the hand pulls the handle back out to x = 0; the proxy, free, is on it again)
#   t = 5.5 s  field 4: field 2 again (pressed to the end: the mesh's row names the penetration, 4 mm)
# Usage: scripts/scope-mesh-figure.sh [OUT.png] (default docs/figures/scope-mesh.png); HAPTICD_BINARY as for the tests.
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."
out=${1:-docs/figures/scope-mesh.png}
# shellcheck source=scripts/figure-daemon.sh
source scripts/figure-daemon.sh
start_figure_daemon scope-mesh-figure
"$python" - "$work/hapticd.sock" <<'PY' &
import sys, time
from hapticd_client import Client, box, field, mesh
with Client.connect(socket_path=sys.argv[1], client="scope-mesh-figure") as c:
    t0 = time.monotonic()
    def at(t):
        time.sleep(max(0.0, t0 + t - time.monotonic()))
    at(1.0); c.add(mesh(*box((0.02, 0.02, 0.02)), position=(-0.022, 0.0, 0.0), K=200, B=2))
    at(1.5); push = c.add(field(center=(0, 0, 0), radius=0.1, force=(-2.0, 0, 0)))
    at(3.0); c.add(field(center=(0, 0, 0), radius=0.1, force=(0, 1.0, 0)))
    at(4.5); c.remove(push)
    at(5.5); c.add(field(center=(0, 0, 0), radius=0.1, force=(-2.0, 0, 0)))
    at(60.0)
PY
scene=$!
"$python" -m hapticd_client.scope --shm "$shm" --out "$out" --data "$work/scope.npz" --window 7 --duration 7 \
          --every 10 --size 1200x800
"$python" - "$work/scope.npz" <<'PY'
import sys, numpy as np
d = np.load(sys.argv[1])
k = [i for i in range(len(d["object_ids"])) if np.isfinite(d["proxy"][:, i, 0]).any()][0]
pressed = d["proxy_constraints"][:, k] > 0
print(f"scope-mesh-figure: {len(d['tick'])} samples, ticks {d['tick'][0]}..{d['tick'][-1]}, objects "
      f"{list(d['object_ids'])}, mesh {d['object_ids'][k]} pressed in {pressed.sum()} samples, proxy x "
      f"{1e3 * d['proxy'][pressed, k, 0].min():.4f}..{1e3 * d['proxy'][pressed, k, 0].max():.4f} mm, "
      f"largest |proxy - handle| {1e3 * np.nanmax(d['penetration'][:, k]):.3f} mm, last "
      f"{1e3 * d['penetration'][-1, k]:.3f} mm")
PY
