// SPDX-License-Identifier: Apache-2.0
// The optimum of an energy criterion under a force-noise budget (normalised units m = T = 1):
//
//   minimise C_Ep(alpha, beta)  over the main stable region of the loop with the velocity estimator,
//   subject to g_F(alpha, beta) <= g_max,
//
// g_F the quantisation force-noise gain of velocity_estimator.hpp (sigma_F = (m q / T^2) g_F, so a physical
// budget sigma_max [N] is g_max = sigma_max T^2 / (m q)), C_Ep (p = 0, 1, 2) the energy costs of the estimator's
// loop (eqs. 6-8 of Hulin et al. 2011 on that loop).
//
// Method. (1) The unconstrained optimum (optimal_point with the estimator); if g_F there is <= g_max it is the
// answer. (2) Otherwise, assuming C_Ep has no other local minimum in the region (the criteria grow towards the
// stability boundary; checked on fine grids in tests/core/test_noise_budget.cpp), the constrained minimum lies
// on the curve g_F = g_max. At each alpha the curve is found on the main region's stable beta interval
// (lo, hi) (EstimatorStabilityRegion::beta_interval): g_min(alpha) = min_beta g_F by a 16-cell grid and Brent
// (scalar_search.hpp); where g_min <= g_max, the two crossings beta_lo(alpha) in (lo, beta*) and
// beta_hi(alpha) in (beta*, hi) by bisection that keeps the side with g_F <= g_max (so the returned point meets
// the budget as computed), to 1e-13 of the interval (g_F is taken to grow monotonically away from beta*; g_F
// -> inf at the stability edges). Each branch is a smooth curve alpha -> (alpha, beta_b(alpha)); the cost
// along it is minimised over log alpha: a scan of `alpha_grid` points log-spaced over
// [alpha_floor alpha_max, alpha_max), then Brent on the best point's two neighbouring cells to
// `alpha_tolerance` (relative in log alpha). The better branch is the answer.
// Accuracy: the point meets g_F <= g_max (bisection keeps the feasible side; rounding of g_F itself ~1e-13
// relative); the cost is that of the exact minimum on the curve to within C'' (alpha_tolerance alpha)^2 /2
// (Brent at a smooth minimum) plus the bisection's effect, |dC/dbeta| 1e-13 (hi - lo): below 1e-9
// relative at the measured points (tests/core/test_noise_budget.cpp: no point of a 150 x 150 grid of the main
// region, nor of a 61 x 61 grid within +-2 % of the optimum, that meets the budget has a lower cost, within
// 1e-9 relative; backward, low-pass 0.02 and 0.1, window 15, d = 0 and 1).
// Impossible budgets: g_F -> 0 only as alpha -> 0; the search covers alpha >= alpha_floor alpha_max (default
// 1e-6); a budget no scanned alpha meets throws InvalidParameter naming `noise_budget`.
// Cost: about alpha_grid (40 + 2 x 45) + 40 x 130 evaluations of g_F (O(N^3) each, N the loop's states),
// plus the unconstrained optimum. Measured (BM_NoiseBudgetOptimum, d = 1): ~0.1 s backward and low-pass,
// ~2 s window 15 (docs/velocity-estimation.md).
//
// The Pareto front (C against g_F): the constrained optimum for a list of budgets (noise_pareto_front).
// The estimator's parameter jointly: the constrained optimum for each candidate estimator (a list: windows
// 1..N_max, or low-pass cutoffs on a grid), the best one returned (optimal_estimator_under_noise_budget); for
// the low-pass over an interval of nu: a log-spaced scan of nu, then Brent in log nu on the best scan point's
// neighbouring cells (optimal_lowpass_under_noise_budget; a local refinement of the scan's best basin).
#pragma once

#include <cmath>
#include <optional>
#include <string>
#include <vector>

#include "velocity_estimator.hpp"

namespace hapticopt {

/// Options of optimal_point_under_noise_budget.
struct NoiseBudgetOptions {
    EstimatorOptimumOptions unconstrained;  ///< the unconstrained optimum's search
    int alpha_grid = 64;                    ///< log-spaced alpha scan of the curve g_F = g_max, >= 8
    int beta_grid = 16;                     ///< grid of the g_F minimum over beta at one alpha, >= 4
    double alpha_floor = 1e-6;              ///< smallest alpha searched, relative to alpha_max, (0, 0.1]
    double alpha_tolerance = 1e-10;         ///< Brent's tolerance in log alpha, (0, 1e-3]
};

/// The constrained optimum and what it meets.
struct NoiseBudgetOptimum {
    Criterion criterion = Criterion::CE2;
    VelocityEstimator estimator;
    double noise_budget = 0;  ///< g_max
    double alpha = 0;
    double beta = 0;
    double cost = HUGE_VAL;
    double force_noise_gain = 0;  ///< g_F at (alpha, beta), <= noise_budget
    bool budget_active = false;   ///< false: the unconstrained optimum meets the budget (and is returned)
    double alpha_max = 0;         ///< the main region's tip
    double unconstrained_cost = HUGE_VAL;
    double unconstrained_force_noise_gain = 0;
};

namespace detail {

inline int noise_budget_energy_index(const char* fn, Criterion criterion) {
    const auto k = energy_index(criterion);
    if (!k || requires_no_overshoot(criterion)) {
        throw InvalidParameter(fn, "criterion", static_cast<double>(criterion), "CE0, CE1 or CE2 under a noise budget");
    }
    return *k;
}

}  // namespace detail

/// The optimum of CE0..2 subject to g_F <= noise_budget (the method and accuracy of the header comment).
/// Throws InvalidParameter naming `noise_budget` when it is not finite and > 0 or when no stable gains with
/// alpha >= alpha_floor alpha_max meet it, `criterion` for anything but CE0..2, and the options' names.
HAPTICOPT_DEFERRED
NoiseBudgetOptimum optimal_point_under_noise_budget(Criterion criterion, const NormalizedPlant& plant,
                                                    const VelocityEstimator& estimator, double noise_budget,
                                                    const NoiseBudgetOptions& options = {}) {
    const char* fn = "hapticopt::optimal_point_under_noise_budget";
    validate(plant, fn);
    validate(estimator, fn);
    const int index = detail::noise_budget_energy_index(fn, criterion);
    detail::require_in_range(fn, "noise_budget", noise_budget, 0.0, true, HUGE_VAL,
                             "finite and > 0 (normalised g_max = sigma_max T^2 / (m q))");
    detail::require_in_range(fn, "alpha_grid", options.alpha_grid, 8, false, 1e5, "8 <= alpha_grid <= 10^5");
    detail::require_in_range(fn, "beta_grid", options.beta_grid, 4, false, 1e5, "4 <= beta_grid <= 10^5");
    detail::require_in_range(fn, "alpha_floor", options.alpha_floor, 0.0, true, 0.1, "0 < alpha_floor <= 0.1");
    detail::require_in_range(fn, "alpha_tolerance", options.alpha_tolerance, 0.0, true, 1e-3,
                             "0 < alpha_tolerance <= 1e-3");
    NoiseBudgetOptimum out;
    out.criterion = criterion;
    out.estimator = estimator;
    out.noise_budget = noise_budget;
    const SampledPlant<double> sampled(plant);
    auto noise = [&](double a, double b) { return estimator_force_noise_gain(sampled, estimator, a, b); };
    auto cost = [&](double a, double b) {
        const EnergyCosts c = estimator_energy_costs(sampled, estimator, a, b);
        return index == 0 ? c.ce0 : index == 1 ? c.ce1 : c.ce2;
    };

    const EstimatorOptimum free = optimal_point(criterion, plant, estimator, options.unconstrained);
    out.alpha_max = free.alpha_max;
    out.unconstrained_cost = free.cost ? *free.cost : HUGE_VAL;
    out.unconstrained_force_noise_gain = noise(free.alpha, free.beta);
    if (out.unconstrained_force_noise_gain <= noise_budget) {
        out.alpha = free.alpha;
        out.beta = free.beta;
        out.cost = out.unconstrained_cost;
        out.force_noise_gain = out.unconstrained_force_noise_gain;
        return out;
    }
    out.budget_active = true;

    const EstimatorStabilityRegion region(plant, estimator);
    // beta on branch `side` (0: below beta*, 1: above) at alpha, NaN where g_min(alpha) > g_max.
    auto crossing = [&](double a, int side) {
        const std::pair<double, double> interval = region.beta_interval(a);
        auto range = [&](double) { return interval; };
        auto g = [&](double, double b) { return noise(a, b); };
        const detail::ScalarMinimum m = detail::minimize_over_beta(g, range, a, options.beta_grid);
        if (!(m.value <= noise_budget)) return std::nan("");
        double inside = m.x, outside = side == 0 ? interval.first : interval.second;
        if (noise(a, outside) <= noise_budget) return outside;  // the budget does not bind before the edge
        const double width = interval.second - interval.first;
        for (int k = 0; k < 200 && std::abs(outside - inside) > 1e-13 * width; ++k) {
            const double mid = (inside + outside) / 2;
            (noise(a, mid) <= noise_budget ? inside : outside) = mid;
        }
        return inside;
    };
    auto branch_cost = [&](double log_a, int side) {
        const double a = std::exp(log_a);
        const double b = crossing(a, side);
        return std::isnan(b) ? HUGE_VAL : cost(a, b);
    };
    const double l0 = std::log(options.alpha_floor * out.alpha_max), l1 = std::log(out.alpha_max);
    const int n = options.alpha_grid;
    const double step = (l1 - l0) / n;
    double best = HUGE_VAL;
    int best_i = -1, best_side = 0;
    for (int i = 0; i < n; ++i) {
        const double l = l0 + (i + 0.5) * step;
        for (int side = 0; side < 2; ++side) {
            const double c = branch_cost(l, side);
            if (c < best) {
                best = c;
                best_i = i;
                best_side = side;
            }
        }
    }
    if (best_i < 0) {
        throw InvalidParameter(
            fn, "noise_budget", noise_budget,
            "a g_F met by some stable gains with alpha >= alpha_floor alpha_max (none found on the scan)");
    }
    double best_l = l0 + (best_i + 0.5) * step;
    for (int side = 0; side < 2; ++side) {
        const double lo = std::max(l0, best_l - step), hi = std::min(l1, best_l + step);
        const detail::ScalarMinimum m =
            detail::minimize_scalar([&](double l) { return branch_cost(l, side); }, lo, hi, options.alpha_tolerance);
        if (std::isfinite(m.value) && m.value < best) {
            best = m.value;
            best_side = side;
            best_l = m.x;
        }
    }
    out.alpha = std::exp(best_l);
    out.beta = crossing(out.alpha, best_side);
    out.cost = cost(out.alpha, out.beta);
    out.force_noise_gain = noise(out.alpha, out.beta);
    return out;
}

/// The Pareto front of C against g_F: the constrained optimum for each budget (any order; budgets that no
/// scanned gains meet are left out). Each point's force_noise_gain <= its budget and cost is the least cost
/// for it (budget_active false: the unconstrained optimum).
HAPTICOPT_DEFERRED
std::vector<NoiseBudgetOptimum> noise_pareto_front(Criterion criterion, const NormalizedPlant& plant,
                                                   const VelocityEstimator& estimator,
                                                   const std::vector<double>& budgets,
                                                   const NoiseBudgetOptions& options = {}) {
    std::vector<NoiseBudgetOptimum> out;
    for (const double g : budgets) {
        try {
            out.push_back(optimal_point_under_noise_budget(criterion, plant, estimator, g, options));
        } catch (const InvalidParameter& e) {
            if (e.parameter() != "noise_budget" || !(g > 0 && std::isfinite(g))) throw;
        }
    }
    return out;
}

/// The estimator's parameter jointly: the constrained optimum for each candidate (e.g. windows 1..N_max, or
/// low-pass cutoffs on a grid), the one of least cost (first on ties). Candidates whose budget no scanned gains
/// meet are skipped; throws InvalidParameter naming `noise_budget` when none meets it and `estimators` when
/// the list is empty.
HAPTICOPT_DEFERRED
NoiseBudgetOptimum optimal_estimator_under_noise_budget(Criterion criterion, const NormalizedPlant& plant,
                                                        const std::vector<VelocityEstimator>& estimators,
                                                        double noise_budget, const NoiseBudgetOptions& options = {}) {
    const char* fn = "hapticopt::optimal_estimator_under_noise_budget";
    if (estimators.empty()) throw InvalidParameter(fn, "estimators", 0.0, "at least one candidate estimator");
    std::optional<NoiseBudgetOptimum> best;
    for (const VelocityEstimator& e : estimators) {
        try {
            const NoiseBudgetOptimum o = optimal_point_under_noise_budget(criterion, plant, e, noise_budget, options);
            if (!best || o.cost < best->cost) best = o;
        } catch (const InvalidParameter& x) {
            if (x.parameter() != "noise_budget" || !(noise_budget > 0 && std::isfinite(noise_budget))) throw;
        }
    }
    if (!best) {
        throw InvalidParameter(fn, "noise_budget", noise_budget,
                               "a g_F met by some stable gains with one of the candidate estimators");
    }
    return *best;
}

/// The low-pass cut-off jointly with the gains: minimise the constrained optimum's cost over nu in
/// [nu_min, nu_max] (0 < nu_min < nu_max): `scan` cut-offs log-spaced over the interval (ends included), then
/// Brent over log nu on the best one's neighbouring cells to `log_tolerance`. Cut-offs whose budget no scanned
/// gains meet count as +inf. Throws InvalidParameter naming `nu_min`, `nu_max`, `scan`, `log_tolerance` or,
/// when no cut-off meets it, `noise_budget`.
HAPTICOPT_DEFERRED
NoiseBudgetOptimum optimal_lowpass_under_noise_budget(Criterion criterion, const NormalizedPlant& plant, double nu_min,
                                                      double nu_max, double noise_budget, int scan = 12,
                                                      double log_tolerance = 1e-3,
                                                      const NoiseBudgetOptions& options = {}) {
    const char* fn = "hapticopt::optimal_lowpass_under_noise_budget";
    detail::require_in_range(fn, "nu_min", nu_min, 0.0, true, HUGE_VAL, "finite and > 0");
    detail::require_in_range(fn, "nu_max", nu_max, nu_min, true, HUGE_VAL, "finite and > nu_min");
    detail::require_in_range(fn, "scan", scan, 3, false, 1e4, "3 <= scan <= 10^4");
    detail::require_in_range(fn, "log_tolerance", log_tolerance, 0.0, true, 1.0, "0 < log_tolerance <= 1");
    detail::require_in_range(fn, "noise_budget", noise_budget, 0.0, true, HUGE_VAL, "finite and > 0");
    std::optional<NoiseBudgetOptimum> best;
    auto at = [&](double log_nu) {
        try {
            const NoiseBudgetOptimum o = optimal_point_under_noise_budget(
                criterion, plant, VelocityEstimator::low_pass(std::exp(log_nu)), noise_budget, options);
            if (!best || o.cost < best->cost) best = o;
            return o.cost;
        } catch (const InvalidParameter& x) {
            if (x.parameter() != "noise_budget") throw;
            return HUGE_VAL;
        }
    };
    const double l0 = std::log(nu_min), l1 = std::log(nu_max), step = (l1 - l0) / (scan - 1);
    int best_i = -1;
    double best_cost = HUGE_VAL;
    for (int i = 0; i < scan; ++i) {
        const double c = at(l0 + i * step);
        if (c < best_cost) {
            best_cost = c;
            best_i = i;
        }
    }
    if (best_i < 0) {
        throw InvalidParameter(fn, "noise_budget", noise_budget,
                               "a g_F met by some stable gains with a cut-off in the interval");
    }
    const double centre = l0 + best_i * step;
    detail::minimize_scalar(at, std::max(l0, centre - step), std::min(l1, centre + step), log_tolerance);
    return *best;
}

}  // namespace hapticopt
