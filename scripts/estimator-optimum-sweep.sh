#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# The estimator optimum's sweep (tests/benchmarks/estimator_optimum_sweep.cpp, 180 cases) against the working
# tree's headers and, given a git revision, against that revision's headers too; then a summary:
#   - newton against brent, where gamma > 0 (the CE2 minimum on the edge alpha -> 0+) and where gamma = 0: cases,
#     the largest relative cost difference, the cases above 1e-9, newton without a finite cost where brent has one;
#   - with a revision: the largest relative CE2 cost difference at gamma = 0, and alpha_max (fast grid) moving by
#     more than 1e-10, and the largest relative change of the newton CE2 point (alpha, beta).
# Usage: scripts/estimator-optimum-sweep.sh [REVISION]   (g++ -O2; about a minute per build on 2 cores)
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."
out="$(mktemp -d)"
trap 'rm -rf "$out"' EXIT
run() {  # run <include dir> <name>
  g++ -std=c++20 -O2 -DNDEBUG -I"$1" -isystem /usr/include/eigen3 tests/benchmarks/estimator_optimum_sweep.cpp \
    -o "$out/$2"
  "$out/$2" > "$out/$2.txt"
}
run include current
if [[ $# -ge 1 ]]; then
  mkdir -p "$out/base-tree"
  git archive "$1" include | tar -x -C "$out/base-tree"
  run "$out/base-tree/include" base
fi
python3 - "$out" <<'PY'
import math, os, sys
out = sys.argv[1]
def load(name):
    rows = [l.split() for l in open(os.path.join(out, name + ".txt"))][1:]
    return {tuple(r[:5]): [float(x) for x in r[5:]] for r in rows}
def rel(a, b):
    if a == b: return 0.0
    return abs(a - b) / max(abs(a), abs(b))
def newton_against_brent(name, rows):
    for label, keep in (("gamma > 0", lambda g: g > 0), ("gamma = 0", lambda g: g == 0)):
        cases = {k: v for k, v in rows.items() if keep(float(k[3])) and math.isfinite(v[5])}
        worst = max((rel(v[4], v[5]) for v in cases.values() if math.isfinite(v[4])), default=0.0)
        above = sum(1 for v in cases.values() if math.isfinite(v[4]) and rel(v[4], v[5]) > 1e-9)
        missing = sum(1 for v in cases.values() if not math.isfinite(v[4]))
        print(f"{name}: {label}, {len(cases)} cases with a finite brent cost: newton cost off by up to {worst:.3g} "
              f"relative, {above} above 1e-9, {missing} without a finite newton cost")
        for k, v in cases.items():
            if math.isfinite(v[4]) and rel(v[4], v[5]) > 1e-9:
                side = "newton lower" if v[4] < v[5] else "NEWTON HIGHER"
                print("  ", " ".join(k), f"newton {v[4]:.17g} brent {v[5]:.17g} ({side})")
current = load("current")
newton_against_brent("current", current)
if os.path.exists(os.path.join(out, "base.txt")):
    base = load("base")
    newton_against_brent("base", base)
    flat = [rel(base[k][4], current[k][4]) for k in current if float(k[3]) == 0 and math.isfinite(current[k][4])]
    moved = [(k, rel(base[k][0], current[k][0])) for k in current if rel(base[k][0], current[k][0]) > 1e-10]
    print(f"gamma = 0: {len(flat)} cases, CE2 cost differs by up to {max(flat):.3g} relative")
    print(f"alpha_max on the fast grid moved by more than 1e-10 in {len(moved)} cases, "
          f"by up to {max((m for _, m in moved), default=0):.3g} relative")
    for k, m in moved:
        print("  ", " ".join(k), f"{m:.3g}")
    both = [k for k in current if math.isfinite(current[k][2]) and math.isfinite(base[k][2]) and current[k][0] > 0]
    da = max(((rel(base[k][2], current[k][2]), abs(base[k][2] - current[k][2]) / current[k][0], k) for k in both),
             default=(0.0, 0.0, None))
    db = max(((rel(base[k][3], current[k][3]), k) for k in both), default=(0.0, None))
    inner = [k for k in both if float(k[3]) == 0]
    print(f"CE2 point (newton), gamma = 0 (interior minima), {len(inner)} cases: alpha moved by up to "
          f"{max((rel(base[k][2], current[k][2]) for k in inner), default=0):.3g} relative, beta by up to "
          f"{max((rel(base[k][3], current[k][3]) for k in inner), default=0):.3g}")
    print(f"CE2 point (newton), all {len(both)} cases: alpha moved by up to {da[0]:.3g} relative "
          f"({max(abs(base[k][2] - current[k][2]) / current[k][0] for k in both):.3g} of alpha_max at most), "
          f"beta by up to {db[0]:.3g} relative")
    print("  largest alpha change:", " ".join(da[2]) if da[2] else "-", "; largest beta change:",
          " ".join(db[1]) if db[1] else "-")
PY
