# SPDX-License-Identifier: Apache-2.0
"""The unit step response of the loop, exact at any time (step_response.hpp).

Normalised units (m = T = 1, F = 1): physical x = x_n F T^2/m, x' = x'_n F T/m, E = E_n F^2 T^2/m,
t = t_n T. Method: the loop state at the sample before t by the exact loop map, then exp(A tau)
inside the period: exact up to rounding (no time-stepping); defined for unstable gains too.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Optional

import numpy as np
import numpy.typing as npt

from . import _core
from .costs import _plant_args
from .parameters import Plant

__all__ = ["StepResponse", "step_response", "sampled_step_response"]


@dataclass(frozen=True)
class StepResponse:
    """x(t), x'(t) and E(t) = 1/2 (alpha + gamma) (x - x_inf)^2 + 1/2 x'^2 (eq. 4) on `time`;
    final_position x_inf = 1/(alpha + gamma)."""

    time: np.ndarray
    position: np.ndarray
    velocity: np.ndarray
    energy: np.ndarray
    final_position: float


def step_response(alpha: float, beta: float, time: npt.ArrayLike, plant: Optional[Plant] = None) -> StepResponse:
    """x(t), x'(t), E(t) of the unit step at each time (any shape and order, each finite and >= 0;
    at most 10^8 periods; otherwise InvalidParameterError naming `time`). Cost O(N^2 t_max) for the
    batch; GIL released."""
    t = np.ascontiguousarray(np.asarray(time, dtype=np.float64))
    x, v, e, x_inf = _core.step_response(*_plant_args(plant), float(alpha), float(beta), t)
    return StepResponse(t, x, v, e, float(x_inf))


def sampled_step_response(alpha: float, beta: float, samples: int, plant: Optional[Plant] = None) -> np.ndarray:
    """x_j = x(j), j = 0 .. samples - 1 (the samples the wall controller sees)."""
    return _core.sampled_step_response(*_plant_args(plant), float(alpha), float(beta), int(samples))
