#!/usr/bin/env python3
# SPDX-License-Identifier: Apache-2.0
"""Records a session with a 100 000-triangle mesh (the 400 x 125 solid torus of measure-mesh-upload.py, 50 000
vertices) and replays it (docs/recording.md, "Meshes"): `hapticd --serve --record` at the real 1 kHz rate (real-time
mode: the recorder's non-blocking path) on the 3-axis simulated device, started by the first commit; a client
uploads the torus, adds it beside the resting handle for 2 s, leaves; then `hapticd --replay` under /usr/bin/time.
Prints the file's size, what its mesh record takes, the records dropped (the end record), the loop's largest
wake-up latency while the mesh was written (the tick records), and the replay's time and memory.

    PYTHONPATH=python/src scripts/measure-mesh-recording.py build/release/apps/hapticd/hapticd [--lockstep]
"""
import os
import pathlib
import subprocess
import sys
import tempfile
import time

import hapticd_client as hc
from hapticd_client import recording

hapticd = sys.argv[1]
lockstep = "--lockstep" in sys.argv[2:]
repository = pathlib.Path(__file__).resolve().parents[1]
directory = pathlib.Path(tempfile.mkdtemp(prefix="hapticd-mesh-recording-"))
sock, rec_path = str(directory / "hapticd.sock"), str(directory / "mesh.rec")
args = [hapticd, "--config", "", "--device", str(repository / "tests/server/sim3.toml"), "--no-walls", "--rt-priority",
        "0", "--mlock", "false", "--watchdog-overruns", "1000000", "--watchdog-stall-periods", "1000000", "--serve",
        "--serve-socket", sock, "--serve-shm", f"/hapticd-measure-mesh-rec-{os.getpid()}", "--serve-wait-commit",
        "--record", rec_path] + (["--lockstep"] if lockstep else [])
daemon = subprocess.Popen(args, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
for _ in range(400):
    if os.path.exists(sock):
        break
    time.sleep(0.05)
v, t = hc.torus(0.03, 0.01, 400, 125)
with hc.Client.connect(socket_path=sock, client="measure", timeout_s=30) as c:
    mesh_id = c.upload_mesh(v, t, solid=True, build_timeout_s=30)
    c.add(hc.mesh(mesh_id=mesh_id, position=(0.0, 0.05, 0.0), K=2000.0, B=2.0))
    time.sleep(2.0)
    c.bye()
time.sleep(0.5)
daemon.terminate()
out, _ = daemon.communicate(timeout=60)
assert daemon.returncode == 0, out
size = os.path.getsize(rec_path)
r = recording.load(rec_path)
m = r.meshes[mesh_id]
mesh_bytes = 128 * (1 + -(-len(m.vertices) // 5) + -(-len(m.triangles) // 10))
before = [b.tick for b in r.batches]
first = before[0] if before else 0
window = r.ticks["wake_latency_ns"][first:first + 100]
print(f"{len(m.triangles)} triangles, {len(m.vertices)} vertices: file {size} bytes for {len(r.ticks)} ticks and "
      f"{len(r.batches)} batches; its mesh record {mesh_bytes} bytes; dropped ticks {r.end['dropped_ticks']}, batches "
      f"{r.end['dropped_batches']}; largest wake-up latency in the 100 ticks from the add {window.max() / 1e3:.0f} us "
      f"(whole run {r.ticks['wake_latency_ns'].max() / 1e3:.0f} us)")
timed = subprocess.run(["/usr/bin/time", "-f", "%e s %M KB", hapticd, "--replay", rec_path, "--quiet"],
                       capture_output=True, text=True)
print(f"replay: exit {timed.returncode}, {timed.stdout.strip()} ({timed.stderr.strip().splitlines()[-1]})")
