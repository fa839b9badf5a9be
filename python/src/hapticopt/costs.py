# SPDX-License-Identifier: Apache-2.0
"""Stability and the step/collision criteria at a point, and vectorised over numpy arrays.

Model (normalised, m = T = 1; Hulin et al. 2011): plant x'' + delta x' + gamma x =
F - f_w, wall f_j = alpha x_j + beta (x_j - x_{j-1}) behind a zero-order hold and the delay d;
unit step F = 1 from rest, x_inf = 1/(alpha + gamma).

    E(t) = 1/2 (alpha + gamma) (x(t) - x_inf)^2 + 1/2 x'(t)^2,   E(0) = 1/(2 (alpha + gamma))   (eqs. 4-5)
    C_Ep = (1/E(0)) int_0^inf t^p E(t) dt,  p = 0, 1, 2                                          (eqs. 6-8)
    C_OV = (max_t x(t) - x_inf) / x_inf   (continuous-time maximum)                              (eq. 9)
    C_Ip: the same integrals for a collision at v0 (x(0) = 0, x'(0) = v0, x_{-1} = -v0 T, empty
          delay buffer, F = 0), normalised by E(0) = 1/2 m v0^2; penetration = max x / (v0 T).

Method and accuracy (the C++ headers energy_costs.hpp, overshoot.hpp, impulse_costs.hpp): exact
per-period integrals and exact infinite sums by Stein equations; relative error <= 1e-10 for
spectral radius rho <= 0.999 and <= 1e-13/(1 - rho)^2 nearer the boundary. The overshoot maximum is
exact inside each period with a Lyapunov-proven stop. Unstable gains: +inf. Stability: Schur-Cohn on
the characteristic polynomial, refined in long double near the boundary (decision exact to ~1e-13).
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Optional, Tuple, Union

import numpy as np
import numpy.typing as npt

from . import _core
from .estimator import EstimatorLike, VelocityEstimator, velocity_estimator
from .parameters import PhysicalPlant, Plant, WallGains, normalize, normalize_gains

__all__ = ["Stability", "Costs", "Overshoot", "Penetration", "CRITERIA_WITH_SURFACE", "stability", "is_stable",
           "costs", "cost", "cost_grid", "overshoot", "penetration", "passivity_margin", "is_passive",
           "force_noise_gain", "force_noise_std"]

#: Criteria that have a cost surface C(alpha, beta): accepted by cost(), cost_grid(), optimal_curve().
#: "CE0", "CE1", "CE2", "OV", "CI0", "CI1", "CI2" (the extension's list, from criterion.hpp).
CRITERIA_WITH_SURFACE: Tuple[str, ...] = tuple(_core.SURFACE_CRITERIA)

ArrayLike = npt.ArrayLike
FloatOrArray = Union[float, np.ndarray]

_DEFAULT_PLANT = Plant()


def _plant_args(plant: Optional[Plant]) -> tuple:
    p = _DEFAULT_PLANT if plant is None else plant
    if not isinstance(p, Plant):
        raise TypeError(f"plant must be a hapticopt.Plant (normalised), got {type(p).__name__}; "
                        "use hapticopt.normalize(PhysicalPlant(...))")
    return float(p.gamma), float(p.delta), float(p.delay)


@dataclass(frozen=True)
class Stability:
    """Schur-Cohn verdict, its margin min(1 - |k_i|), the spectral radius of the loop matrix (a
    second opinion from its eigenvalues), and whether the verdict was recomputed in long double."""

    stable: bool
    margin: float
    spectral_radius: float
    refined: bool


@dataclass(frozen=True)
class Costs:
    """Every criterion at one gain pair (+inf where unstable); `no_overshoot` is C_OV <= tolerance
    with the proven stop reached; passivity_margin: the Colgate-Schenkel margin (passivity.hpp,
    with the loop delay), None for a fractional delay, which that condition does not cover.
    force_noise_gain: g_F, sigma_F = (m q / T^2) g_F (quantisation force noise, estimator_noise.hpp).
    Every field is the loop's with its velocity estimator (estimator_costs.hpp, estimator_impulse.hpp,
    estimator_passivity.hpp)."""

    stable: bool
    spectral_radius: float
    ce0: float
    ce1: float
    ce2: float
    ov: float
    no_overshoot: bool
    ci0: float
    ci1: float
    ci2: float
    penetration: float
    passivity_margin: Optional[float]
    force_noise_gain: float = math.inf
    velocity_estimator: VelocityEstimator = VelocityEstimator()

    def __getitem__(self, criterion: str) -> float:
        """The cost by criterion name: costs["CE2"]."""
        if criterion not in CRITERIA_WITH_SURFACE:
            raise ValueError(f"Costs: criterion = {criterion!r} is invalid; accepted: {', '.join(CRITERIA_WITH_SURFACE)}")
        return float(getattr(self, criterion.lower()))


@dataclass(frozen=True)
class Overshoot:
    """C_OV (eq. 9) with the time of the maximum (NaN when there is none), whether it is within the
    tolerance, whether the proven stop was reached, and the periods examined."""

    value: float
    time: float
    within_tolerance: bool
    converged: bool
    periods: int


@dataclass(frozen=True)
class Penetration:
    """Collision penetration depth max_t x(t) / (v0 T), its time, the proven stop, periods examined."""

    depth: float
    time: float
    converged: bool
    periods: int


def stability(alpha: float, beta: float, plant: Optional[Plant] = None, *,
              estimator: EstimatorLike = None) -> Stability:
    """Stability of the loop at (alpha, beta): all characteristic roots strictly inside the unit
    circle (Schur-Cohn; refined in long double where the margin is below 1e-4). With a velocity
    estimator (hapticopt.VelocityEstimator or "lowpass:0.02", "window:15", ...): Schur-Cohn on the
    estimator loop's polynomial p_est (estimator_stability.hpp), spectral radius of its loop matrix."""
    e = velocity_estimator(estimator)
    if e.kind == "backward":
        return Stability(*_core.stability(*_plant_args(plant), float(alpha), float(beta)))
    return Stability(*_core.estimator_stability(*_plant_args(plant), float(alpha), float(beta), *e.args()))


def is_stable(alpha: float, beta: float, plant: Optional[Plant] = None, *, estimator: EstimatorLike = None) -> bool:
    """stability(...).stable."""
    return stability(alpha, beta, plant, estimator=estimator).stable


def costs(alpha: float, beta: float, plant: Optional[Plant] = None, *, overshoot_tolerance: float = 1e-12,
          estimator: EstimatorLike = None) -> Costs:
    """C_E0..2, C_OV, C_I0..2, penetration, stability, passivity margin and g_F at one point (what
    `hapticopt cost --json` prints). NaN or infinite gains raise InvalidParameterError. With a velocity
    estimator other than backward (`hapticopt cost --velocity`): every field of the estimator's loop (collision
    criteria: estimator_impulse.hpp; passivity: estimator_passivity.hpp, None for a fractional delay)."""
    e = velocity_estimator(estimator)
    if e.kind == "backward":
        d = _core.point_costs(*_plant_args(plant), float(alpha), float(beta), float(overshoot_tolerance))
        return Costs(**d)
    d = _core.estimator_point_costs(*_plant_args(plant), float(alpha), float(beta), *e.args(),
                                    float(overshoot_tolerance))
    return Costs(stable=d["stable"], spectral_radius=d["spectral_radius"], ce0=d["ce0"], ce1=d["ce1"], ce2=d["ce2"],
                 ov=d["ov"], no_overshoot=d["no_overshoot"], ci0=d["ci0"], ci1=d["ci1"], ci2=d["ci2"],
                 penetration=d["penetration"], passivity_margin=d["passivity_margin"],
                 force_noise_gain=d["force_noise_gain"], velocity_estimator=e)


def force_noise_gain(alpha: float, beta: float, plant: Optional[Plant] = None, *,
                     estimator: EstimatorLike = None) -> float:
    """g_F: the steady-state standard deviation of the commanded force per encoder step, normalised
    (sigma_F = (m q / T^2) g_F), for a white rounding error of variance q^2/12 on the measured position:
    g_F^2 = c^T P c with P = M P M^T + g g^T / 12 (the Stein equation of estimator_noise.hpp);
    +inf when the loop is unstable."""
    e = velocity_estimator(estimator)
    return float(_core.force_noise_gain(*_plant_args(plant), float(alpha), float(beta), *e.args()))


def force_noise_std(gains: WallGains, plant: PhysicalPlant, position_resolution: float, *,
                    estimator: EstimatorLike = None) -> float:
    """sigma_F [N] = (m q / T^2) g_F for physical gains, plant and encoder step q [m] (> 0);
    estimator strings may give the low-pass cutoff in Hz ("lowpass:20Hz", converted with plant.period)."""
    q = float(position_resolution)
    if not (math.isfinite(q) and q > 0):
        raise ValueError(f"hapticopt.force_noise_std: position_resolution = {position_resolution!r} is invalid; "
                         "accepted: finite and > 0 [m]")
    e = velocity_estimator(estimator, plant.period)
    g = normalize_gains(gains, plant.mass, plant.period)
    return plant.mass * q / plant.period ** 2 * force_noise_gain(g.alpha, g.beta, normalize(plant), estimator=e)


def cost(criterion: str, alpha: ArrayLike, beta: ArrayLike, plant: Optional[Plant] = None, *,
         overshoot_tolerance: float = 1e-12, threads: int = 1) -> FloatOrArray:
    """One criterion (CE0, CE1, CE2, OV, CI0, CI1, CI2) over numpy arrays of alpha and beta
    (broadcast together). Returns an array of the broadcast shape (a float for two scalars):
    +inf where the loop is unstable, NaN where alpha or beta is NaN or infinite (that cell only).
    The plant is set up once; the loop runs in C++ with the GIL released, on `threads` threads
    (1..1024; interleaved cells). Same values, bit for bit, as the point-wise costs(), whatever
    the thread count."""
    a, b = np.broadcast_arrays(np.asarray(alpha, dtype=np.float64), np.asarray(beta, dtype=np.float64))
    out = _core.cost_array(str(criterion), *_plant_args(plant), np.ascontiguousarray(a), np.ascontiguousarray(b),
                           float(overshoot_tolerance), int(threads))
    return float(out.reshape(())) if a.ndim == 0 else out.reshape(a.shape)


def cost_grid(criterion: str, alphas: ArrayLike, betas: ArrayLike, plant: Optional[Plant] = None, *,
              overshoot_tolerance: float = 1e-12, threads: int = 1) -> np.ndarray:
    """cost() on the grid alphas x betas, shaped (len(betas), len(alphas)) as matplotlib's
    contour(alphas, betas, Z) expects."""
    a = np.asarray(alphas, dtype=np.float64).reshape(1, -1)
    b = np.asarray(betas, dtype=np.float64).reshape(-1, 1)
    return np.asarray(cost(criterion, a, b, plant, overshoot_tolerance=overshoot_tolerance, threads=threads))


def overshoot(alpha: float, beta: float, plant: Optional[Plant] = None, *, tolerance: float = 1e-12,
              max_periods: int = 100_000_000) -> Overshoot:
    """C_OV (eq. 9): exact in-period maxima, Lyapunov-proven stop. "No overshoot" means C_OV <=
    tolerance (relative; 1e-12 reproduces the paper's tables; values below ~1e-15 are not resolved)."""
    return Overshoot(*_core.overshoot(*_plant_args(plant), float(alpha), float(beta), float(tolerance),
                                      int(max_periods)))


def penetration(alpha: float, beta: float, plant: Optional[Plant] = None, *,
                max_periods: int = 100_000_000) -> Penetration:
    """Penetration depth of the collision response, max_t x(t) / (v0 T) (impulse_costs.hpp)."""
    return Penetration(*_core.penetration(*_plant_args(plant), float(alpha), float(beta), int(max_periods)))


def passivity_margin(alpha: float, beta: float, plant: Optional[Plant] = None, *,
                     estimator: EstimatorLike = None) -> float:
    """Colgate-Schenkel margin with the loop delay z^-d (passivity.hpp): mu = delta - max_theta R(theta),
    R = Re{(1 - e^{-i theta}) e^{-i d theta} (alpha + beta (1 - e^{-i theta}))} / (2 (1 - cos theta));
    for d = 0, mu = delta - alpha/2 - |beta|. Passive iff mu > 0. With a velocity estimator the damper is
    beta D(z) instead of beta (1 - z^-1) (estimator_passivity.hpp). Integer delays only (a fractional
    one raises InvalidParameterError naming `delay`)."""
    e = velocity_estimator(estimator)
    return float(_core.passivity_margin(*_plant_args(plant), float(alpha), float(beta), *e.args()))


def is_passive(alpha: float, beta: float, plant: Optional[Plant] = None, *, estimator: EstimatorLike = None) -> bool:
    """passivity_margin(...) > 0."""
    return passivity_margin(alpha, beta, plant, estimator=estimator) > 0
