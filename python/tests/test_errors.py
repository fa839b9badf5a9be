# SPDX-License-Identifier: Apache-2.0
"""Bad input raises ValueError (InvalidParameterError) naming the parameter and the accepted range."""
from __future__ import annotations

import math

import numpy as np
import pytest

import hapticopt as ho


def check(error, parameter):
    message = str(error.value)
    assert isinstance(error.value, ValueError)
    assert parameter in message and "accepted" in message, message


@pytest.mark.parametrize("kwargs,parameter", [
    (dict(gamma=-1.0), "gamma"), (dict(delta=math.nan), "delta"), (dict(delay=-0.5), "delay"),
    (dict(delay=5000.0), "delay"),
])
def test_bad_plant(kwargs, parameter):
    with pytest.raises(ho.InvalidParameterError) as error:
        ho.Plant(**kwargs)
    check(error, parameter)
    assert error.value.parameter == parameter


@pytest.mark.parametrize("kwargs,parameter", [
    (dict(mass=-0.3, period=0.001), "mass"), (dict(mass=0.3, period=0.0), "period"),
    (dict(mass=0.3, period=0.001, damping=-1.0), "damping"), (dict(mass=math.inf, period=0.001), "mass"),
])
def test_bad_physical_plant(kwargs, parameter):
    with pytest.raises(ValueError) as error:
        ho.PhysicalPlant(**kwargs)
    check(error, parameter)


def test_bad_gains_and_options():
    with pytest.raises(ValueError) as e:
        ho.costs(math.nan, 0.3)
    check(e, "alpha")
    assert e.value.parameter == "alpha" and math.isnan(e.value.value)
    with pytest.raises(ValueError) as e:
        ho.stability(0.1, math.inf)
    check(e, "beta")
    with pytest.raises(ValueError) as e:
        ho.overshoot(0.05, 0.3, tolerance=0.0)
    check(e, "tolerance")
    with pytest.raises(ValueError) as e:
        ho.cost("CE2", [0.1], [0.2], overshoot_tolerance=2.0)
    check(e, "overshoot_tolerance")
    with pytest.raises(ValueError) as e:
        ho.boundary(points=3)
    check(e, "points")
    with pytest.raises(ValueError) as e:
        ho.beta_range(5.0)
    check(e, "alpha")
    with pytest.raises(ValueError) as e:
        ho.step_response(0.05, 0.3, [0.0, -1.0])
    check(e, "time")
    with pytest.raises(ValueError) as e:
        ho.step_response(0.05, 0.3, [0.0, math.nan])
    check(e, "time")
    with pytest.raises(ValueError) as e:
        ho.step_response(0.05, 0.3, [1e9])  # beyond the 10^8-period cap: an error, not an hour-long loop
    check(e, "time")
    with pytest.raises(ValueError) as e:
        ho.sampled_step_response(0.05, 0.3, 10**9)
    check(e, "samples")
    with pytest.raises(ValueError) as e:
        ho.optimal_point("CE2", alpha_grid=1)
    check(e, "alpha_grid")
    with pytest.raises(ValueError) as e:
        ho.robust_optimum("CE2", mass=(0.3, 0.2), period=0.001)
    check(e, "mass.max")
    with pytest.raises(ValueError) as e:
        ho.passivity_margin(0.05, 0.3, ho.Plant(delta=0.02, delay=1.5))
    check(e, "delay")


@pytest.mark.parametrize("call", [
    lambda: ho.cost("CE3", 0.1, 0.2), lambda: ho.optimal_point("ce2"), lambda: ho.optimal_curve("amax", [0.1]),
    lambda: ho.robust_optimum("OV", mass=0.3, period=0.001), lambda: ho.passive_optimum("CE2+OV"),
    lambda: ho.costs(0.1, 0.2)["XX"],
])
def test_unknown_criterion_names_the_accepted_ones(call):
    with pytest.raises(ValueError) as error:
        call()
    assert "criterion" in str(error.value) and "accepted" in str(error.value)


def test_shape_mismatch_and_wrong_plant_type():
    with pytest.raises(ValueError):
        ho.cost("CE2", np.zeros(3), np.zeros(2))
    with pytest.raises(TypeError):
        ho.costs(0.1, 0.2, ho.PhysicalPlant(mass=0.3, period=0.001))
