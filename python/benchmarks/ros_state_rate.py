# SPDX-License-Identifier: Apache-2.0
"""What a ROS 2 subscriber of hapticd-ros receives (docs/ros.md, "Measured"): the rate of ~/pose over a window
and the latency from the tick (the message's stamp: the tick's wake-up time on the system clock) to the
subscriber's callback (its CLOCK_REALTIME at the callback's start).

With ``--hapticd BINARY`` it starts the daemon (paced 1 kHz, simulated device, no walls, SCHED_OTHER) and
``hapticd-ros --rate RATE`` (the console script beside this interpreter) on a socket and segment of its own, and
stops both after; without, it subscribes to a running node's ``--topic``. Prints one JSON line: count, window_s,
rate_hz, latency_ms {median, p99, max}, gap_ms {median, max}, and the node's missed_periods since it started (/diagnostics).

    build/ros-venv/bin/python python/benchmarks/ros_state_rate.py --hapticd build/release/apps/hapticd/hapticd \
        --rate 500 --seconds 10
"""
from __future__ import annotations

import argparse
import json
import os
import pathlib
import signal
import socket
import statistics
import subprocess
import sys
import tempfile
import time


def percentile(values, q):
    ordered = sorted(values)
    return ordered[min(len(ordered) - 1, int(q * len(ordered)))]


def measure(node, topic: str, seconds: float, settle_s: float = 1.0):
    """(stamps_ns, arrivals_ns) of ~/pose messages received during ``seconds`` after ``settle_s``."""
    import rclpy
    from geometry_msgs.msg import PoseStamped
    stamps, arrivals = [], []
    state = {"recording": False}

    def on_pose(msg):
        arrived = time.clock_gettime_ns(time.CLOCK_REALTIME)
        if state["recording"]:
            stamps.append(msg.header.stamp.sec * 1_000_000_000 + msg.header.stamp.nanosec)
            arrivals.append(arrived)

    subscription = node.create_subscription(PoseStamped, topic, on_pose, 100)
    end = time.monotonic() + settle_s
    while time.monotonic() < end:
        rclpy.spin_once(node, timeout_sec=0.01)
    state["recording"] = True
    start = time.monotonic()
    while time.monotonic() - start < seconds:
        rclpy.spin_once(node, timeout_sec=0.01)
    window = time.monotonic() - start
    node.destroy_subscription(subscription)
    return stamps, arrivals, window


def summary(stamps, arrivals, window):
    latencies = [(a - s) * 1e-6 for s, a in zip(stamps, arrivals)]
    gaps = [(b - a) * 1e-6 for a, b in zip(stamps, stamps[1:])]
    return {"count": len(stamps), "window_s": round(window, 3), "rate_hz": round(len(stamps) / window, 1),
            "latency_ms": {"median": round(statistics.median(latencies), 3), "p99": round(percentile(latencies, 0.99), 3),
                           "max": round(max(latencies), 3)} if latencies else None,
            "gap_ms": {"median": round(statistics.median(gaps), 3), "max": round(max(gaps), 3)} if gaps else None}


def _start(args, directory):
    """hapticd and hapticd-ros; returns their processes (the node's namespace: /hapticd_probe)."""
    sock = os.path.join(directory, "hapticd.sock")
    daemon = subprocess.Popen([args.hapticd, "--config", "", "--no-walls", "--rt-priority", "0", "--watchdog-overruns",
                               "1000000", "--watchdog-stall-periods", "1000000", "--serve", "--serve-socket", sock,
                               "--serve-shm", f"/hapticd-ros-probe-{os.getpid()}"],
                              stdout=subprocess.DEVNULL, stderr=subprocess.STDOUT)
    end = time.monotonic() + 20
    while time.monotonic() < end:
        with socket.socket(socket.AF_UNIX, socket.SOCK_SEQPACKET) as s:
            try:
                s.connect(sock)
                break
            except OSError:
                time.sleep(0.05)
    script = pathlib.Path(sys.executable).with_name("hapticd-ros")
    node = subprocess.Popen([str(script), "--socket", sock, "--namespace", "/hapticd_probe", "--rate", str(args.rate)],
                            stdout=subprocess.DEVNULL, stderr=subprocess.STDOUT)
    return daemon, node


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--topic", default="/hapticd/pose")
    parser.add_argument("--seconds", type=float, default=10.0)
    parser.add_argument("--hapticd", default=None, help="start this daemon and hapticd-ros (else: measure --topic)")
    parser.add_argument("--rate", type=float, default=500.0, help="hapticd-ros --rate, with --hapticd")
    args = parser.parse_args()
    import rclpy
    from diagnostic_msgs.msg import DiagnosticArray
    processes = []
    with tempfile.TemporaryDirectory() as directory:
        if args.hapticd:
            processes = _start(args, directory)
            args.topic = "/hapticd_probe/pose"
        rclpy.init()
        node = rclpy.create_node("hapticd_rate_probe")
        missed = {}

        def on_diagnostics(array):
            for status in array.status:
                values = {kv.key: kv.value for kv in status.values}
                if "missed_periods" in values:
                    missed[status.name] = int(values["missed_periods"])

        node.create_subscription(DiagnosticArray, "/diagnostics", on_diagnostics, 10)
        try:
            before = dict(missed)
            result = summary(*measure(node, args.topic, args.seconds, settle_s=3.0 if args.hapticd else 1.0))
            end = time.monotonic() + 1.5
            while time.monotonic() < end:
                rclpy.spin_once(node, timeout_sec=0.05)
            result["missed_periods_since_start"] = {k: v - before.get(k, 0) for k, v in missed.items()}
            result["rate_requested_hz"] = args.rate if args.hapticd else None
            print(json.dumps(result))
        finally:
            node.destroy_node()
            rclpy.shutdown()
            for p in reversed(processes):
                p.send_signal(signal.SIGTERM)
                p.wait(20)


if __name__ == "__main__":
    main()
