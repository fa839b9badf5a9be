#!/usr/bin/env python3
# SPDX-License-Identifier: Apache-2.0
"""The 200 Hz moving wall, measured from the daemon's per-tick trace (docs/simulated-hand.md).

Runs `hapticd --serve --no-walls --trace` (real time, the default simulated device and hand unless
--daemon-args says otherwise), then `example_moving_wall` (a CE2 plane, normal -x, offset 5 mm, +-2 mm at
1 Hz, sent at 200 Hz) for --duration seconds, and prints from the trace's ticks while the wall was there:
  contact/release pairs: times the force along the normal went from 0 to > 0 (the wall pushing or not),
  roughness: the RMS of the force's second difference f_j - 2 f_{j-1} + f_{j-2}, N,
  force min / max, N; position min / max, mm.
usage: moving_wall_chatter.py BUILD_DIR [--hapticd PATH] [--example PATH] [--duration 2] [--daemon-args '...']
"""
import argparse, csv, math, os, shlex, signal, subprocess, sys, tempfile, time


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("build")
    ap.add_argument("--hapticd")
    ap.add_argument("--example")
    ap.add_argument("--duration", type=float, default=2.0)
    ap.add_argument("--daemon-args", default="")
    ap.add_argument("--keep-trace", help="copy the daemon's trace CSV here")
    ap.add_argument("--rt-priority", default="0", help="the daemon's SCHED_FIFO priority (0: none; needs the privilege)")
    a = ap.parse_args()
    hapticd = a.hapticd or os.path.join(a.build, "apps/hapticd/hapticd")
    example = a.example or os.path.join(a.build, "apps/examples/example_moving_wall")
    with tempfile.TemporaryDirectory() as d:
        sock, trace = os.path.join(d, "h.sock"), os.path.join(d, "trace.csv")
        shm = "/hapticd-chatter-%d" % os.getpid()
        daemon = subprocess.Popen([hapticd, "--config", "", "--serve", "--no-walls", "--serve-socket", sock, "--serve-shm", shm,
                                   "--rt-priority", a.rt_priority, "--mlock", "false", "--trace", trace, "--quiet"] + shlex.split(a.daemon_args))
        for _ in range(500):
            if os.path.exists(sock):
                break
            time.sleep(0.01)
        time.sleep(0.3)  # the handle settles in the hand
        out = subprocess.run([example, "--socket", sock, "--duration", str(a.duration)], capture_output=True, text=True)
        time.sleep(0.1)
        daemon.send_signal(signal.SIGINT)
        daemon.wait(timeout=10)
        print(out.stdout.strip())
        rows = list(csv.DictReader(open(trace)))
        if a.keep_trace:
            open(a.keep_trace, "w").write(open(trace).read())
    f = [-float(r["wall_force_N"]) for r in rows]  # along the normal -x
    x = [float(r["position_m"]) for r in rows]
    on = [i for i, v in enumerate(f) if v != 0.0]
    if not on:
        print("the wall never pushed"); return 1
    lo, hi = on[0], on[0] + int(a.duration * 1000)  # from the first force, --duration s of ticks
    f, x = f[lo:hi], x[lo:hi]
    pairs = sum(1 for i in range(1, len(f)) if f[i - 1] == 0.0 and f[i] > 0.0)
    d2 = [f[i] - 2 * f[i - 1] + f[i - 2] for i in range(2, len(f))]
    rms = math.sqrt(sum(v * v for v in d2) / len(d2))
    late = sum(1 for r in rows[lo:hi] if float(r["wake_latency_us"]) > 1000.0)
    print("ticks woken more than a period late: %d" % late)
    print("ticks %d: contact/release pairs %d, in contact %d ticks, roughness (RMS second difference) %.4f N, "
          "force %.3f .. %.3f N, position %.3f .. %.3f mm" % (len(f), pairs, sum(1 for v in f if v > 0), rms, min(f), max(f),
                                                             1e3 * min(x), 1e3 * max(x)))
    return 0


if __name__ == "__main__":
    sys.exit(main())
