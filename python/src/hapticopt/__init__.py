# SPDX-License-Identifier: Apache-2.0
"""hapticopt: exact stability region, energy costs and optimal gains of a sampled-data virtual wall
(Hulin, Gonzalez Camarero, Albu-Schaeffer, "Optimal Control for Haptic Rendering", IROS 2011).

One implementation, two languages: every number comes from the C++ header library
(include/hapticopt/) through the extension hapticopt._core. Normalised units throughout (m = T = 1;
hapticopt.normalize / to_physical convert). Figures: hapticopt.plot (needs matplotlib, extra `plot`);
hapticopt.plot_noise_pareto is hapticopt.plot.noise_pareto.
Documentation: docs/python.md of the repository.
"""
from ._core import InvalidParameterError, __version__
from .costs import (CRITERIA_WITH_SURFACE, Costs, Overshoot, Penetration, Stability, cost, cost_grid, costs,
                    force_noise_gain, force_noise_std, is_passive, is_stable, overshoot, passivity_margin,
                    penetration, stability)
from .estimator import VelocityEstimator, velocity_estimator
from .limit_cycles import (AbbottOkamuraPassivity, LimitCycle, LimitCyclePrediction, abbott_okamura_passivity,
                           predict_limit_cycle, quantised_rest_exists)
from .optima import (COLLISION_CRITERIA, STEP_CRITERIA, MassRangeStability, OptimalCurve, Optimum, PassiveOptimum,
                     RobustOptimum, WallTuning, mass_range_stability, optimal_curve, optimal_point, optimal_wall,
                     passive_optimum, robust_optimum,
                     NoiseBudgetOptimum, noise_pareto_front, optimal_point_under_noise_budget)
from .plot import noise_pareto as plot_noise_pareto
from .parameters import (Gains, PhysicalPlant, Plant, WallGains, normalize, normalize_gains, to_physical,
                         to_physical_plant)
from .region import Boundary, alpha_max, beta_range, boundary
from .response import StepResponse, sampled_step_response, step_response

__all__ = [
    "__version__", "InvalidParameterError",
    "Plant", "PhysicalPlant", "Gains", "WallGains", "normalize", "normalize_gains", "to_physical", "to_physical_plant",
    "Stability", "Costs", "Overshoot", "Penetration", "CRITERIA_WITH_SURFACE", "stability", "is_stable", "costs",
    "cost", "cost_grid", "overshoot", "penetration", "passivity_margin", "is_passive",
    "VelocityEstimator", "velocity_estimator", "force_noise_gain", "force_noise_std",
    "StepResponse", "step_response", "sampled_step_response",
    "Boundary", "boundary", "alpha_max", "beta_range",
    "STEP_CRITERIA", "COLLISION_CRITERIA", "OptimalCurve", "Optimum", "WallTuning", "RobustOptimum",
    "PassiveOptimum", "optimal_curve", "optimal_point", "optimal_wall", "robust_optimum", "passive_optimum",
    "NoiseBudgetOptimum", "optimal_point_under_noise_budget", "noise_pareto_front", "plot_noise_pareto",
    "AbbottOkamuraPassivity", "LimitCycle", "LimitCyclePrediction", "abbott_okamura_passivity", "predict_limit_cycle",
    "quantised_rest_exists", "MassRangeStability", "mass_range_stability",
]
