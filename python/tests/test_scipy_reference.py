# SPDX-License-Identifier: Apache-2.0
"""The library's closed-form costs against the independent scipy reference (scipy_reference.py).

Agreement, stated per point: |library - reference| / reference <= 1e-10 + 1e-12 + 100 eps kappa, where
 - 1e-10 is the library's documented accuracy for spectral radius rho <= 0.999 (energy_costs.hpp;
   every point here has rho <= 0.99, asserted);
 - 1e-12 covers the reference's quadrature (quad_vec, epsrel 1e-13, on Gramians of positive
   integrands, so the relative error carries over to the traces) with a margin of 10;
 - 100 eps kappa bounds the reference's Lyapunov solves (backward stable; kappa = cond(I - M (x) M),
   computed at the point; 100 covers the three chained solves and the dimension n^2 <= 36).
"""
from __future__ import annotations

import math

import numpy as np
import pytest

import hapticopt as ho
from scipy_reference import ReferenceLoop

EPS = np.finfo(float).eps


def points():
    """Per delay d = 0..3: the CE2 optimum, a stiffer point and a point with gamma, delta > 0."""
    out = []
    for d in range(4):
        for gamma, delta in ((0.0, 0.0), (0.0008, 0.015)):
            plant = ho.Plant(gamma, delta, float(d))
            o = ho.optimal_point("CE2", plant)
            out.append((plant, o.alpha, o.beta))
            a = 0.6 * o.alpha_max
            lo, hi = ho.beta_range(a, plant)
            out.append((plant, a, lo + 0.4 * (hi - lo)))
    return out


POINTS = points()


@pytest.mark.parametrize("plant,alpha,beta", POINTS,
                         ids=[f"d{p.delay:g}-g{p.gamma:g}-a{a:.4f}-b{b:.4f}" for p, a, b in POINTS])
def test_costs_agree_with_the_scipy_reference(plant, alpha, beta):
    ref = ReferenceLoop(alpha, beta, plant.gamma, plant.delta, int(plant.delay)).reference()
    assert ref.spectral_radius <= 0.99
    c = ho.costs(alpha, beta, plant)
    assert math.isclose(c.spectral_radius, ref.spectral_radius, rel_tol=1e-12)
    tolerance = 1e-10 + 1e-12 + 100 * EPS * ref.kronecker_condition
    for name, value in zip(("CE0", "CE1", "CE2"), ref.step):
        assert abs(c[name] - value) <= tolerance * value, (name, c[name], value, tolerance)
    for name, value in zip(("CI0", "CI1", "CI2"), ref.collision):
        assert abs(c[name] - value) <= tolerance * value, (name, c[name], value, tolerance)


@pytest.mark.parametrize("delay", [0, 1, 3])
def test_step_response_agrees_with_the_scipy_reference(delay):
    plant = ho.Plant(0.0005, 0.01, float(delay))
    o = ho.optimal_point("CE1", plant)
    loop = ReferenceLoop(o.alpha, o.beta, plant.gamma, plant.delta, delay)
    times = np.array([0.0, 0.37, 1.0, 2.5, 7.93, 20.0])
    r = ho.step_response(o.alpha, o.beta, times, plant)
    expected = np.array([loop.step_position(t) for t in times])
    # Both exact up to rounding: expm (Pade, ~1e-15 relative) propagated over <= 20 periods of a
    # contracting loop; 1e-12 of x_inf covers ~20 steps of a few ulp each with a margin of 10.
    np.testing.assert_allclose(r.position, expected, rtol=0, atol=1e-12 * r.final_position)


@pytest.mark.parametrize("delay,criterion", [(0, "CE2"), (1, "CE2"), (2, "CE1"), (3, "CE0")])
def test_overshoot_is_the_supremum_of_the_scipy_samples(delay, criterion):
    """C_OV (eq. 9) is a continuous-time maximum: every sample of the reference step response is at
    most x_inf (1 + C_OV), and the best of 400 samples per period comes within the sampling error
    of a smooth maximum, |x''| h^2 / 8 for spacing h (half a spacing to the true maximum), doubled
    for the variation of x'' over that interval, plus 1e-12 x_inf of rounding."""
    plant = ho.Plant(0.0005, 0.01, float(delay))
    o = ho.optimal_point(criterion, plant)
    ov = ho.overshoot(o.alpha, o.beta, plant)
    assert ov.value > 1e-4 and ov.converged  # these optima overshoot visibly
    loop = ReferenceLoop(o.alpha, o.beta, plant.gamma, plant.delta, delay)
    per_period = 400
    periods = int(np.ceil(ov.time)) + 40  # well past the maximum (the proven stop lies within this)
    x = loop.step_positions_on_grid(periods, per_period).ravel()
    x_inf = 1.0 / (o.alpha + plant.gamma)
    exact_max = x_inf * (1 + ov.value)
    k = int(np.argmax(x))
    h = 1.0 / per_period
    curvature = abs(x[k - 1] - 2 * x[k] + x[k + 1]) / h ** 2
    assert x[k] <= exact_max + 1e-12 * x_inf
    assert exact_max - x[k] <= 2 * curvature * h ** 2 / 8 + 1e-12 * x_inf
    assert abs(k * h - ov.time) <= h  # the same maximum, found at the same time
