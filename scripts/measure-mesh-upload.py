#!/usr/bin/env python3
# SPDX-License-Identifier: Apache-2.0
"""Times a 100 000-triangle mesh upload (a 400 x 125 torus, solid) against a running `hapticd --serve` on a 3-axis
device: the chunks, mesh_end's reply, mesh_end -> ready (validation and hierarchy on the daemon's mesh worker), and
the slowest heartbeat of a second session meanwhile (docs/protocol.md, section 4a).

    PYTHONPATH=python/src scripts/measure-mesh-upload.py SOCKET
"""
import sys
import time

import hapticd_client as hc
sock = sys.argv[1]
c = hc.Client.connect(socket_path=sock, client="measure", timeout_s=30)
other = hc.Client.connect(socket_path=sock, client="other", timeout_s=30)
v, t = hc.torus(0.03, 0.01, 400, 125)
mid = int(c.request("mesh_begin", vertices=len(v), triangles=len(t), mode="solid")["mesh"])
t0 = time.monotonic()
for at in range(0, len(v), 500):
    c.request("mesh_chunk", mesh=mid, first=at, vertices=[x for row in v[at:at + 500] for x in row])
for at in range(0, len(t), 1000):
    c.request("mesh_chunk", mesh=mid, first=at, triangles=[i for row in t[at:at + 1000] for i in row])
t1 = time.monotonic()
c.request("mesh_end", mesh=mid)
t2 = time.monotonic()
worst = 0.0
while c.request("mesh_status", mesh=mid)["state"] == "building":
    h0 = time.monotonic(); other.heartbeat(); worst = max(worst, time.monotonic() - h0)
t3 = time.monotonic()
print(f"{len(t)} triangles: chunks {t1 - t0:.3f} s, mesh_end reply {1e3 * (t2 - t1):.1f} ms, ready {1e3 * (t3 - t2):.0f} ms "
      f"after mesh_end; another session's slowest heartbeat meanwhile {1e3 * worst:.1f} ms")
