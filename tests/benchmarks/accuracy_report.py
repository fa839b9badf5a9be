#!/usr/bin/env python3
"""Prints the run-time-against-error table (docs/accuracy.md) from hapticopt_accuracy_benchmarks.

Usage: tests/benchmarks/accuracy_report.py <build>/tests/benchmarks/hapticopt_accuracy_benchmarks [benchmark args]
   or: tests/benchmarks/accuracy_report.py --json results.json   (output of --benchmark_format=json)
"""
import json
import subprocess
import sys

LABELS = {
    "BM_EnergyClosedForm": "C_E closed form (Stein equations)",
    "BM_TimeStepping": "C_E time-stepping + Simpson, {steps} steps/period",
    "BM_TimeSteppingRichardson": "C_E Richardson of Simpson ({steps} and {steps2} steps/period)",
    "BM_OvershootExact": "C_OV exact continuous maximum",
}


def load(argv):
    if len(argv) >= 3 and argv[1] == "--json":
        with open(argv[2]) as f:
            return json.load(f)
    out = subprocess.run([argv[1], "--benchmark_format=json", *argv[2:]], check=True, capture_output=True, text=True)
    return json.loads(out.stdout)


def main(argv):
    if len(argv) < 2:
        print(__doc__, file=sys.stderr)
        return 2
    data = load(argv)
    rows = []
    for b in data["benchmarks"]:
        if b.get("run_type", "iteration") != "iteration":
            continue
        name = b["name"].split("/")
        fn = name[0]
        args = dict(p.split(":") for p in name[1:] if ":" in p)
        d = int(args["d"])
        steps = int(args.get("steps", 0))
        t_us = b["real_time"] * {"ns": 1e-3, "us": 1.0, "ms": 1e3, "s": 1e6}[b["time_unit"]]
        label = LABELS[fn].format(steps=steps, steps2=2 * steps)
        if "err_ce" in b:
            rows.append((d, "energy", label, t_us, b["err_ce"]))
        if "err_ov" in b:
            ov_label = label if fn == "BM_OvershootExact" else f"C_OV sampled maximum, {steps} samples/period"
            rows.append((d, "overshoot", ov_label, t_us, b["err_ov"]))
    rows.sort(key=lambda r: (r[0], r[1], -r[3]))
    print("| d | quantity | method | time per evaluation [us] | error |")
    print("|---|---|---|---:|---:|")
    for d, what, label, t, err in rows:
        print(f"| {d} | {what} | {label} | {t:.4g} | {err:.2e} |")
    print()
    print("error: energy = max over C_E0..2 of |value - reference| / reference; overshoot = |C_OV - reference| "
          "(in units of x_inf). Reference: tests/data/accuracy_reference.csv (long double).")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
