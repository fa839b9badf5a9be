# SPDX-License-Identifier: Apache-2.0
"""The velocity estimator in the Python API (estimator=): against the C++ CLI's JSON and against an
independent numpy simulation of the sampled loop.

CLI agreement: same library, the extension compiled by pip (-O3) and the CLI by CMake (-O2): a few ulp
of difference amplified by the Stein solves' conditioning ~1/(1 - rho)^2 (<= 1e3 at these points, rho
<= 0.97): relative 1e-11 for the closed-form costs, g_F and the spectral radius. The optimum: the
optimisers stop at 1e-10 relative in alpha and Brent's ~1e-8 in beta, so a few-ulp different surface
moves the point by up to that: absolute 1e-8 (alpha, beta are O(0.1)); the cost is flat at the minimum
(quadratic in the shift): relative 1e-9; g_F is not flat there (first order in the shift, |grad g_F| <= 1e2
at these points): relative 1e-6.
"""
from __future__ import annotations

import json
import math
import subprocess

import numpy as np
import pytest

import hapticopt as ho

ESTIMATORS = ["lowpass:0.02", "lowpass:0.1", "window:15", "window:3", "backward"]
POINTS = [(0.004, 0.1, 1.0), (0.003, 0.07, 1.0), (0.002, 0.05, 0.0), (0.004, 0.1, 2.0)]  # alpha, beta, d


def run_json(cli, *args):
    out = subprocess.run([cli, *args, "--json"], check=True, capture_output=True, text=True).stdout
    return json.loads(out)


def close(value, cli_value, rtol):
    if cli_value is None:  # the CLI prints null for +inf (unstable)
        return value is None or math.isinf(value)
    return math.isclose(value, cli_value, rel_tol=rtol, abs_tol=0.0)


@pytest.mark.parametrize("estimator", ESTIMATORS)
@pytest.mark.parametrize("alpha,beta,delay", POINTS)
def test_costs_with_an_estimator_match_the_cli(cli, estimator, alpha, beta, delay):
    expected = run_json(cli, "cost", "--alpha", repr(alpha), "--beta", repr(beta), "--delay", repr(delay),
                        "--velocity", estimator)
    c = ho.costs(alpha, beta, ho.Plant(delay=delay), estimator=estimator)
    assert c.stable == expected["stable"]
    assert math.isclose(c.spectral_radius, expected["spectral_radius"], rel_tol=1e-11)
    for name in ("CE0", "CE1", "CE2", "OV"):
        assert close(c[name], expected[name], 1e-11), name
    assert close(c.force_noise_gain, expected["force_noise_gain"], 1e-11)
    assert c.stable == ho.is_stable(alpha, beta, ho.Plant(delay=delay), estimator=estimator)
    for name in ("CI0", "CI1", "CI2"):
        assert close(c[name], expected[name], 1e-11), name
    assert close(c.penetration, expected["penetration"], 1e-11)
    assert close(c.passivity_margin, expected["passivity_margin"], 1e-11)


@pytest.mark.parametrize("criterion", ["CE2", "CI2"])
@pytest.mark.parametrize("estimator", ["lowpass:0.1", "window:5", "backward"])
def test_passive_optimum_with_an_estimator_matches_the_cli(cli, criterion, estimator):
    # The point and cost as for the unconstrained optimum (module docstring). The margin is Lipschitz in the
    # gains: |d mu| <= (d + 1/2) |d alpha| + c |d beta| with c = max_theta of the damper's coefficient in R,
    # 1 for the window and (1 + lambda)/(1 - lambda) = 3.3 for the low-pass nu = 0.1, so the points' 1e-8
    # give at most 5e-8: absolute 1e-7.
    plant = ho.Plant(delta=0.02, delay=1.0)
    expected = run_json(cli, "optimum", "--criterion", criterion, "--passive", "--delay", "1", "--delta", "0.02",
                        "--velocity", estimator)
    p = ho.passive_optimum(criterion, plant, estimator=estimator)
    assert p is not None and p.velocity_estimator == ho.velocity_estimator(estimator)
    assert abs(p.alpha - expected["alpha"]) <= 1e-8
    assert abs(p.beta - expected["beta"]) <= 1e-8
    assert math.isclose(p.cost, expected["cost"], rel_tol=1e-9)
    assert abs(p.margin - expected["passivity_margin"]) <= 1e-7
    # Reported passive: the margin with the estimator at the point (>= 0 up to the beta bisection's 1e-12) and
    # stable by the estimator loop's Schur-Cohn test.
    assert ho.passivity_margin(p.alpha, p.beta, plant, estimator=estimator) == p.margin
    assert p.margin >= -1e-12
    assert ho.is_stable(p.alpha, p.beta, plant, estimator=estimator)
    if estimator == "backward":
        assert p == ho.passive_optimum(criterion, plant)


def test_passivity_with_an_estimator_is_not_the_backward_passivity():
    # At d = 1, delta = 0.02 the backward difference's passive C_E2 optimum damps less than the window's passive
    # set allows (docs/velocity-estimation.md): the window's optimum is not passive with the backward difference.
    plant = ho.Plant(delta=0.02, delay=1.0)
    w = ho.passive_optimum("CE2", plant, estimator="window:5")
    assert ho.passivity_margin(w.alpha, w.beta, plant, estimator="window:5") >= -1e-12
    assert ho.passivity_margin(w.alpha, w.beta, plant) < 0
    assert ho.passive_optimum("CE2", ho.Plant(delay=1.0), estimator="lowpass:0.1") is None  # delta = 0


def test_the_paper_optimum_is_unstable_behind_the_filters():
    # The paper's C_E2 optimum at d = 1 (Table III) behind a 20 Hz low-pass at 1 kHz and a 15-sample window:
    # unstable (the spectral radius of the estimator's loop matrix above 1); stable with the backward difference.
    plant = ho.Plant(delay=1.0)
    assert ho.stability(0.0582, 0.3796, plant).stable
    for estimator in ("lowpass:0.02", ho.VelocityEstimator.moving_window(15)):
        s = ho.stability(0.0582, 0.3796, plant, estimator=estimator)
        assert not s.stable and s.spectral_radius > 1.0
        assert math.isinf(ho.force_noise_gain(0.0582, 0.3796, plant, estimator=estimator))


@pytest.mark.parametrize("criterion", ["CE0", "CE2", "amax", "CE2+OV"])
@pytest.mark.parametrize("estimator", ["lowpass:0.02", "window:15"])
def test_optimum_with_an_estimator_matches_the_cli(cli, criterion, estimator):
    expected = run_json(cli, "optimum", "--criterion", criterion, "--delay", "1", "--velocity", estimator)
    o = ho.optimal_point(criterion, ho.Plant(delay=1.0), estimator=estimator)
    assert abs(o.alpha - expected["alpha"]) <= 1e-8
    assert abs(o.beta - expected["beta"]) <= 1e-8
    assert math.isclose(o.alpha_max, expected["alpha_max"], rel_tol=1e-10)
    if expected["cost"] is None:
        assert o.cost is None
    else:
        assert math.isclose(o.cost, expected["cost"], rel_tol=1e-9)
    if criterion != "amax":
        # amax's point is on the stability boundary (alpha_max to ~1e-14): g_F grows without bound there and is
        # finite or not by rounding, which the -O3 extension and the -O2 CLI need not share.
        assert math.isclose(o.force_noise_gain, expected["force_noise_gain"], rel_tol=1e-6)
    assert len(o.stable_islands) == len(expected["stable_islands"])
    assert str(o.velocity_estimator) == estimator


def test_physical_wall_with_a_cutoff_in_hertz(cli):
    # 0.30 kg, 1 kHz, 1 ms delay: lowpass:20Hz is nu = 0.02 (the CLI converts with --period as well).
    plant = ho.PhysicalPlant(mass=0.3, period=1e-3, time_delay=1e-3)
    w = ho.optimal_wall("CE2", plant, estimator="lowpass:20Hz")
    expected = run_json(cli, "optimum", "--criterion", "CE2", "--mass", "0.3", "--period", "0.001", "--time-delay",
                        "0.001", "--velocity", "lowpass:20Hz")
    assert math.isclose(w.K, expected["K"], rel_tol=1e-6) and math.isclose(w.B, expected["B"], rel_tol=1e-6)
    sigma = ho.force_noise_std(ho.WallGains(w.K, w.B), plant, 1e-5, estimator="lowpass:20Hz")
    c = run_json(cli, "cost", "--alpha", repr(w.alpha), "--beta", repr(w.beta), "--delay", "1", "--mass", "0.3",
                 "--period", "0.001", "--position-resolution", "1e-5", "--velocity", "lowpass:20Hz")
    assert math.isclose(sigma, c["force_noise_std"], rel_tol=1e-9)  # K, B round trip: a few ulp


def simulated_noise_gain(alpha, beta, delay, estimator, steps=40000):
    """g_F by an independent route: the impulse response h_j of the commanded force to one rounding error
    e_0 = 1 on the measured position, simulated through the exact sampled double integrator (m = T = 1,
    gamma = delta = 0, integer delay d: the force f_{j-d} acts over period j); white e of variance 1/12 gives
    var(f) = sum_j h_j^2 / 12. Truncated after `steps` periods (the tail is below rho^steps)."""
    e = ho.velocity_estimator(estimator)
    lam = math.exp(-2 * math.pi * e.cutoff) if e.kind == "lowpass" else 0.0
    n = e.window if e.kind == "window" else 1
    x = v = 0.0
    y = np.zeros(steps)
    f = np.zeros(steps)
    vel = 0.0
    for j in range(steps):
        y[j] = x + (1.0 if j == 0 else 0.0)
        if e.kind == "lowpass":
            vel = lam * vel + (1 - lam) * (y[j] - (y[j - 1] if j >= 1 else 0.0))
        else:
            vel = (y[j] - (y[j - n] if j >= n else 0.0)) / n
        f[j] = alpha * y[j] + beta * vel
        u = -(f[j - delay] if j >= delay else 0.0)
        x, v = x + v + 0.5 * u, v + u
    return math.sqrt(float(np.sum(f * f)) / 12.0), f


@pytest.mark.parametrize("estimator", ["backward", "lowpass:0.02", "lowpass:0.1", "window:15", "window:4"])
@pytest.mark.parametrize("alpha,beta,delay", [(0.004, 0.1, 1), (0.002, 0.05, 0), (0.003, 0.08, 2)])
def test_noise_gain_against_an_impulse_response_simulation(estimator, alpha, beta, delay):
    plant = ho.Plant(delay=float(delay))
    g = ho.force_noise_gain(alpha, beta, plant, estimator=estimator)
    simulated, f = simulated_noise_gain(alpha, beta, delay, estimator)
    assert abs(f[-200:]).max() < 1e-12 * abs(f).max()  # the truncated tail is negligible
    # Summation of 4e4 squares in double: relative error <= ~1e-12; the Stein solve ~1e-13 / (1 - rho^2).
    assert math.isclose(g, simulated, rel_tol=1e-9)


def test_window_one_is_the_backward_difference():
    plant = ho.Plant(delay=1.0)
    a = ho.costs(0.0582, 0.3796, plant)
    b = ho.costs(0.0582, 0.3796, plant, estimator="window:1")
    for name in ("CE0", "CE1", "CE2"):
        assert math.isclose(a[name], b[name], rel_tol=1e-10)  # two methods: 1e-10 (the C++ tests' tolerance)
    assert math.isclose(a.force_noise_gain, b.force_noise_gain, rel_tol=1e-12)  # the same Stein solve


def test_parse_mirrors_the_cli():
    assert ho.VelocityEstimator.parse("lowpass:0.02") == ho.VelocityEstimator.lowpass(0.02)
    assert ho.VelocityEstimator.parse("lowpass:20Hz", 1e-3).cutoff == pytest.approx(0.02, rel=1e-15)
    assert ho.VelocityEstimator.parse("window:15") == ho.VelocityEstimator.moving_window(15)
    assert ho.VelocityEstimator.parse("backward") == ho.VelocityEstimator()
    assert str(ho.VelocityEstimator.parse("window:15")) == "window:15"


@pytest.mark.parametrize("text,parameter", [("window:0", "window"), ("window:1001", "window"),
                                            ("lowpass:-1", "cutoff"), ("lowpass:0", "cutoff")])
def test_out_of_range_estimators_name_the_parameter(text, parameter):
    with pytest.raises(ho.InvalidParameterError) as info:
        ho.force_noise_gain(0.004, 0.1, estimator=text)
    assert info.value.parameter == parameter


@pytest.mark.parametrize("text,word", [("window:2.5", "window"), ("lowpass:abc", "cutoff"),
                                       ("lowpass:20Hz", "period"), ("median:3", "velocity")])
def test_malformed_estimators_are_value_errors(text, word):
    with pytest.raises(ValueError, match=word):
        ho.costs(0.004, 0.1, estimator=text)
    with pytest.raises(TypeError):
        ho.costs(0.004, 0.1, estimator=15)


@pytest.mark.parametrize("estimator,budget", [("lowpass:0.02", 0.002), ("backward", 0.05), ("window:5", 0.01),
                                              ("lowpass:0.02", 0.01)])
def test_noise_budget_optimum_matches_the_cli(cli, estimator, budget):
    # Same library: the point along the curve g_F = g_max by Brent (1e-10 in log alpha) and bisection (1e-13 of the
    # beta interval); a few-ulp different surface moves it by up to that: alpha, beta relative 1e-7; the cost
    # is flat along the curve at its minimum: relative 1e-9.
    expected = run_json(cli, "optimum", "--criterion", "CE2", "--delay", "1", "--velocity", estimator,
                        "--noise-budget", repr(budget))
    o = ho.optimal_point_under_noise_budget("CE2", budget, ho.Plant(delay=1.0), estimator=estimator)
    assert o.force_noise_gain <= budget
    assert o.budget_active == expected["budget_active"]
    assert math.isclose(o.alpha, expected["alpha"], rel_tol=1e-7)
    assert math.isclose(o.beta, expected["beta"], rel_tol=1e-7)
    assert math.isclose(o.cost, expected["cost"], rel_tol=1e-9)
    # The point really has the g_F it reports (an independent route: the impulse-response simulation).
    simulated, _ = simulated_noise_gain(o.alpha, o.beta, 1, estimator, steps=60000)
    assert math.isclose(o.force_noise_gain, simulated, rel_tol=1e-8)


def test_noise_pareto_front_and_bad_budgets():
    plant = ho.Plant(delay=1.0)
    front = ho.noise_pareto_front("CE2", [1e-12, 1e-3, 3e-3, 1e-2], plant, estimator="lowpass:0.02")
    assert [p.noise_budget for p in front] == [1e-3, 3e-3, 1e-2]  # 1e-12: no stable gains meet it, left out
    assert all(p.force_noise_gain <= p.noise_budget for p in front)
    assert front[0].cost >= front[1].cost >= front[2].cost
    with pytest.raises(ho.InvalidParameterError) as info:
        ho.optimal_point_under_noise_budget("CE2", -1.0, plant, estimator="lowpass:0.02")
    assert info.value.parameter == "noise_budget"
    with pytest.raises(ValueError, match="amax, OV, CE0, CE1, CE2, CE0\\+OV"):
        ho.optimal_point_under_noise_budget("CI2", 0.01, plant)
