# SPDX-License-Identifier: Apache-2.0
"""Every criterion with every estimator, with and without a force-noise budget, and the robust optimum of the loop
with its estimator (include/hapticopt/noise_budget.hpp, robust_optimum.hpp), from Python against the CLI and
against the library's own independent checks (the budget by a separate Stein solve, the mass range by the exact
crossing test).

Agreement with the CLI: the same searches compiled twice (-O3 by pip, -O2 by CMake); the largest-alpha searches stop
where the overshoot crosses 1e-12 and bisect to 1e-10 in log alpha, so a few-ulp different surface moves the point by
at most that bisection's step near a steep crossing: relative 1e-8 in alpha.
"""
from __future__ import annotations

import json
import math
import subprocess

import pytest

import hapticopt as ho

FALCON = ho.Plant(gamma=0.0, delta=0.0, delay=6.0)


def run_json(cli, *args):
    out = subprocess.run([cli, *args, "--json"], check=True, capture_output=True, text=True).stdout
    return json.loads(out)


def test_ov_with_a_window_has_no_overshoot_and_matches_the_cli(cli):
    o = ho.optimal_point("OV", ho.Plant(delay=1.0), estimator="window:15")
    assert 0 < o.alpha < o.alpha_max
    assert o.cost is not None and o.cost <= 1e-12
    c = run_json(cli, "optimum", "--criterion", "OV", "--velocity", "window:15", "--delay", "1")
    assert math.isclose(o.alpha, c["alpha"], rel_tol=1e-8)


@pytest.mark.parametrize("criterion", ["amax", "OV", "CE2+OV"])
def test_a_binding_budget_is_met(criterion):
    free = ho.optimal_point("CE2+OV" if criterion == "CE2+OV" else "CE2", FALCON, estimator="window:15")
    g_free = ho.force_noise_gain(free.alpha, free.beta, FALCON, estimator="window:15")
    budget = (0.9 if criterion == "CE2+OV" else 0.5) * g_free
    o = ho.optimal_point_under_noise_budget(criterion, budget, FALCON, estimator="window:15")
    assert o.budget_active
    # An independent Stein solve at the returned gains: within the budget (the band's ends keep the feasible side).
    assert ho.force_noise_gain(o.alpha, o.beta, FALCON, estimator="window:15") <= budget
    assert 0 < o.alpha < o.alpha_max
    if criterion == "amax":
        assert o.force_noise_gain >= budget * (1 - 1e-6)  # the stiffest gains meeting it sit on it


def test_the_robust_falcon_wall_with_its_window_and_budget():
    r = ho.robust_optimum("CE2", mass=(0.22, 0.30), period=1e-3, time_delay=0.006, estimator="window:15",
                          force_noise_budget=0.05, position_resolution=4.85e-5)
    assert r.stable_over_box and r.mass_segments_certified
    assert 0 < r.force_noise_max <= 0.05
    assert r.worst_cost <= r.nominal_worst_cost
    assert r.velocity_estimator.window == 15
    # The exact mass-range test, over the profile's set widened by its 10 % margin: stable.
    s = ho.mass_range_stability(r.K, r.B, mass=(0.20, 0.33), period=1e-3, time_delay=0.006, estimator="window:15")
    assert s.stable
    with pytest.raises(ho.InvalidParameterError) as e:
        ho.robust_optimum("CE2", mass=(0.22, 0.30), period=1e-3, time_delay=0.006, estimator="window:15",
                          force_noise_budget=1e-9, position_resolution=4.85e-5)
    assert e.value.parameter == "force_noise_budget"
