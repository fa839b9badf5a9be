# SPDX-License-Identifier: Apache-2.0
"""Plant and gain parameters, physical and normalised (Hulin et al. 2011, Table I and eq. 3).

    alpha = K T^2/m,  beta = B T/m,  gamma = k T^2/m,  delta = b T/m,  d = t_d/T;
    back:  K = alpha m/T^2,  B = beta m/T.

In normalised units m = T = 1; every criterion of the package is dimensionless and depends on the
normalised parameters only. The conversions are the C++ library's (parameters.hpp): exact up to
one rounding per product.
"""
from __future__ import annotations

from dataclasses import dataclass

from . import _core

__all__ = ["Plant", "PhysicalPlant", "Gains", "WallGains", "normalize", "normalize_gains", "to_physical",
           "to_physical_plant"]


@dataclass(frozen=True)
class Plant:
    """The normalised plant: gamma = k T^2/m >= 0, delta = b T/m >= 0, delay d = t_d/T in [0, 1000]
    (integer or fractional). Invalid values raise InvalidParameterError (a ValueError) naming the
    parameter and its accepted range."""

    gamma: float = 0.0
    delta: float = 0.0
    delay: float = 0.0

    def __post_init__(self) -> None:
        _core.validate_plant(float(self.gamma), float(self.delta), float(self.delay))


@dataclass(frozen=True)
class PhysicalPlant:
    """Device + arm (eq. 1) and loop: mass m [kg] > 0, period T [s] > 0, damping b [N s/m] >= 0,
    stiffness k [N/m] >= 0, loop delay t_d [s] >= 0 (need not be a multiple of T)."""

    mass: float
    period: float
    damping: float = 0.0
    stiffness: float = 0.0
    time_delay: float = 0.0

    def __post_init__(self) -> None:
        normalize(self)  # validates, with the library's message

    def normalized(self) -> Plant:
        """Table I: (gamma, delta, d)."""
        return normalize(self)


@dataclass(frozen=True)
class Gains:
    """Normalised wall gains: alpha = K T^2/m, beta = B T/m."""

    alpha: float
    beta: float


@dataclass(frozen=True)
class WallGains:
    """Physical wall gains: stiffness K [N/m], damping B [N s/m]. `K` and `B` are the names of the C++
    library and of hapticd's protocol; `stiffness` and `damping` are the same numbers."""

    stiffness: float
    damping: float

    @property
    def K(self) -> float:  # noqa: N802 (the paper's and the protocol's name)
        """The stiffness [N/m]."""
        return self.stiffness

    @property
    def B(self) -> float:  # noqa: N802
        """The damping [N s/m]."""
        return self.damping


def normalize(plant: PhysicalPlant) -> Plant:
    """Table I: gamma = k T^2/m, delta = b T/m, d = t_d/T."""
    gamma, delta, delay = _core.normalize_plant(float(plant.mass), float(plant.damping), float(plant.stiffness),
                                                float(plant.period), float(plant.time_delay))
    return Plant(gamma, delta, delay)


def normalize_gains(gains: WallGains, mass: float, period: float) -> Gains:
    """Table I: alpha = K T^2/m, beta = B T/m."""
    alpha, beta = _core.normalize_gains(float(gains.stiffness), float(gains.damping), float(mass), float(period))
    return Gains(alpha, beta)


def to_physical(gains: Gains, mass: float, period: float) -> WallGains:
    """Eq. 3: K = alpha m/T^2, B = beta m/T."""
    stiffness, damping = _core.to_physical_gains(float(gains.alpha), float(gains.beta), float(mass), float(period))
    return WallGains(stiffness, damping)


def to_physical_plant(plant: Plant, mass: float, period: float) -> PhysicalPlant:
    """Inverse of normalize() for a given mass and period."""
    m, b, k, t, td = _core.to_physical_plant(float(plant.gamma), float(plant.delta), float(plant.delay),
                                             float(mass), float(period))
    return PhysicalPlant(mass=m, period=t, damping=b, stiffness=k, time_delay=td)
