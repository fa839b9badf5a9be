# SPDX-License-Identifier: Apache-2.0
"""The exact stable region in the (alpha, beta) plane (stability_region.hpp).

D-decomposition: on the boundary a characteristic root lies on the unit circle; for z = e^{i theta}
the equation p(z) = P_0(z) + alpha P_alpha(z) + beta P_beta(z) = 0 gives one point (alpha, beta) per
frequency theta in (0, theta_c); the region is closed by the segment alpha = -gamma. alpha_max is the
root of d alpha / d theta, accurate to ~1e-12 (its beta too: 12 - 8 sqrt(2) and 2 sqrt(2) - 2 for d = 0).
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Optional, Tuple

import numpy as np

from . import _core
from .costs import _plant_args
from .parameters import Plant

__all__ = ["Boundary", "boundary", "alpha_max", "beta_range"]


@dataclass(frozen=True)
class Boundary:
    """The closed boundary polygon (points of the complex-root branch from theta -> 0 to theta_c,
    then the line alpha = -gamma), the tip (alpha_max, beta_at_alpha_max), alpha_min = -gamma and
    the closing frequency theta_c."""

    theta: np.ndarray
    alpha: np.ndarray
    beta: np.ndarray
    alpha_max: float
    beta_at_alpha_max: float
    alpha_min: float
    closing_frequency: float


def boundary(plant: Optional[Plant] = None, points: int = 256) -> Boundary:
    """The stability boundary as a closed polygon of `points` + 1 vertices (8 <= points <= 10^7)."""
    return Boundary(**_core.boundary(*_plant_args(plant), int(points)))


def alpha_max(plant: Optional[Plant] = None) -> float:
    """The largest stable alpha (the stiffness limit of the wall, normalised)."""
    return boundary(plant, 8).alpha_max


def beta_range(alpha: float, plant: Optional[Plant] = None) -> Tuple[float, float]:
    """The open interval of stable beta at alpha, alpha_min < alpha <= alpha_max (~1e-15 in theta)."""
    lo, hi = _core.beta_range(*_plant_args(plant), float(alpha))
    return float(lo), float(hi)
