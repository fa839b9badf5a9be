#!/usr/bin/env python3
# SPDX-License-Identifier: Apache-2.0
"""State rate and command latency of the Python client over the three ways to reach hapticd (docs/clients.md,
"Remote use: measured"): the SOCK_SEQPACKET control socket, the stream socket, and the stream socket through
an OpenSSH Unix-socket forward on the loopback (a real sshd started here, python/tests/ssh_support.py).

For each: subscribe at 1000 Hz and count the `state` messages received over DURATION s (messages/s, and the
`dropped` count the last one carries); then N `heartbeat` requests one after another, each round trip timed
(time.perf_counter around Client.heartbeat: send, the server's reply, the client's receive and JSON decode):
median and 99th percentile.

Usage: scripts/measure-remote.py [--hapticd build/release/apps/hapticd/hapticd] [--duration 5] [--requests 1000]
"""
from __future__ import annotations

import argparse
import os
import pathlib
import signal
import statistics
import subprocess
import sys
import tempfile
import time

ROOT = pathlib.Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "python" / "src"))
sys.path.insert(0, str(ROOT / "python" / "tests"))
import hapticd_client as hc  # noqa: E402
from ssh_support import SshServer  # noqa: E402


def measure(path, duration_s, requests):
    with hc.Client.connect(socket_path=path, client="measure-remote", timeout_s=10.0) as c:
        c.subscribe(1000.0)
        c.next_state(5.0)
        count, last = 0, None
        start = time.perf_counter()
        while time.perf_counter() - start < duration_s:
            m = c.next_state(1.0)
            if m is not None:
                count, last = count + 1, m
        elapsed = time.perf_counter() - start
        c.unsubscribe()
        rtts = []
        for _ in range(requests):
            t0 = time.perf_counter()
            c.heartbeat()
            rtts.append(time.perf_counter() - t0)
        rtts.sort()
        return {"transport": "stream" if c.stream else "seqpacket", "rate": count / elapsed,
                "dropped": last["dropped"] if last else None, "median_us": 1e6 * statistics.median(rtts),
                "p99_us": 1e6 * rtts[min(len(rtts) - 1, int(0.99 * len(rtts)))]}


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--hapticd", default=str(ROOT / "build/release/apps/hapticd/hapticd"))
    parser.add_argument("--duration", type=float, default=5.0)
    parser.add_argument("--requests", type=int, default=1000)
    args = parser.parse_args()
    with tempfile.TemporaryDirectory(prefix="hapticd-remote-") as tmp:
        d = pathlib.Path(tmp)
        sock = str(d / "hapticd.sock")
        daemon = subprocess.Popen([args.hapticd, "--config", "", "--no-walls", "--rt-priority", "0",
                                   "--watchdog-overruns", "1000000", "--watchdog-stall-periods", "1000000",
                                   "--serve", "--serve-socket", sock, "--serve-shm", f"/hapticd-measure-{os.getpid()}"],
                                  stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        ssh = None
        try:
            end = time.monotonic() + 20
            while not os.path.exists(sock + ".stream") and time.monotonic() < end:
                time.sleep(0.05)
            time.sleep(0.2)
            ssh = SshServer(d / "ssh")
            forward = str(d / "forward.sock")
            ssh.forward(forward, sock + ".stream")
            print(f"{'way':<34} {'states/s':>9} {'dropped':>8} {'median us':>10} {'p99 us':>8}")
            for name, path in (("control socket (SOCK_SEQPACKET)", sock), ("stream socket", sock + ".stream"),
                               ("ssh -L forward of the stream socket", forward)):
                r = measure(path, args.duration, args.requests)
                print(f"{name:<34} {r['rate']:>9.1f} {r['dropped']!s:>8} {r['median_us']:>10.0f} {r['p99_us']:>8.0f}")
        finally:
            if ssh is not None:
                ssh.close()
            daemon.send_signal(signal.SIGTERM)
            daemon.wait(20)


if __name__ == "__main__":
    main()
