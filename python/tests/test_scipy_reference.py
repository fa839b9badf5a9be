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
