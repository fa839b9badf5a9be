# SPDX-License-Identifier: Apache-2.0
"""Coulomb friction and encoder quantisation in the Python API (hapticopt.limit_cycles): against the C++ CLI's JSON
(`hapticopt limit-cycle --json`) and, for the rest condition, against its closed form written here with numpy.

CLI agreement: the same library, the extension compiled by pip (-O3) and the CLI by CMake (-O2), the plant and
gains converted by the same C++ functions, so the inputs are the same bits. The describing function ends in
bisections: the amplitude to 1e-12 of itself, the phase crossover to 1e-13 rad; a few ulp of difference in a
bisection's test can move its result by at most that bracket. Tolerance: relative 1e-10 for the amplitude and
the mean position, 1e-9 for the frequency (the crossover's 1e-13 rad is 2e-11 Hz at T = 1 ms, and it moves with
the amplitude through the friction's equivalent damping); booleans and the number of cycles exactly.
"""
from __future__ import annotations

import json
import math
import subprocess

import numpy as np
import pytest

import hapticopt as ho

MASS, PERIOD, STEP = 0.3, 1e-3, 20e-6
# The paper's C_E2 optima (Tables III, IV) at d = 0 and 1, and the library's at d = 6.
WALLS = [(0.2474, 0.7445, 0.0), (0.0582, 0.3796, 1.0), (0.00466432, 0.112281, 6.0)]


def run_json(cli, *args):
    out = subprocess.run([cli, *args, "--json"], check=True, capture_output=True, text=True).stdout
    return json.loads(out)


@pytest.mark.parametrize("alpha,beta,delay", WALLS)
@pytest.mark.parametrize("friction,depth", [(0.0, 100.5), (0.1, 100.5), (0.3, 100.25)])
def test_the_prediction_matches_the_cli(cli, alpha, beta, delay, friction, depth):
    plant = ho.to_physical_plant(ho.Plant(delay=delay), MASS, PERIOD)
    gains = ho.to_physical(ho.Gains(alpha, beta), MASS, PERIOD)
    push = gains.stiffness * STEP * depth
    expected = run_json(cli, "limit-cycle", "--alpha", repr(alpha), "--beta", repr(beta), "--delay", repr(delay),
                        "--mass", repr(MASS), "--period", repr(PERIOD), "--position-resolution", repr(STEP),
                        "--coulomb-friction", repr(friction), "--push", repr(push))
    p = ho.predict_limit_cycle(gains, plant, STEP, coulomb_friction=friction, push=push)
    assert p.predicted == expected["limit_cycle_predicted"]
    assert p.rest_exists == expected["rest_exists"]
    assert p.grows_at_large_amplitude == expected["grows_at_large_amplitude"]
    assert len(p.cycles) == len(expected["cycles"])
    for got, want in zip(p.cycles, expected["cycles"]):
        assert got.stable == want["stable"]
        assert math.isclose(got.amplitude, want["amplitude"], rel_tol=1e-10)
        assert math.isclose(got.frequency, want["frequency"], rel_tol=1e-9)
        assert math.isclose(got.mean_position, want["mean_position"], rel_tol=1e-10, abs_tol=1e-10 * STEP)
    if p.predicted:
        assert p.cycle is not None
        assert math.isclose(p.cycle.amplitude, expected["limit_cycle"]["amplitude"], rel_tol=1e-10)
    else:
        assert p.cycle is None and expected["limit_cycle"] is None
    ao = ho.abbott_okamura_passivity(gains, plant, friction, STEP)
    assert ao.passive == expected["abbott_okamura"]["passive"]
    assert ao.stiffness_bound == expected["abbott_okamura"]["stiffness_bound"]


def test_the_rest_condition_is_its_closed_form():
    # With no plant spring a rest holds the push F iff K q min(r, 1 - r) <= f_c, r the fractional part of F / (K q)
    # (limit_cycles.hpp, item 3). Pushes placed at fractions away from the decision boundary by far more than
    # rounding (>= 1e-3 of a count).
    gains = ho.WallGains(17460.0, 113.9)
    kq = gains.stiffness * STEP
    for fraction in np.linspace(0.0, 0.999, 37):
        for friction in (0.0, 0.05, 0.1, 0.2):
            distance = kq * min(fraction, 1.0 - fraction)
            if abs(distance - friction) < 1e-3 * kq:
                continue
            push = kq * (40.0 + fraction)
            assert ho.quantised_rest_exists(push, gains, friction, STEP) == (distance <= friction), (fraction, friction)
    # Every push has a rest exactly when K <= 2 f_c / q (Abbott & Okamura's Coulomb bound).
    assert ho.abbott_okamura_passivity(gains, ho.PhysicalPlant(MASS, PERIOD), kq / 2 * 1.001, STEP).passive
    assert not ho.abbott_okamura_passivity(gains, ho.PhysicalPlant(MASS, PERIOD), kq / 2 * 0.999, STEP).passive


def test_bad_values_are_named():
    plant = ho.PhysicalPlant(MASS, PERIOD)
    gains = ho.WallGains(1000.0, 10.0)
    with pytest.raises(ho.InvalidParameterError, match="position_step"):
        ho.predict_limit_cycle(gains, plant, 0.0)
    with pytest.raises(ho.InvalidParameterError, match="coulomb_friction"):
        ho.predict_limit_cycle(gains, plant, STEP, coulomb_friction=-1.0)
    with pytest.raises(ho.InvalidParameterError, match="external_force"):
        ho.predict_limit_cycle(gains, plant, STEP, push=math.nan)
    with pytest.raises(ho.InvalidParameterError, match="gains.stiffness"):
        ho.predict_limit_cycle(ho.WallGains(0.0, 10.0), plant, STEP)
    with pytest.raises(ho.InvalidParameterError, match="position_step"):
        ho.quantised_rest_exists(1.0, gains, 0.1, -STEP)
    with pytest.raises(ho.InvalidParameterError, match="coulomb_friction"):
        ho.abbott_okamura_passivity(gains, plant, -0.1, STEP)
