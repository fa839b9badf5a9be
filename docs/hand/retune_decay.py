#!/usr/bin/env python3
# SPDX-License-Identifier: Apache-2.0
"""Nominal against re-tuned gains after the simulated hand's release (docs/robust-stability.md, "Online re-tuning").

Runs `hapticd --config "" --lockstep --quiet --bilateral --scenario step --hand-schedule release@R,grip@G
--duration D --trace --summary-json` with the extra --args, once as given and once with --retune, and prints for each:
  the gains in force after the release (the summary's K, B, or --retune's row 1 from its switch on);
  the switch ticks (--retune);
  from the trace, over the released phase [R, G):
    t_decay: the time after the release until |x| stays below `--fraction` of |x| at the release (x the penetration,
      0 the wall's equilibrium without the hand's force), or until it stays within `--counts` encoder counts when
      the profile rounds the position (the limit cycle of one count is the floor there);
    CE2: sum over the released ticks of (K_j x_j^2 / 2 + m (dx_j / T)^2 / 2) T / E_0 (the wall's and the handle's
      energy integrated over time, divided by its value at the release: the second energy criterion's measure of
      the same transient; m the released mass, dx the backward difference).
usage: retune_decay.py HAPTICD [--release 1.0] [--grip 10.0] [--duration 11.0] [--args '--device falcon --simulate']
"""
import argparse, csv, json, os, shlex, subprocess, sys, tempfile


def run(hapticd, a, extra, d, tag):
    trace, summary = os.path.join(d, tag + ".csv"), os.path.join(d, tag + ".json")
    cmd = [hapticd, "--config", "", "--lockstep", "--quiet", "--bilateral", "--scenario", "step",
           "--hand-schedule", "release@%g,grip@%g" % (a.release, a.grip), "--duration", str(a.duration),
           "--trace", trace, "--summary-json", summary] + shlex.split(a.args) + extra
    r = subprocess.run(cmd, capture_output=True, text=True)
    sys.stderr.write(r.stderr)
    if r.returncode != 0:
        sys.exit("hapticd exited with %d: %s" % (r.returncode, " ".join(cmd)))
    rows = [(int(x["tick"]), float(x["position_m"])) for x in csv.DictReader(open(trace))]
    return rows, json.load(open(summary))


def measure(rows, s, a, T):
    release, grip = int(round(a.release / T)), int(round(a.grip / T))
    m = [e for e in s["hand_events"] if e["event"] == "release"][0]["mass"]
    gains = [(s["K"], s["B"])] * len(rows)
    if "retune" in s:
        row = 0
        table = s["retune"]["rows"]
        for j in range(len(rows)):
            for sw in s["retune"]["switches"]:
                if j > sw["tick"]:
                    row = sw["row"]
            gains[j] = (table[row][0]["K"], table[row][0]["B"])
    x0 = abs(rows[release][1])
    q = s.get("position_resolution", 0.0) or 0.0
    bound = a.counts * q if q > 0 else a.fraction * x0
    last = release
    for j in range(release, grip):
        if abs(rows[j][1]) > bound:
            last = j
    e = lambda j: 0.5 * gains[j][0] * rows[j][1] ** 2 + 0.5 * m * ((rows[j][1] - rows[j - 1][1]) / T) ** 2
    e0 = e(release)
    ce2 = sum(e(j) * T for j in range(release, grip)) / e0
    return (last - release + 1) * T, bound, ce2, gains[grip - 1]


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("hapticd")
    ap.add_argument("--release", type=float, default=1.0)
    ap.add_argument("--grip", type=float, default=10.0)
    ap.add_argument("--duration", type=float, default=11.0)
    ap.add_argument("--fraction", type=float, default=1e-3)
    ap.add_argument("--counts", type=float, default=2.0)
    ap.add_argument("--args", default="--device falcon --simulate")
    a = ap.parse_args()
    with tempfile.TemporaryDirectory() as d:
        for tag, extra in (("nominal", []), ("retuned", ["--retune"])):
            rows, s = run(a.hapticd, a, extra, d, tag)
            T = a.duration / len(rows)
            t_decay, bound, ce2, (K, B) = measure(rows, s, a, T)
            switches = [(sw["tick"], sw["row"]) for sw in s.get("retune", {}).get("switches", [])]
            print("%-8s K %.4g N/m, B %.4g N s/m after the release; switches %s; t_decay (|x| <= %.3g m) %.3f s; "
                  "CE2 / E_0 %.4g s" % (tag, K, B, switches or "-", bound, t_decay, ce2))


if __name__ == "__main__":
    main()
