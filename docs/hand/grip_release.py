#!/usr/bin/env python3
# SPDX-License-Identifier: Apache-2.0
"""Energy and force when the simulated hand lets go of a wall and grips again (docs/simulated-hand.md).

Runs `hapticd --lockstep --hand-schedule release@R,grip@G --duration D --trace --summary-json` (the step intent:
the hand presses the handle into the first wall with --step-force) with the extra --args, and prints:
  K, B of the wall (the summary);
  at the release, from the summary's event records (the simulated device's exact state, not the encoder's):
    E_release = K p^2 / 2 + m v^2 / 2 with the released mass m (p: the penetration, p > 0 in the wall);
  at the grip: E_grip the same way (in the wall) or m v^2 / 2 (out of it; the free handle keeps its velocity,
    so that is the energy it left the wall with): E_grip / E_release is what the wall kept or gave back;
  from the trace: |F| at the release tick, the peak |F| while released, the last released tick with F != 0
    (a unilateral wall: the handle left it), max |F| over the released phase's second half, the peak |F| after
    the grip and max |F| over the run's last 0.3 s.
usage: grip_release.py HAPTICD [--release 1.0] [--grip 2.0] [--duration 3.0] [--args '--device falcon --simulate']
"""
import argparse, csv, json, os, shlex, subprocess, sys, tempfile


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("hapticd")
    ap.add_argument("--release", type=float, default=1.0)
    ap.add_argument("--grip", type=float, default=2.0)
    ap.add_argument("--duration", type=float, default=3.0)
    ap.add_argument("--args", default="--device falcon --simulate")
    a = ap.parse_args()
    with tempfile.TemporaryDirectory() as d:
        trace, summary = os.path.join(d, "t.csv"), os.path.join(d, "s.json")
        cmd = [a.hapticd, "--config", "", "--lockstep", "--quiet", "--scenario", "step",
               "--hand-schedule", "release@%g,grip@%g" % (a.release, a.grip), "--duration", str(a.duration),
               "--trace", trace, "--summary-json", summary] + shlex.split(a.args)
        run = subprocess.run(cmd, capture_output=True, text=True)
        sys.stderr.write(run.stderr)
        if run.returncode != 0:
            sys.exit("hapticd exited with %d" % run.returncode)
        rows = [(int(r["tick"]), float(r["position_m"]), float(r["wall_force_N"]), float(r["time_s"]))
                for r in csv.DictReader(open(trace))]
        s = json.load(open(summary))
    K, B = s["K"], s["B"]
    rel, grip = s["hand_events"][0], s["hand_events"][1]

    def energy(e, m):
        p = max(e["position"], 0.0) if "--bilateral" not in a.args else e["position"]
        return 0.5 * K * p * p + 0.5 * m * e["velocity"] ** 2

    m_free = rel["mass"]
    e_rel, e_grip = energy(rel, m_free), energy(grip, m_free)
    tr, tg = rel["tick"], grip["tick"]
    released = [r for r in rows if tr <= r[0] < tg]
    touching = [r[0] for r in released if r[2] != 0.0]
    half = [abs(r[2]) for r in rows if (tr + tg) // 2 <= r[0] < tg]
    after = [abs(r[2]) for r in rows if r[0] >= tg]
    last = [abs(r[2]) for r in rows[:-1] if r[3] >= a.duration - 0.3]  # the run's final tick writes zero
    print("K = %.6g N/m, B = %.6g N s/m; released mass %.4g kg" % (K, B, m_free))
    print("release at tick %d: x = %.6g m, v = %.6g m/s, |F| = %.4f N, E_release = %.4g J"
          % (tr, rel["position"], rel["velocity"], abs(rows[tr][2]), e_rel))
    print("released: peak |F| %.4f N; last tick with F != 0: %s; max |F| over the second half %.4f N"
          % (max(abs(r[2]) for r in released), touching[-1] if touching else "none", max(half)))
    print("grip at tick %d: x = %.6g m, v = %.6g m/s, E_grip = %.4g J (E_grip / E_release = %.4g)"
          % (tg, grip["position"], grip["velocity"], e_grip, e_grip / e_rel if e_rel > 0 else float("nan")))
    print("after the grip: peak |F| %.4f N; max |F| over the last 0.3 s %.4f N" % (max(after), max(last)))


if __name__ == "__main__":
    main()
