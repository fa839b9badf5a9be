#!/usr/bin/env python3
# SPDX-License-Identifier: Apache-2.0
"""The comparison of docs/passivity.md: on the simulated device (docs/passivity/sim_damped.toml:
0.30 kg, b = 6 N s/m, i.e. delta = 0.02; 1 kHz; lockstep; bilateral wall), for d = 0, 1, 3 delay-buffer
periods, three walls
  optimal   the optimum of C_E2 (step) or C_I2 (collision)            hapticopt optimum --criterion CE2|CI2
  PC        1.5 alpha_max at the beta of the region's tip + hapticd --passivity-control
  passive   the best passive gains for C_E2 or C_I2                    hapticopt optimum ... --passive
in the paper's step (1 N into the wall at rest, 3 s) and a collision (at the surface, 0.02 m/s, no force,
3 s). From each trace: C_E0..2 (step) or C_I0..2 (collision), overshoot (step), penetration (max x) and peak
|wall force|. Writes the Markdown table to stdout and the figure (step responses) to the SVG path.

The continuous-time state between samples is reconstructed exactly from the trace: the simulated plant is
m x'' + b x' = F_ext + u with u the traced (held) wall force, integrated in closed form per period; the
script checks that the reconstruction reproduces every traced position (to 1e-9 of the largest |x|) before using it.
Integrals: composite Simpson with 16 sub-intervals per period (error O(h^4), h = T/16; on these smooth
exponentials far below the printed 4 digits).

Usage: docs/passivity/compare.py HAPTICOPT HAPTICD OUT.svg [WORKDIR]"""
import csv
import json
import math
import os
import subprocess
import sys
import tempfile

M, B_DEV, T = 0.30, 6.0, 1e-3
V0 = 0.02          # m/s, collision speed (peak force stays below the profile's 10 N)
DURATION = 3.0     # s
SUB = 16           # Simpson sub-intervals per period
HERE = os.path.dirname(os.path.abspath(__file__))
PROFILE = os.path.join(HERE, "sim_damped.toml")


def run_json(cmd):
    return json.loads(subprocess.run(cmd, check=True, capture_output=True, text=True).stdout)


def gains(hapticopt, criterion, d, passive=False):
    cmd = [hapticopt, "optimum", "--criterion", criterion, "--mass", str(M), "--period", str(T),
           "--damping", str(B_DEV), "--time-delay", repr(d * T), "--json"]
    if passive:
        cmd.insert(4, "--passive")
    o = run_json(cmd)
    return o["K"], o["B"]


def pc_gains(hapticopt, d, factor=1.5):
    o = run_json([hapticopt, "boundary", "--delta", repr(B_DEV * T / M), "--delay", str(d), "--json"])
    return factor * o["alpha_max"] * M / T ** 2, o["beta_at_alpha_max"] * M / T


def run_hapticd(hapticd, workdir, name, K, B, d, scenario, control):
    trace = os.path.join(workdir, name + ".csv")
    summary = os.path.join(workdir, name + ".json")
    cmd = [hapticd, "--device", PROFILE, "--lockstep", "--bilateral", "--stiffness", repr(K), "--damping", repr(B),
           "--delay-buffer", str(d), "--duration", str(DURATION), "--scenario", scenario, "--trace", trace,
           "--summary-json", summary, "--quiet"]
    if scenario == "push":
        cmd += ["--push-distance", "0", "--push-speed", repr(V0), "--push-force", "0"]
    else:
        cmd += ["--step-force", "1"]
    if control:
        cmd.append("--passivity-control")
    subprocess.run(cmd, check=True)
    rows = list(csv.DictReader(open(trace)))
    x = [float(r["position_m"]) for r in rows]
    u = [float(r["wall_force_N"]) for r in rows]
    ext = [float(r["external_force_N"]) for r in rows]
    return x, u, ext, json.load(open(summary))


def propagate(x, v, G, t):
    """m x'' + b x' = G from (x, v) over t (closed form)."""
    a = B_DEV / M
    e = math.exp(-a * t)
    vinf = G / B_DEV
    return x + vinf * t + (v - vinf) * (1 - e) / a, vinf + (v - vinf) * e


def criteria(x, u, ext, K, v0, x_inf, kind):
    """Reconstruct between samples, integrate E t^p (p = 0, 1, 2) by Simpson; E as in eqs. 4 / impulse_costs."""
    xs, vs = x[0], v0
    integrals = [0.0, 0.0, 0.0]
    peak_x = x[0]
    worst = 0.0
    h = T / SUB

    def energy(xx, vv):
        return 0.5 * K * (xx - x_inf) ** 2 + 0.5 * M * vv ** 2

    for j in range(len(x) - 1):
        G = ext[j] + u[j]
        pts = []
        for s in range(SUB + 1):
            xx, vv = propagate(xs, vs, G, s * h)
            pts.append((j * T + s * h, energy(xx, vv)))
            peak_x = max(peak_x, xx)
        for p in range(3):
            acc = 0.0
            for s in range(SUB + 1):
                w = 1 if s in (0, SUB) else (4 if s % 2 else 2)
                acc += w * pts[s][1] * pts[s][0] ** p
            integrals[p] += acc * h / 3
        xs, vs = propagate(xs, vs, G, T)
        worst = max(worst, abs(xs - x[j + 1]))
    worst /= max(abs(v) for v in x) or 1.0
    if worst > 1e-9:
        sys.exit("compare.py: the reconstruction misses the trace by %.3g relative: not the exact plant" % worst)
    e0 = 0.5 * K * x_inf ** 2 if kind == "step" else 0.5 * M * v0 ** 2
    return [integrals[p] / (T ** (p + 1) * e0) for p in range(3)], peak_x


def main():
    if len(sys.argv) < 4:
        sys.exit(__doc__)
    hapticopt, hapticd, svg_path = sys.argv[1:4]
    workdir = sys.argv[4] if len(sys.argv) > 4 else tempfile.mkdtemp(prefix="passivity_compare_")
    os.makedirs(workdir, exist_ok=True)
    print("| d | scenario | wall | K [N/m] | B [N s/m] | C_0 | C_1 | C_2 | overshoot | penetration [um] | peak force [N] "
          "| PC damper ticks (capped) |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|")
    curves = {}
    for d in (0, 1, 3):
        for scenario, criterion in (("step", "CE2"), ("push", "CI2")):
            walls = [("optimal " + criterion, gains(hapticopt, criterion, d), False),
                     ("PC 1.5 alpha_max", pc_gains(hapticopt, d), True),
                     ("passive " + criterion, gains(hapticopt, criterion, d, passive=True), False)]
            for label, (K, B), control in walls:
                x, u, ext, summary = run_hapticd(hapticd, workdir, "d%d_%s_%s" % (d, scenario, label.split()[0]),
                                                 K, B, d, scenario, control)
                v0 = 0.0 if scenario == "step" else V0
                x_inf = 1.0 / K if scenario == "step" else 0.0
                c, peak_x = criteria(x, u, ext, K, v0, x_inf, scenario)
                ov = "%.4g" % ((peak_x - x_inf) / x_inf) if scenario == "step" else "-"
                pc = summary.get("passivity_control")
                pcs = "%d (%d)" % (pc["damper_ticks"], pc["capped_ticks"]) if pc else "-"
                print("| %d | %s | %s | %.5g | %.4g | %.4g | %.4g | %.4g | %s | %.4g | %.4g | %s |" % (
                    d, "step 1 N" if scenario == "step" else "collision %g m/s" % V0, label, K, B, c[0], c[1], c[2],
                    ov, peak_x * 1e6, max(abs(f) for f in u), pcs))
                if scenario == "step":
                    curves[(d, label.split()[0])] = [xi / x_inf for xi in x[:151]]
    write_svg(svg_path, curves)


def write_svg(path, curves):
    """Three panels (d = 0, 1, 3): x / x_inf against t over the first 150 ms of the step."""
    w, h, pad = 300, 240, 40
    colours = {"optimal": "#1f77b4", "PC": "#d62728", "passive": "#2ca02c"}
    ymax = 2.0
    out = ['<svg xmlns="http://www.w3.org/2000/svg" width="%d" height="%d" font-family="sans-serif" font-size="11">'
           % (3 * w, h + 30),
           '<rect width="100%" height="100%" fill="white"/>']
    for i, d in enumerate((0, 1, 3)):
        x0 = i * w + pad
        y0 = pad / 2
        pw, ph = w - pad - 10, h - pad - 10
        out.append('<g id="panel-d%d">' % d)
        out.append('<rect x="%g" y="%g" width="%g" height="%g" fill="none" stroke="#000"/>' % (x0, y0, pw, ph))
        out.append('<text x="%g" y="%g" text-anchor="middle">d = %d: step response x / x_inf</text>'
                   % (x0 + pw / 2, y0 - 4, d))
        for tick in (0, 50, 100, 150):
            px = x0 + pw * tick / 150
            out.append('<text x="%g" y="%g" text-anchor="middle">%d ms</text>' % (px, y0 + ph + 14, tick))
        for yt in (0, 1, 2):
            py = y0 + ph * (1 - yt / ymax)
            out.append('<line x1="%g" x2="%g" y1="%g" y2="%g" stroke="#ccc"/>' % (x0, x0 + pw, py, py))
            out.append('<text x="%g" y="%g" text-anchor="end">%d</text>' % (x0 - 3, py + 4, yt))
        for key, colour in colours.items():
            ys = curves.get((d, key))
            if not ys:
                continue
            pts = " ".join("%.2f,%.2f" % (x0 + pw * j / 150, y0 + ph * (1 - min(max(y, -0.2), ymax) / ymax))
                           for j, y in enumerate(ys))
            out.append('<polyline class="%s" points="%s" fill="none" stroke="%s" stroke-width="1.3"/>'
                       % (key, pts, colour))
        out.append('</g>')
    legend = [("optimal C_E2", "optimal"), ("1.5 alpha_max + passivity control", "PC"), ("best passive C_E2", "passive")]
    for k, (text, key) in enumerate(legend):
        lx = pad + k * 280
        out.append('<line x1="%g" x2="%g" y1="%g" y2="%g" stroke="%s" stroke-width="2"/>'
                   % (lx, lx + 20, h + 18, h + 18, colours[key]))
        out.append('<text x="%g" y="%g">%s</text>' % (lx + 25, h + 22, text))
    out.append('</svg>')
    with open(path, "w") as f:
        f.write("\n".join(out) + "\n")


if __name__ == "__main__":
    main()
