# SPDX-License-Identifier: Apache-2.0
"""Per-point cost of C_E2 (d = 1, gamma = 0.001, delta = 0.02) in one run, four ways:

  1. the C++ Google Benchmark (hapticopt_benchmarks: BM_EnergyCostSingleIndex/1/2, plant precomputed,
     and BM_EnergyCostsIncludingPlantSetup/1, all three costs with the plant set up per call);
  2. one point through Python (hapticopt.cost on two floats: conversion + plant setup + C_E2);
  3. the vectorised grid (hapticopt.cost_grid, 500 x 500 over the stable region's bounding box),
     time per cell; also per stable cell;
  4. the independent scipy reference of the tests (expm + quad_vec Gramians + 3 Lyapunov solves), and
     a lean variant of it (Gramians by a 16-point Gauss-Legendre rule).

Goal: vectorised >= 100x faster per point than the scipy reference. Run (docs/python.md):
  build/py-venv/bin/python python/benchmarks/bench_costs.py --cpp build/py/tests/benchmarks/hapticopt_benchmarks
Times are medians over repetitions of CPU time per point (time.process_time; the C++ figures are
Google Benchmark's cpu_time medians); BLAS limited to one thread.
"""
from __future__ import annotations

import os

# One core for every contender (the C++ benchmark is single-threaded): a multi-threaded BLAS would
# add its threads' spinning to scipy's CPU time. Set before numpy loads its BLAS.
for _variable in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_variable, "1")

import argparse
import json
import pathlib
import statistics
import subprocess
import sys
import time

import numpy as np
from scipy.linalg import expm

import hapticopt as ho

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parents[1] / "tests"))
from scipy_reference import ReferenceLoop  # noqa: E402

PLANT = ho.Plant(0.001, 0.02, 1.0)
ALPHA, BETA = 0.0582, 0.3796  # the benchmark's d = 1 point (core_benchmarks.cpp, gains_for(1))


class LeanReferenceLoop(ReferenceLoop):
    """The scipy reference with its Gramians by a fixed 16-point Gauss-Legendre rule (16 expm calls
    for the three instead of quad_vec's adaptive hundreds): a fairer, faster scipy baseline (the
    integrand is analytic on [0, 1]: the rule is exact to rounding here)."""

    _nodes, _weights = np.polynomial.legendre.leggauss(16)

    def _gramian(self, r: int) -> np.ndarray:
        if r == 0:
            taus = (self._nodes + 1) / 2
            self._exps = [expm(self.a3 * t) for t in taus]
            self._taus = taus
        return sum(w / 2 * t ** r * (e.T @ self.q @ e) for w, t, e in zip(self._weights, self._taus, self._exps))


def cpu_per_call(function, calls: int, repetitions: int) -> float:
    samples = []
    for _ in range(repetitions):
        start = time.process_time()
        for _ in range(calls):
            function()
        samples.append((time.process_time() - start) / calls)
    return statistics.median(samples)


def cpp_figures(executable: str, repetitions: int) -> dict:
    out = subprocess.run([executable, "--benchmark_filter=BM_EnergyCostSingleIndex/1/2$|BM_EnergyCostsIncludingPlantSetup/1$",
                          f"--benchmark_repetitions={repetitions}", "--benchmark_report_aggregates_only=true",
                          "--benchmark_format=json"], check=True, capture_output=True, text=True).stdout
    figures = {}
    for b in json.loads(out)["benchmarks"]:
        if b.get("aggregate_name") == "median":
            scale = {"us": 1e-6, "ns": 1e-9, "ms": 1e-3}[b["time_unit"]]
            figures[b["run_name"]] = b["cpu_time"] * scale
    return figures


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--cpp", help="path of hapticopt_benchmarks (the C++ benchmark); omitted: not run")
    parser.add_argument("--grid", type=int, default=500)
    parser.add_argument("--repetitions", type=int, default=5)
    parser.add_argument("--all-criteria", action="store_true",
                        help="also time the whole grid once for each of CE0, CE1, OV, CI0, CI1, CI2")
    args = parser.parse_args()

    rows = []
    if args.cpp:
        for name, seconds in cpp_figures(args.cpp, args.repetitions).items():
            rows.append((f"C++ {name}", seconds))
    rows.append(("Python hapticopt.cost('CE2', a, b, plant), one point",
                 cpu_per_call(lambda: ho.cost("CE2", ALPHA, BETA, PLANT), 2000, args.repetitions)))
    rows.append(("Python hapticopt.costs(a, b, plant): all criteria + stability, one point",
                 cpu_per_call(lambda: ho.costs(ALPHA, BETA, PLANT), 200, args.repetitions)))
    b = ho.boundary(PLANT)
    alphas = np.linspace(0.0, b.alpha_max, args.grid)
    betas = np.linspace(b.beta.min(), b.beta.max(), args.grid)
    grid_times = []
    for _ in range(args.repetitions):
        start = time.process_time()
        z = ho.cost_grid("CE2", alphas, betas, PLANT)
        grid_times.append(time.process_time() - start)
    grid_seconds = statistics.median(grid_times)
    stable = int(np.isfinite(z).sum())
    rows.append((f"vectorised cost_grid {args.grid}x{args.grid}, per cell ({stable} stable cells)",
                 grid_seconds / z.size))
    rows.append(("vectorised cost_grid, per stable cell (unstable cells ~free)", grid_seconds / stable))
    reference = cpu_per_call(lambda: ReferenceLoop(ALPHA, BETA, *PLANT.__dict__.values()).step_costs(), 3,
                             args.repetitions)
    rows.append(("scipy reference (expm + quad_vec + solve_discrete_lyapunov), one point", reference))
    lean = cpu_per_call(lambda: LeanReferenceLoop(ALPHA, BETA, *PLANT.__dict__.values()).step_costs(), 20,
                        args.repetitions)
    rows.append(("scipy lean (expm at 16 Gauss-Legendre nodes + solve_discrete_lyapunov), one point", lean))

    print(f"C_E2 at alpha {ALPHA}, beta {BETA}, gamma {PLANT.gamma}, delta {PLANT.delta}, d {PLANT.delay:g}; "
          f"median of {args.repetitions}, CPU time per point")
    print(f"{'what':78s} {'time/point':>12s} {'scipy / this':>12s}")
    for name, seconds in rows:
        print(f"{name:78s} {seconds * 1e6:9.3f} us {reference / seconds:12.0f}")
    print(f"whole {args.grid}x{args.grid} grid: {grid_seconds:.3f} s CPU")
    if args.all_criteria:
        for criterion in ("CE0", "CE1", "OV", "CI0", "CI1", "CI2"):
            start = time.process_time()
            ho.cost_grid(criterion, alphas, betas, PLANT)
            print(f"whole {args.grid}x{args.grid} grid of {criterion}: {time.process_time() - start:.3f} s CPU (one run)")
    for name, baseline in (("scipy reference", reference), ("scipy lean", lean)):
        ratio = baseline / (grid_seconds / stable)
        print(f"goal vectorised >= 100x faster than the {name} per (stable) point: {ratio:.0f}x -> "
              f"{'met' if ratio >= 100 else 'NOT met'}")


if __name__ == "__main__":
    main()
