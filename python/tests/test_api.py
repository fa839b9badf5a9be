# SPDX-License-Identifier: Apache-2.0
"""The Python API: version from the one source, conversions, dataclasses, optima, passivity."""
from __future__ import annotations

import dataclasses
import importlib.metadata
import math
import re

import numpy as np
import pytest

import hapticopt as ho
from conftest import VERSION_HEADER


def test_version_is_the_libraries():
    header = VERSION_HEADER.read_text()
    version = re.search(r'#define HAPTICOPT_VERSION_STRING "([^"]+)"', header).group(1)
    assert ho.__version__ == version
    assert importlib.metadata.version("hapticopt") == version
    # The C++ build's project(VERSION) must say the same (the package reads version.hpp only).
    cmake = (VERSION_HEADER.parents[2] / "CMakeLists.txt").read_text()
    assert re.search(r"project\(hapticopt\s+VERSION\s+([0-9.]+)", cmake).group(1) == version


def test_normalize_and_back():
    device = ho.PhysicalPlant(mass=0.3, period=0.001, damping=2.0, stiffness=10.0, time_delay=0.0025)
    p = ho.normalize(device)
    assert p == ho.Plant(10.0 * 1e-6 / 0.3, 2.0 * 0.001 / 0.3, 2.5)  # Table I
    back = ho.to_physical_plant(p, 0.3, 0.001)
    assert math.isclose(back.damping, 2.0, rel_tol=1e-15) and math.isclose(back.time_delay, 0.0025, rel_tol=1e-15)
    g = ho.to_physical(ho.Gains(0.0582, 0.3796), 0.3, 0.001)
    assert math.isclose(g.stiffness, 0.0582 * 0.3 / 1e-6, rel_tol=1e-15)  # eq. 3
    assert ho.normalize_gains(g, 0.3, 0.001).alpha == pytest.approx(0.0582, rel=1e-15)


def test_results_are_dataclasses():
    for value in (ho.costs(0.05, 0.3), ho.stability(0.05, 0.3), ho.optimal_point("CE2"), ho.boundary(),
                  ho.step_response(0.05, 0.3, [1.0]), ho.overshoot(0.05, 0.3)):
        assert dataclasses.is_dataclass(value)


def test_stability_at_the_exact_boundary_point():
    # d = 0, gamma = delta = 0: alpha_max = 12 - 8 sqrt(2) at beta = 2 sqrt(2) - 2 (Hulin et al. 2011).
    a, b = 12 - 8 * math.sqrt(2), 2 * math.sqrt(2) - 2
    assert ho.alpha_max() == pytest.approx(a, abs=1e-12)
    assert ho.is_stable(a - 1e-9, b) and not ho.is_stable(a + 1e-9, b)
    s = ho.stability(0.0582, 0.3796, ho.Plant(delay=1.0))
    assert s.stable and 0 < s.spectral_radius < 1


def test_step_response_at_the_samples_equals_the_sampled_response():
    plant = ho.Plant(delay=1.0)
    r = ho.step_response(0.0582, 0.3796, np.arange(30.0), plant)
    x = ho.sampled_step_response(0.0582, 0.3796, 30, plant)
    # Same loop map; the continuous version adds expm(A * 0) = I: equal to rounding of x_inf + xi.
    np.testing.assert_allclose(r.position, x, rtol=0, atol=1e-13 * r.final_position)
    assert r.final_position == pytest.approx(1 / 0.0582)
    # The overshoot maximum is the continuous-time one: at least every sampled value.
    ov = ho.overshoot(0.0582, 0.3796, plant)
    assert (1 + ov.value) * r.final_position >= r.position.max()


def test_optimal_wall_is_the_normalised_optimum_in_physical_units():
    device = ho.PhysicalPlant(mass=0.3, period=0.001)
    t = ho.optimal_wall("CE2", device)
    o = ho.optimal_point("CE2", ho.Plant())
    assert t.alpha == o.alpha and t.beta == o.beta
    assert math.isclose(t.stiffness, o.alpha * 0.3 / 1e-6, rel_tol=1e-15)
    assert math.isclose(t.damping, o.beta * 0.3 / 1e-3, rel_tol=1e-15)
    assert 0 < t.stability_margin < 1
    # K and B (the C++ library's and hapticd's names) are the same numbers as stiffness and damping.
    assert (t.K, t.B) == (t.stiffness, t.damping)
    g = ho.to_physical(ho.Gains(o.alpha, o.beta), 0.3, 0.001)
    assert (g.K, g.B) == (g.stiffness, g.damping)


def test_collision_optimum_fields():
    o = ho.optimal_point("CI2", ho.Plant(delay=1.0))
    assert o.penetration > 0 and o.on_region_edge is False and o.cost > 0
    assert o.cost <= ho.cost("CI2", o.alpha, o.beta * 1.01, ho.Plant(delay=1.0))


def test_passive_optimum_is_passive_whenever_reported():
    assert ho.passive_optimum("CE2", ho.Plant(delay=1.0)) is None  # delta = 0: nothing is passive
    for plant in (ho.Plant(delta=0.02), ho.Plant(delta=0.02, delay=1.0)):
        p = ho.passive_optimum("CE2", plant)
        assert p is not None and p.margin >= 0
        assert ho.passivity_margin(p.alpha, p.beta, plant) == pytest.approx(p.margin, abs=1e-12)
        assert ho.is_stable(p.alpha, p.beta, plant)
        # The step optimum itself is not passive (Hulin et al.'s remark; README: margins < 0).
        o = ho.optimal_point("CE2", plant)
        assert not ho.is_passive(o.alpha, o.beta, plant)
        assert p.cost > o.cost


def test_costs_fractional_delay_has_no_passivity_margin():
    c = ho.costs(0.04, 0.25, ho.Plant(delay=1.5))
    assert c.passivity_margin is None and c.stable
