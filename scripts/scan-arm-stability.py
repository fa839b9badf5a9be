#!/usr/bin/env python3
# SPDX-License-Identifier: Apache-2.0
"""Which gain pairs stable for the device alone (gamma = delta = 0) become unstable with a human arm in the paper's
box (Hulin et al. 2011, eq. 2: gamma < 0.001, delta < 0.02 at 1 kHz)? docs/robust-stability.md, "The arm".

Grid: 80 alphas up to 0.9999 alpha_max of the backward difference's region and 41 betas across its interval at
each; pairs stable for the device alone with the estimator are judged again at gamma in {0, 0.0005, 0.001} and
delta in {0, 0.005, 0.01, 0.02}. Prints, per estimator and delay, the pairs stable alone, those unstable with some
arm, and those unstable with an arm of delta >= 0.01.

Usage: scripts/scan-arm-stability.py  (needs the hapticopt Python package: scripts/test-python.sh installs it)
"""
import itertools

import hapticopt as h

GAMMAS = [0.0, 0.0005, 0.001]
DELTAS = [0.0, 0.005, 0.01, 0.02]


def scan(estimator, d):
    alone = h.Plant(0.0, 0.0, d)
    amax = h.alpha_max(alone)
    stable_alone = unstable = unstable_damped = 0
    for i in range(1, 81):
        a = amax * i / 80 * 0.9999
        lo, hi = h.beta_range(a, alone)
        for j in range(41):
            b = lo + (hi - lo) * (j + 0.5) / 41.5
            if not h.is_stable(a, b, alone, estimator=estimator):
                continue
            stable_alone += 1
            failing = [(g, dl) for g, dl in itertools.product(GAMMAS, DELTAS)
                       if not h.is_stable(a, b, h.Plant(g, dl, d), estimator=estimator)]
            unstable += 1 if failing else 0
            unstable_damped += 1 if any(dl >= 0.01 for _, dl in failing) else 0
    return stable_alone, unstable, unstable_damped


def main():
    for name, estimator in [("backward", None), ("window:15", "window:15")]:
        for d in [0, 1, 6]:
            n, bad, damped = scan(estimator, d)
            print(f"{name:10s} d = {d}: {n:5d} pairs stable alone, {bad:4d} unstable with some arm, "
                  f"{damped} with an arm of delta >= 0.01", flush=True)


if __name__ == "__main__":
    main()
