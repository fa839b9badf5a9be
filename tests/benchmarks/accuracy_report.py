#!/usr/bin/env python3
# SPDX-License-Identifier: Apache-2.0
"""Prints the run-time-against-error tables (docs/accuracy.md) from hapticopt_accuracy_benchmarks and,
with --svg, draws them as a log-log figure (time per evaluation against error).

Usage: tests/benchmarks/accuracy_report.py [--svg FIGURE.svg] [--save-json RUN.json] <build>/tests/benchmarks/hapticopt_accuracy_benchmarks [benchmark args]
   or: tests/benchmarks/accuracy_report.py [--svg FIGURE.svg] --json RUN.json   (output of --benchmark_format=json)
"""
import json
import math
import subprocess
import sys

LABELS = {
    "BM_EnergyClosedForm": "C_E closed form (Stein equations)",
    "BM_TimeStepping": "C_E time-stepping + Simpson, {steps} steps/period",
    "BM_TimeSteppingRichardson": "C_E Richardson of Simpson ({steps} and {steps2} steps/period)",
    "BM_OvershootExact": "C_OV exact continuous maximum",
}
# Method families of the figure: (benchmark, quantity) -> (legend, marker)
FAMILIES = {
    ("BM_EnergyClosedForm", "energy"): ("closed form", "diamond"),
    ("BM_TimeStepping", "energy"): ("time-stepping (10/100/1000 steps)", "circle"),
    ("BM_TimeSteppingRichardson", "energy"): ("Richardson (10/100/1000 + double)", "square"),
    ("BM_OvershootExact", "overshoot"): ("exact continuous maximum", "diamond"),
    ("BM_TimeStepping", "overshoot"): ("sampled maximum (10/100/1000)", "circle"),
    ("BM_OptimumSearch/0", "optimum"): ("CE2 search", "circle"),
    ("BM_OptimumSearch/1", "optimum"): ("CE2+OV search", "square"),
}
D_COLOURS = {0: "#1f77b4", 1: "#d62728", 6: "#2ca02c"}
ERROR_FLOOR = 1e-17  # errors of exactly 0 are drawn here


def load(argv):
    if len(argv) >= 2 and argv[0] == "--json":
        with open(argv[1]) as f:
            return json.load(f)
    out = subprocess.run([argv[0], "--benchmark_format=json", *argv[1:]], check=True, capture_output=True, text=True)
    return json.loads(out.stdout)


def rows_of(data):
    rows, optimum_rows = [], []
    for b in data["benchmarks"]:
        if b.get("run_type", "iteration") != "iteration":
            continue
        name = b["name"].split("/")
        fn = name[0]
        args = dict(p.split(":") for p in name[1:] if ":" in p)
        d = int(args["d"])
        t_us = b["real_time"] * {"ns": 1e-3, "us": 1.0, "ms": 1e3, "s": 1e6}[b["time_unit"]]
        if fn == "BM_OptimumSearch":
            ov = int(args["ov"])
            optimum_rows.append((d, ov, int(args["tol_exp"]), t_us, b["err_opt_alpha"], b["err_opt_cost"]))
            continue
        steps = int(args.get("steps", 0))
        label = LABELS[fn].format(steps=steps, steps2=2 * steps)
        if "err_ce" in b:
            rows.append((d, "energy", label, t_us, b["err_ce"], fn))
        if "err_ov" in b:
            ov_label = label if fn == "BM_OvershootExact" else f"C_OV sampled maximum, {steps} samples/period"
            rows.append((d, "overshoot", ov_label, t_us, b["err_ov"], fn))
    rows.sort(key=lambda r: (r[0], r[1], -r[3]))
    optimum_rows.sort()
    return rows, optimum_rows


def print_tables(rows, optimum_rows):
    print("| d | quantity | method | time per evaluation [us] | error |")
    print("|---|---|---|---:|---:|")
    for d, what, label, t, err, _ in rows:
        print(f"| {d} | {what} | {label} | {t:.4g} | {err:.2e} |")
    print()
    print("error: energy = max over C_E0..2 of |value - reference| / reference; overshoot = |C_OV - reference| "
          "(in units of x_inf). Reference: tests/data/accuracy_reference.csv (long double).")
    if optimum_rows:
        print()
        print("| d | criterion | alpha_tolerance | time per search [ms] | alpha error | cost error |")
        print("|---|---|---|---:|---:|---:|")
        for d, ov, tol, t, ea, ec in optimum_rows:
            print(f"| {d} | {'CE2+OV' if ov else 'CE2'} | 1e-{tol} | {t / 1e3:.4g} | {ea:.2e} | {ec:.2e} |")
        print()
        print("errors relative to the same search with alpha_tolerance 1e-13 on a 4x denser coarse grid.")


def marker(shape, x, y, colour):
    r = 4.5
    if shape == "circle":
        return f'<circle cx="{x:.1f}" cy="{y:.1f}" r="{r}" fill="none" stroke="{colour}" stroke-width="1.6"/>'
    if shape == "square":
        return (f'<rect x="{x - r:.1f}" y="{y - r:.1f}" width="{2 * r}" height="{2 * r}" fill="none" '
                f'stroke="{colour}" stroke-width="1.6"/>')
    return (f'<path d="M{x:.1f},{y - r - 1:.1f} L{x + r + 1:.1f},{y:.1f} L{x:.1f},{y + r + 1:.1f} '
            f'L{x - r - 1:.1f},{y:.1f} Z" fill="{colour}" stroke="{colour}"/>')


def panel(title, points, xlabel, ox, oy, w, h):
    """points: (x, y, family, d); log10 axes fitted to whole decades."""
    xs = [math.log10(p[0]) for p in points]
    ys = [math.log10(max(p[1], ERROR_FLOOR)) for p in points]
    x0, x1 = math.floor(min(xs)), math.ceil(max(xs))
    y0, y1 = math.floor(min(ys)), math.ceil(max(ys))
    x1 += x1 == x0
    y1 += y1 == y0
    px = lambda v: ox + (v - x0) / (x1 - x0) * w
    py = lambda v: oy + h - (v - y0) / (y1 - y0) * h
    out = [f'<rect x="{ox}" y="{oy}" width="{w}" height="{h}" fill="none" stroke="#000"/>',
           f'<text x="{ox + w / 2}" y="{oy - 8}" text-anchor="middle" font-size="14">{title}</text>',
           f'<text x="{ox + w / 2}" y="{oy + h + 36}" text-anchor="middle" font-size="12">{xlabel}</text>',
           f'<text x="{ox - 48}" y="{oy + h / 2}" text-anchor="middle" font-size="12" '
           f'transform="rotate(-90 {ox - 48} {oy + h / 2})">error</text>']
    for e in range(x0, x1 + 1):
        out.append(f'<line x1="{px(e):.1f}" y1="{oy + h}" x2="{px(e):.1f}" y2="{oy + h + 5}" stroke="#000"/>')
        out.append(f'<text x="{px(e):.1f}" y="{oy + h + 18}" text-anchor="middle" font-size="11">1e{e}</text>')
    ystep = max(1, (y1 - y0 + 7) // 8)
    for e in range(y0, y1 + 1, ystep):
        out.append(f'<line x1="{ox - 5}" y1="{py(e):.1f}" x2="{ox}" y2="{py(e):.1f}" stroke="#000"/>')
        out.append(f'<line x1="{ox}" y1="{py(e):.1f}" x2="{ox + w}" y2="{py(e):.1f}" stroke="#ddd"/>')
        out.append(f'<text x="{ox - 8}" y="{py(e) + 4:.1f}" text-anchor="end" font-size="11">1e{e}</text>')
    families = []
    for (xv, yv, family, d), lx, ly in zip(points, xs, ys):
        legend, shape = FAMILIES[family]
        if legend not in [f[0] for f in families]:
            families.append((legend, shape))
        out.append(marker(shape, px(lx), py(ly), D_COLOURS.get(d, "#000")))
    for k, (legend, shape) in enumerate(families):
        y = oy + h + 58 + 16 * k
        out.append(marker(shape, ox + 8, y - 4, "#444"))
        out.append(f'<text x="{ox + 18}" y="{y}" font-size="11">{legend}</text>')
    return out


def write_svg(path, rows, optimum_rows):
    energy = [(t, e, (fn, "energy"), d) for d, what, _, t, e, fn in rows if what == "energy"]
    over = [(t, e, (fn, "overshoot"), d) for d, what, _, t, e, fn in rows if what == "overshoot"]
    opt = [(t / 1e3, ea, (f"BM_OptimumSearch/{ov}", "optimum"), d) for d, ov, _, t, ea, _ in optimum_rows]
    panels = [("Energy costs C_E0..2 (relative error)", energy, "time per evaluation [us]"),
              ("Overshoot C_OV (error in units of x_inf)", over, "time per evaluation [us]")]
    if opt:
        panels.append(("Optimum search (relative error of alpha)", opt, "time per search [ms]"))
    w, h = 360, 300
    width = 90 + len(panels) * (w + 90)
    parts = [f'<svg xmlns="http://www.w3.org/2000/svg" width="{width}" height="{h + 170}" '
             f'font-family="sans-serif"><rect width="100%" height="100%" fill="#fff"/>']
    for k, (title, pts, xlabel) in enumerate(panels):
        parts += panel(title, pts, xlabel, 80 + k * (w + 90), 40, w, h)
    for k, (d, colour) in enumerate(D_COLOURS.items()):
        x = 80 + 90 * k
        parts.append(f'<rect x="{x}" y="{h + 145}" width="12" height="12" fill="{colour}"/>')
        parts.append(f'<text x="{x + 18}" y="{h + 155}" font-size="12">d = {d}</text>')
    parts.append(f'<text x="{80 + 90 * len(D_COLOURS)}" y="{h + 155}" font-size="11">errors of 0 drawn at '
                 f'{ERROR_FLOOR:g}; times from one benchmark run (tests/benchmarks/accuracy_report.py)</text>')
    parts.append("</svg>")
    with open(path, "w") as f:
        f.write("\n".join(parts) + "\n")


def main(argv):
    svg = save = None
    while argv and argv[0] in ("--svg", "--save-json"):
        if len(argv) < 2:
            break
        if argv[0] == "--svg":
            svg = argv[1]
        else:
            save = argv[1]
        argv = argv[2:]
    if not argv:
        print(__doc__, file=sys.stderr)
        return 2
    data = load(argv)
    if save:
        with open(save, "w") as f:
            json.dump(data, f, indent=1)
    rows, optimum_rows = rows_of(data)
    print_tables(rows, optimum_rows)
    if svg:
        write_svg(svg, rows, optimum_rows)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
