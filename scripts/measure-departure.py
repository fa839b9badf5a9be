#!/usr/bin/env python3
# SPDX-License-Identifier: Apache-2.0
"""Times the server's answers while a departure is planned (docs/protocol.md, section 5, "A client that leaves").
Session A commits a plane at 45 degrees to the x and y axes (K 100 N/m, B 1 N s/m), then closes its socket; session B,
subscribed to the state at 100 Hz, sends `status` every 50 ms for DURATION seconds from the close. Prints B's longest
status round trip and longest gap between state messages; the daemon's log says how long the plan took ("departure
planned in ... ms"). The figure of docs/protocol.md: the simulated Falcon with its config wall,

    hapticd --serve --config "" --device falcon --simulate --stiffness 180 --damping 7.35 --serve-socket SOCKET &
    scripts/measure-departure.py SOCKET [DURATION]
"""
import json
import select
import socket
import sys
import time

path = sys.argv[1]
duration = float(sys.argv[2]) if len(sys.argv) > 2 else 15.0


def connect():
    s = socket.socket(socket.AF_UNIX, socket.SOCK_SEQPACKET)
    s.connect(path)
    s.send(json.dumps({"type": "hello", "protocol": 1, "client": "measure-departure"}).encode())
    json.loads(s.recv(70000))
    return s


a, b = connect(), connect()
r = 0.7071067811865476
plane = {"kind": "plane", "normal": [r, r, 0], "offset": 0.06, "mode": "unilateral", "gains": {"K": 100, "B": 1}}
t0 = time.monotonic()
a.send(json.dumps({"type": "commit", "id": 1, "ops": [{"op": "add", "object": plane}]}).encode())
reply = json.loads(a.recv(70000))
print(f"commit: {reply.get('type')} in {time.monotonic() - t0:.1f} s")
b.send(json.dumps({"type": "subscribe", "id": 1, "rate_hz": 100}).encode())
time.sleep(0.5)
t0 = time.monotonic()
a.close()
last_state, max_gap, max_rtt, replies, pending, next_id = None, 0.0, 0.0, 0, None, 10
while time.monotonic() - t0 < duration:
    if pending is None:
        next_id += 1
        b.send(json.dumps({"type": "status", "id": next_id}).encode())
        pending = (next_id, time.monotonic())
    ready, _, _ = select.select([b], [], [], 0.05)
    if not ready:
        continue
    m = json.loads(b.recv(70000))
    now = time.monotonic()
    if m.get("type") == "state":
        if last_state is not None:
            max_gap = max(max_gap, now - last_state)
        last_state = now
    elif m.get("id") == pending[0]:
        max_rtt = max(max_rtt, now - pending[1])
        replies += 1
        pending = None
        time.sleep(0.05)
print(f"after A left: {replies} status replies to B, longest round trip {max_rtt * 1e3:.1f} ms, "
      f"longest gap between state messages {max_gap * 1e3:.1f} ms")
