# SPDX-License-Identifier: Apache-2.0
"""Optimal curves and optimal points of every criterion; robust and passive optima.

Definitions (Hulin et al. 2011; optimum.hpp, impulse_optimum.hpp): optimal curve of C: beta_opt(alpha) =
argmin over the stable beta interval of C(alpha, beta). CEx / CIx point: the global minimum over the
exact stable region. amax: the region's tip. OV: the largest alpha for which some beta gives
C_OV <= tol, with the beta of least overshoot just beyond. CEx+OV: the largest alpha on the C_Ex
curve without overshoot; its cost is C_Ex there.

Method: coarse grid over the exact region, Brent, Newton polish of beta_opt; bisection for the OV
limits. Accuracy: no point of a 120 x 120 grid is better; dC/dbeta changes sign within 1e-8 of
beta_opt; all 64 rows of the paper's Tables III and IV within one printed digit (C++ tests and
python/tests). Robust (robust_optimum.hpp): minimise the worst case of C_E or C_I over a box of
physical parameters, stability over the box (exact crossing test along mass segments when b = k = 0).
Passive (passivity.hpp): minimum over the stable gains with delta > alpha/2 + |beta| (Colgate-Schenkel).
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Optional, Tuple, Union

import numpy as np
import numpy.typing as npt

from . import _core
from .costs import _plant_args
from .estimator import EstimatorLike, VelocityEstimator, velocity_estimator
from .parameters import PhysicalPlant, Plant, WallGains, normalize, to_physical, Gains

__all__ = ["STEP_CRITERIA", "COLLISION_CRITERIA", "OptimalCurve", "Optimum", "WallTuning", "RobustOptimum",
           "PassiveOptimum", "optimal_curve", "optimal_point", "optimal_wall", "robust_optimum", "passive_optimum",
           "NoiseBudgetOptimum", "optimal_point_under_noise_budget", "noise_pareto_front"]

#: The eight criteria of Tables III and IV ("amax", "OV", "CE0" .. "CE2+OV"): criterion.hpp's kAllCriteria.
STEP_CRITERIA: Tuple[str, ...] = tuple(_core.STEP_CRITERIA)
#: The collision criteria (beyond the paper): "CI0", "CI1", "CI2", criterion.hpp's kAllImpulseCriteria.
COLLISION_CRITERIA: Tuple[str, ...] = tuple(_core.COLLISION_CRITERIA)

Range = Union[float, Tuple[float, float]]


@dataclass(frozen=True)
class OptimalCurve:
    """beta_opt(alpha) of `criterion` and the cost there (NaN outside (alpha_min, alpha_max])."""

    criterion: str
    alpha: np.ndarray
    beta: np.ndarray
    cost: np.ndarray


@dataclass(frozen=True)
class Optimum:
    """The optimal point of one criterion. `cost` is None for amax and OV; `penetration` and
    `on_region_edge` are set for the collision criteria only (CI0's infimum lies on the edge)."""

    criterion: str
    plant: Plant
    alpha: float
    beta: float
    cost: Optional[float]
    alpha_max: float
    beta_at_alpha_max: Optional[float] = None
    penetration: Optional[float] = None
    penetration_converged: Optional[bool] = None
    on_region_edge: Optional[bool] = None
    velocity_estimator: VelocityEstimator = VelocityEstimator()
    force_noise_gain: Optional[float] = None
    stable_islands: Tuple[Tuple[float, float, float, float], ...] = ()

    @property
    def stability_margin(self) -> float:
        """alpha / alpha_max."""
        return self.alpha / self.alpha_max


@dataclass(frozen=True)
class WallTuning:
    """The physical answer: optimal K [N/m] and B [N s/m] (eq. 3) of one criterion for a device."""

    criterion: str
    plant: PhysicalPlant
    normalized: Plant
    alpha: float
    beta: float
    cost: Optional[float]
    stiffness: float
    damping: float
    alpha_max: float
    stiffness_max: float

    @property
    def K(self) -> float:  # noqa: N802 (the C++ WallTuning's and hapticd's name)
        """The stiffness [N/m], as `stiffness`."""
        return self.stiffness

    @property
    def B(self) -> float:  # noqa: N802
        """The damping [N s/m], as `damping`."""
        return self.damping

    @property
    def stability_margin(self) -> float:
        """alpha / alpha_max."""
        return self.alpha / self.alpha_max


@dataclass(frozen=True)
class RobustOptimum:
    """Robust gains (K, B), their worst case over the box and where it occurs; the nominal optimum
    (box centre) and its worst case for comparison (+inf: unstable somewhere in the box)."""

    criterion: str
    stiffness: float
    damping: float
    worst_cost: float
    worst_at: PhysicalPlant
    stable_over_box: bool
    mass_segments_certified: bool
    stiffness_max: float
    nominal: PhysicalPlant
    nominal_stiffness: float
    nominal_damping: float
    nominal_worst_cost: float
    nominal_stable_over_box: bool
    force_noise_max: float = 0.0  # largest sigma_F [N] over the verification grid (0 without position_resolution)
    velocity_estimator: VelocityEstimator = VelocityEstimator()

    @property
    def K(self) -> float:  # noqa: N802 (the C++ library's and hapticd's name)
        """The robust stiffness [N/m], as `stiffness`."""
        return self.stiffness

    @property
    def B(self) -> float:  # noqa: N802
        """The robust damping [N s/m], as `damping`."""
        return self.damping


@dataclass(frozen=True)
class PassiveOptimum:
    """The best passive gains and the passivity margin there (>= 0, ~0 on the edge), for the loop's velocity
    estimator."""

    criterion: str
    alpha: float
    beta: float
    cost: float
    margin: float
    velocity_estimator: VelocityEstimator = VelocityEstimator()


def optimal_curve(criterion: str, alpha: npt.ArrayLike, plant: Optional[Plant] = None, *,
                  overshoot_tolerance: float = 1e-12, beta_grid: int = 16) -> OptimalCurve:
    """beta_opt(alpha) of CE0, CE1, CE2, OV, CI0, CI1 or CI2 at each alpha (GIL released). For OV,
    where a whole beta interval has no overshoot the minimiser is not unique: one point of it."""
    a = np.ascontiguousarray(np.asarray(alpha, dtype=np.float64).ravel())
    b, c = _core.optimal_curve(str(criterion), *_plant_args(plant), a, float(overshoot_tolerance), 24, int(beta_grid))
    return OptimalCurve(str(criterion), a, b, c)


def optimal_point(criterion: str, plant: Optional[Plant] = None, *, overshoot_tolerance: float = 1e-12,
                  alpha_grid: int = 24, beta_grid: int = 16, alpha_tolerance: float = 1e-10,
                  estimator: EstimatorLike = None) -> Optimum:
    """The optimum of one of STEP_CRITERIA or COLLISION_CRITERIA (only that one is computed; CE2 at d = 1
    in about 0.15 ms, the OV point in tens of ms). The grids and alpha_tolerance are the C++ OptimumOptions
    with its default method (newton: the energy optima start from a thinned grid, then Newton steps on the
    analytic gradient; alpha_tolerance is the bisections' of OV and CEx+OV; docs/benchmarks.md).

    With a velocity estimator other than backward ("lowpass:0.02", "window:15" or a VelocityEstimator;
    `hapticopt optimum --velocity`): amax, CE0..2 and CE0+OV..CE2+OV over the estimator loop's main stable
    region (estimator_optimum.hpp's optimal_point, its default search grids: the grid arguments here are
    the backward optimiser's); the result carries g_F at the optimum and the stable islands (alpha_min,
    alpha_max, beta_min, beta_max) not connected to the main region. g_F is set for every estimator."""
    p = Plant() if plant is None else plant
    e = velocity_estimator(estimator)
    if e.kind != "backward":
        d = _core.estimator_optimal_point(str(criterion), *_plant_args(p), *e.args(), float(overshoot_tolerance))
        islands = tuple(tuple(i) for i in d.pop("stable_islands"))
        return Optimum(criterion=str(criterion), plant=p, velocity_estimator=e, stable_islands=islands, **d)
    d = _core.optimal_point(str(criterion), *_plant_args(p), float(overshoot_tolerance), int(alpha_grid),
                            int(beta_grid), float(alpha_tolerance))
    g = float(_core.force_noise_gain(*_plant_args(p), d["alpha"], d["beta"], *e.args()))
    return Optimum(criterion=str(criterion), plant=p, force_noise_gain=g, **d)


def optimal_wall(criterion: str, plant: PhysicalPlant, *, estimator: EstimatorLike = None, **options) -> WallTuning:
    """Optimal K and B of `criterion` for a physical plant: normalise (Table I), optimal_point,
    back to physical units (eq. 3); as the C++ optimal_wall(). `options` go to optimal_point; the
    estimator may give a low-pass cutoff in Hz ("lowpass:20Hz", nu = f_c T with plant.period)."""
    n = normalize(plant)
    o = optimal_point(criterion, n, estimator=velocity_estimator(estimator, plant.period), **options)
    g: WallGains = to_physical(Gains(o.alpha, o.beta), plant.mass, plant.period)
    return WallTuning(criterion=str(criterion), plant=plant, normalized=n, alpha=o.alpha, beta=o.beta, cost=o.cost,
                      stiffness=g.stiffness, damping=g.damping, alpha_max=o.alpha_max,
                      stiffness_max=o.alpha_max * plant.mass / plant.period ** 2)


def _range(name: str, value: Range) -> Tuple[float, float]:
    if isinstance(value, (tuple, list)):
        if len(value) != 2:
            raise ValueError(f"hapticopt.robust_optimum: {name} = {value!r} is invalid; accepted: a number or (min, max)")
        return float(value[0]), float(value[1])
    return float(value), float(value)


def robust_optimum(criterion: str, *, mass: Range, period: float, damping: Range = 0.0, stiffness: Range = 0.0,
                   time_delay: Range = 0.0, estimator: EstimatorLike = None, force_noise_budget: float = 0.0,
                   position_resolution: float = 0.0) -> RobustOptimum:
    """Gains minimising the worst case of CE0..2 or CI0..2 over the box (each parameter a value or a
    (min, max) range; physical units) for the loop with the velocity estimator (CI0..2: backward only); with
    force_noise_budget [N] > 0 and the encoder step position_resolution [m], sigma_F stays within the budget at every
    plant of the optimisation grid (force_noise_max: the largest over the verification grid). A few 0.1 s at d = 1
    with the backward difference, about 1 s with a 15-period window at d = 6 (robust_optimum.hpp)."""
    e = velocity_estimator(estimator, period)
    d = _core.robust_optimum(str(criterion), _range("mass", mass), _range("damping", damping),
                             _range("stiffness", stiffness), float(period), _range("time_delay", time_delay),
                             *e.args(), float(force_noise_budget), float(position_resolution))
    return RobustOptimum(criterion=str(criterion), stiffness=d["stiffness"], damping=d["damping"],
                         worst_cost=d["worst_cost"], worst_at=PhysicalPlant(**d["worst_at"]),
                         stable_over_box=d["stable_over_box"], mass_segments_certified=d["mass_segments_certified"],
                         stiffness_max=d["K_max"], nominal=PhysicalPlant(**d["nominal"]),
                         nominal_stiffness=d["nominal_stiffness"], nominal_damping=d["nominal_damping"],
                         nominal_worst_cost=d["nominal_worst_cost"],
                         nominal_stable_over_box=d["nominal_stable_over_box"],
                         force_noise_max=d["force_noise_max"], velocity_estimator=e)


@dataclass(frozen=True)
class MassRangeStability:
    """Fixed gains over an interval of moving masses (the hand gripping or letting go): stable for every mass;
    failing_mass: a mass of the interval where not (None when stable); crossing_masses: every mass > 0 at which a
    root of the loop lies on the unit circle, ascending (include/hapticopt/mass_scaling_stability.hpp)."""

    stable: bool
    failing_mass: Optional[float]
    crossing_masses: Tuple[float, ...]


def mass_range_stability(stiffness: float, damping: float, *, mass: Range, period: float, time_delay: float = 0.0,
                         estimator: EstimatorLike = None) -> MassRangeStability:
    """Whether K, B (physical) are stable for every mass of `mass` ((min, max) or one value) with the free-mass
    plant (b = k = 0) at delay `time_delay` and the velocity estimator: exact (the Schur-Cohn verdict at one end
    and the unit-circle crossings along the mass; docs/robust-stability.md). A few us at d = 1 with the backward
    difference, 0.3 ms with a 15-period window at d = 6 (docs/benchmarks.md)."""
    e = velocity_estimator(estimator, period)
    d = _core.mass_range_stability(float(stiffness), float(damping), _range("mass", mass), float(period),
                                   float(time_delay), *e.args())
    return MassRangeStability(stable=bool(d["stable"]), failing_mass=d["failing_mass"],
                              crossing_masses=tuple(float(m) for m in d["crossing_masses"]))


def passive_optimum(criterion: str, plant: Optional[Plant] = None, *,
                    estimator: EstimatorLike = None) -> Optional[PassiveOptimum]:
    """The minimum of CE0..2 or CI0..2 over the stable passive gains; None when there are none
    (delta = 0: no gains satisfy delta > alpha/2 + |beta|). With a velocity estimator other than backward
    (`hapticopt optimum --passive --velocity`): over the estimator loop's main stable region clipped to its
    passive beta interval (estimator_passivity.hpp)."""
    e = velocity_estimator(estimator)
    d = _core.passive_optimum(str(criterion), *_plant_args(plant), *e.args())
    return None if d is None else PassiveOptimum(criterion=str(criterion), velocity_estimator=e, **d)


@dataclass(frozen=True)
class NoiseBudgetOptimum:
    """The criterion's optimum with g_F <= noise_budget (normalised g_max = sigma_max T^2 / (m q)); budget_active
    False: the unconstrained optimum meets the budget and is returned."""

    criterion: str
    velocity_estimator: VelocityEstimator
    noise_budget: float
    alpha: float
    beta: float
    cost: float
    force_noise_gain: float
    budget_active: bool
    alpha_max: float
    unconstrained_cost: float
    unconstrained_force_noise_gain: float


def optimal_point_under_noise_budget(criterion: str, noise_budget: float, plant: Optional[Plant] = None, *,
                                     estimator: EstimatorLike = None) -> NoiseBudgetOptimum:
    """The criterion's optimum over the estimator loop's main stable region subject to g_F(alpha, beta) <=
    noise_budget (noise_budget.hpp). CE0..2: the unconstrained optimum if it meets the budget, else the minimum along
    the curve g_F = noise_budget (bisection for the curve, Brent along it); amax: the stiffest gains meeting it;
    OV, CE0+OV..CE2+OV: the largest alpha without overshoot on the betas meeting it (the unconstrained point when it
    meets it). A budget no stable gains with alpha >= 1e-6 alpha_max meet raises InvalidParameterError naming
    `noise_budget`."""
    e = velocity_estimator(estimator)
    d = _core.noise_budget_optimum(str(criterion), *_plant_args(plant), *e.args(), float(noise_budget))
    return NoiseBudgetOptimum(criterion=str(criterion), velocity_estimator=e, **d)


def noise_pareto_front(criterion: str, budgets: npt.ArrayLike, plant: Optional[Plant] = None, *,
                       estimator: EstimatorLike = None) -> list:
    """The Pareto front C against g_F: optimal_point_under_noise_budget for each budget (budgets no stable gains
    meet are left out), as a list of NoiseBudgetOptimum in the budgets' order."""
    out = []
    for g in np.asarray(budgets, dtype=np.float64).ravel():
        try:
            out.append(optimal_point_under_noise_budget(criterion, float(g), plant, estimator=estimator))
        except _core.InvalidParameterError as error:
            if error.parameter != "noise_budget" or not (np.isfinite(g) and g > 0):
                raise
    return out
