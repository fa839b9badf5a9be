# SPDX-License-Identifier: Apache-2.0
"""hapticopt.mass_range_stability: fixed gains over an interval of moving masses (the hand gripping or letting go),
against the loop matrix's spectral radius (hapticopt.stability: the state-space model, not the crossing test) on
a dense grid of masses, for the backward difference and the shipped Falcon's window of 15 periods at 6 ms."""
from __future__ import annotations

import numpy as np
import pytest

import hapticopt as ho

T = 1e-3


def radius(K, B, m, d, estimator):
    return ho.stability(K * T * T / m, B * T / m, ho.Plant(delay=d), estimator=estimator).spectral_radius


@pytest.mark.parametrize("d,estimator", [(1, "backward"), (6, "window:15"), (2, "lowpass:0.02")])
def test_the_verdict_over_the_interval_agrees_with_a_dense_scan(d, estimator):
    tip = ho.optimal_point("amax", ho.Plant(delay=d), estimator=estimator)  # the region's size for this loop
    rng = np.random.default_rng(7)
    verdicts = set()
    for _ in range(12):
        alpha = rng.uniform(0.0, 1.2 * tip.alpha)
        beta = rng.uniform(0.0, 2.0 * tip.beta)
        K, B = alpha * 0.30 / T ** 2, beta * 0.30 / T
        r = ho.mass_range_stability(K, B, mass=(0.20, 0.33), period=T, time_delay=d * T, estimator=estimator)
        verdicts.add(r.stable)
        masses = np.linspace(0.20, 0.33, 301)
        rho = np.array([radius(K, B, m, d, estimator) for m in masses])
        if r.stable:
            assert r.failing_mass is None
            assert rho.max() < 1.0
            assert not any(0.20 <= m <= 0.33 for m in r.crossing_masses)
        else:
            assert 0.20 <= r.failing_mass <= 0.33
            assert radius(K, B, r.failing_mass, d, estimator) > 1.0 - 2e-6
        for m in r.crossing_masses:  # a root on the unit circle: the radius is at least 1 there
            if 0.05 < m < 5.0:
                assert radius(K, B, m, d, estimator) > 1.0 - 2e-6
    assert verdicts == {True, False}


def test_the_falcon_amax_wall_fails_when_the_hand_lets_go():
    e = "window:15"
    tip = ho.optimal_point("amax", ho.Plant(delay=6), estimator=e)
    K, B = tip.alpha * 0.999 * 0.30 / T ** 2, tip.beta * 0.30 / T
    held = ho.mass_range_stability(K, B, mass=0.30, period=T, time_delay=0.006, estimator=e)
    assert held.stable
    both = ho.mass_range_stability(K, B, mass=(0.22, 0.30), period=T, time_delay=0.006, estimator=e)
    assert not both.stable
    assert 0.22 <= both.failing_mass < 0.30
    assert radius(K, B, 0.22, 6, e) > 1.0


def test_bad_input_names_the_parameter():
    with pytest.raises(ho.InvalidParameterError, match="mass.min"):
        ho.mass_range_stability(1000.0, 10.0, mass=(0.0, 0.3), period=T)
    with pytest.raises(ho.InvalidParameterError, match="mass.max"):
        ho.mass_range_stability(1000.0, 10.0, mass=(0.3, 0.2), period=T)
    with pytest.raises(ho.InvalidParameterError, match="stiffness"):
        ho.mass_range_stability(float("nan"), 10.0, mass=0.3, period=T)
    with pytest.raises(ho.InvalidParameterError, match="period"):
        ho.mass_range_stability(1000.0, 10.0, mass=0.3, period=-1.0)
