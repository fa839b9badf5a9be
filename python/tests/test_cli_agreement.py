# SPDX-License-Identifier: Apache-2.0
"""Python against the C++ CLI's JSON/CSV (apps/hapticopt): the same library behind both.

Agreement: the extension is compiled by pip (-O3) and the CLI by CMake (-O2), so the compiler may
order floating-point operations differently; rounding differences of a few ulp are amplified by the
conditioning of the Stein solves (~1/(1 - rho)^2 <= 1e2 at these points, rho <= 0.9): relative
1e-12 for the closed-form costs. The optimisers stop at alpha_tolerance 1e-10 and Newton-polish beta
to ~1e-10; a few-ulp different cost surface can move their answer by that much: absolute 1e-8 in
alpha and beta (the README's measured cross-implementation spread is 2.3e-8 over all 64 rows; 1e-8
holds for these rows) and relative 1e-9 in the cost (flat at the minimum: quadratic in the shift).
"""
from __future__ import annotations

import csv
import io
import json
import math
import subprocess

import numpy as np
import pytest

import hapticopt as ho

POINTS = [  # (alpha, beta, gamma, delta, delay): table optima, a fractional delay, an unstable pair
    (0.0582, 0.3796, 0.0, 0.0, 1.0),
    (0.3220, 0.9800, 0.0, 0.0, 0.0),
    (0.05, 0.3, 0.0005, 0.01, 2.0),
    (0.04, 0.25, 0.0, 0.0, 1.5),
    (0.5, 0.1, 0.0, 0.0, 1.0),
]


def run_json(cli, *args):
    out = subprocess.run([cli, *args, "--json"], check=True, capture_output=True, text=True).stdout
    return json.loads(out)


def plant_args(gamma, delta, delay):
    return ["--gamma", repr(gamma), "--delta", repr(delta), "--delay", repr(delay)]


def close(python_value, cli_value, rtol):
    if cli_value is None:  # the CLI prints null for +inf (unstable)
        return math.isinf(python_value)
    return math.isclose(python_value, cli_value, rel_tol=rtol, abs_tol=0.0)


@pytest.mark.parametrize("alpha,beta,gamma,delta,delay", POINTS)
def test_costs_match_the_cli(cli, alpha, beta, gamma, delta, delay):
    expected = run_json(cli, "cost", "--alpha", repr(alpha), "--beta", repr(beta), *plant_args(gamma, delta, delay))
    c = ho.costs(alpha, beta, ho.Plant(gamma, delta, delay))
    assert c.stable == expected["stable"]
    for name in ("CE0", "CE1", "CE2", "OV", "CI0", "CI1", "CI2"):
        assert close(c[name], expected[name], 1e-12), name
    assert close(c.penetration, expected["penetration"], 1e-12)
    assert math.isclose(c.spectral_radius, expected["spectral_radius"], rel_tol=1e-12)
    if c.stable:
        assert c.no_overshoot == expected["no_overshoot"]


@pytest.mark.parametrize("criterion", ["amax", "OV", "CE0", "CE2", "CE1+OV", "CI2"])
@pytest.mark.parametrize("delay", [1.0, 2.5])
def test_optimum_matches_the_cli(cli, criterion, delay):
    expected = run_json(cli, "optimum", "--criterion", criterion, "--delay", repr(delay))
    o = ho.optimal_point(criterion, ho.Plant(delay=delay))
    assert abs(o.alpha - expected["alpha"]) <= 1e-8
    assert abs(o.beta - expected["beta"]) <= 1e-8
    assert math.isclose(o.alpha_max, expected["alpha_max"], rel_tol=1e-12)
    if expected.get("cost") is None:
        assert o.cost is None
    else:
        assert math.isclose(o.cost, expected["cost"], rel_tol=1e-9)


def test_boundary_matches_the_cli(cli):
    out = subprocess.run([cli, "boundary", "--delay", "1", "--csv"], check=True, capture_output=True, text=True).stdout
    rows = list(csv.DictReader(io.StringIO(out)))
    b = ho.boundary(ho.Plant(delay=1.0), points=len(rows) - 1)
    # Same frequencies, same closed-form solve per point: 1e-12 relative to the region's size.
    np.testing.assert_allclose(b.theta, [float(r["theta"]) for r in rows], rtol=0, atol=1e-12)
    np.testing.assert_allclose(b.alpha, [float(r["alpha"]) for r in rows], rtol=0, atol=1e-12)
    np.testing.assert_allclose(b.beta, [float(r["beta"]) for r in rows], rtol=0, atol=1e-12)


def test_robust_optimum_matches_the_cli(cli):
    expected = run_json(cli, "optimum", "--criterion", "CE2", "--robust", "--mass", "0.22:0.30", "--period", "0.001",
                        "--time-delay", "0.001")
    r = ho.robust_optimum("CE2", mass=(0.22, 0.30), period=0.001, time_delay=0.001)
    # Same search on the same grid; the robust search's own tolerance (Brent over K) is ~1e-8 relative.
    assert math.isclose(r.stiffness, expected["K"], rel_tol=1e-7)
    assert math.isclose(r.damping, expected["B"], rel_tol=1e-7)
    assert (r.K, r.B) == (r.stiffness, r.damping)  # the CLI's (and hapticd's) names, the same numbers
    assert math.isclose(r.worst_cost, expected["worst_case"], rel_tol=1e-9)
    assert math.isclose(r.nominal_worst_cost, expected["nominal"]["worst_case"], rel_tol=1e-9)
    assert r.stable_over_box == expected["stable_over_box"]
    assert r.mass_segments_certified == expected["mass_segments_certified"]
    assert r.worst_at.mass == pytest.approx(expected["worst_case_at"]["mass"], rel=1e-9)


@pytest.mark.parametrize("delay", [0.0, 1.0])
def test_passive_optimum_matches_the_cli(cli, delay):
    expected = run_json(cli, "optimum", "--criterion", "CE2", "--passive", "--delta", "0.02", "--delay", repr(delay))
    p = ho.passive_optimum("CE2", ho.Plant(delta=0.02, delay=delay))
    # Same region search; its Brent tolerances put alpha and beta within ~1e-8 of the same minimiser.
    assert abs(p.alpha - expected["alpha"]) <= 1e-8 and abs(p.beta - expected["beta"]) <= 1e-8
    assert math.isclose(p.cost, expected["cost"], rel_tol=1e-9)
    assert expected["passive"] is True and p.margin >= 0
