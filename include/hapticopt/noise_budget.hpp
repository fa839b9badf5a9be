// SPDX-License-Identifier: Apache-2.0
// The optimum of an energy criterion under a force-noise budget (normalised units m = T = 1):
//
//   minimise C_Ep(alpha, beta)  over the main stable region of the loop with the velocity estimator,
//   subject to g_F(alpha, beta) <= g_max,
//
// g_F the quantisation force-noise gain of estimator_noise.hpp (sigma_F = (m q / T^2) g_F, so a physical
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
// The other criteria under the budget (optimal_point_under_noise_budget's comment): amax the largest alpha whose
// band {beta stable: g_F <= g_max} is not empty; OV and CEx+OV the largest alpha where the band holds a beta without
// overshoot (OV: any; CEx+OV: the band's least C_Ex), each by a scan down in log alpha and bisection. The OV point with
// any estimator and no budget: estimator_overshoot_point. Measured on the Falcon's loop: docs/benchmarks.md.
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
#include <utility>
#include <vector>

#include "estimator_costs.hpp"
#include "estimator_noise.hpp"
#include "estimator_optimum.hpp"
#include "estimator_region.hpp"
#include "estimator_types.hpp"

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

/// The budget's band at one alpha: the betas of the main region's stable interval (lo, hi) at alpha with
/// g_F <= g_max. g_min(alpha) = min over beta of g_F by a `beta_grid`-cell grid and Brent; where g_min <= g_max
/// the band is (beta_lo, beta_hi) around the minimiser, each end by bisection that keeps the side with
/// g_F <= g_max, to 1e-13 of the interval (g_F taken to grow monotonically away from its minimiser; it is +inf
/// at the stability edges). An empty band is (NaN, NaN). With g_max = +inf the band is the stable interval.
class NoiseBudgetBand {
  public:
    HAPTICOPT_DEFERRED
    NoiseBudgetBand(const NormalizedPlant& plant, const VelocityEstimator& estimator, double g_max, int beta_grid)
        : sampled_(plant), estimator_(estimator), g_max_(g_max), beta_grid_(beta_grid), region_(plant, estimator) {}

    const EstimatorStabilityRegion& region() const { return region_; }
    double g_max() const { return g_max_; }
    HAPTICOPT_DEFERRED
    double noise(double a, double b) const { return estimator_force_noise_gain(sampled_, estimator_, a, b); }

    /// beta_lo (side 0) or beta_hi (side 1) at alpha; NaN where g_min(alpha) > g_max.
    HAPTICOPT_DEFERRED
    double edge(double a, int side) const {
        const std::pair<double, double> interval = region_.beta_interval(a);
        if (!(interval.second > interval.first)) return std::nan("");
        if (std::isinf(g_max_)) return side == 0 ? interval.first : interval.second;
        const ScalarMinimum m = noise_minimum(a, interval);
        if (!(m.value <= g_max_)) return std::nan("");
        return bisect(a, m.x, side == 0 ? interval.first : interval.second, interval.second - interval.first);
    }

    /// The band at alpha: (lo, hi) and the minimiser of g_F (NaN with g_max = +inf); all NaN when empty.
    struct Band {
        double lo = std::nan("");
        double hi = std::nan("");
        double least_noise_beta = std::nan("");
        bool empty() const { return !(hi > lo); }
    };
    HAPTICOPT_DEFERRED
    Band band(double a) const {
        const std::pair<double, double> interval = region_.beta_interval(a);
        Band out;
        if (!(interval.second > interval.first)) return out;
        if (std::isinf(g_max_)) {
            out.lo = interval.first;
            out.hi = interval.second;
            return out;
        }
        const ScalarMinimum m = noise_minimum(a, interval);
        if (!(m.value <= g_max_)) return out;
        const double width = interval.second - interval.first;
        out.lo = bisect(a, m.x, interval.first, width);
        out.hi = bisect(a, m.x, interval.second, width);
        out.least_noise_beta = m.x;
        return out;
    }

  private:
    HAPTICOPT_DEFERRED
    ScalarMinimum noise_minimum(double a, const std::pair<double, double>& interval) const {
        auto range = [&](double) { return interval; };
        auto g = [&](double, double b) { return noise(a, b); };
        return minimize_over_beta(g, range, a, beta_grid_);
    }

    HAPTICOPT_DEFERRED
    double bisect(double a, double inside, double outside, double width) const {
        if (noise(a, outside) <= g_max_) return outside;  // the budget does not bind before the edge
        for (int k = 0; k < 200 && std::abs(outside - inside) > 1e-13 * width; ++k) {
            const double mid = (inside + outside) / 2;
            (noise(a, mid) <= g_max_ ? inside : outside) = mid;
        }
        return inside;
    }

    SampledPlant<double> sampled_;
    VelocityEstimator estimator_;
    double g_max_;
    int beta_grid_;
    EstimatorStabilityRegion region_;
};

/// The largest alpha in [floor top, top) where holds(alpha), for a property that holds below some alpha and not
/// above it: a scan down from top over `grid` points log-spaced to floor top (the first point where it holds),
/// then bisection in log alpha between it and the scan point above to `log_tolerance`. Returns the alpha where it
/// holds; NaN when no scan point holds.
template <typename Holds>
double largest_alpha_where(Holds&& holds, double top, double floor, int grid, double log_tolerance) {
    const double l1 = std::log(top), l0 = std::log(floor * top), step = (l1 - l0) / grid;
    double with = l1, without = std::nan("");
    for (int i = 0; i < grid; ++i) {
        const double l = l1 - (i + 0.5) * step;
        if (holds(std::exp(l))) {
            without = l;
            break;
        }
        with = l;
    }
    if (std::isnan(without)) return without;
    while (with - without > log_tolerance) {
        const double mid = (with + without) / 2;
        (holds(std::exp(mid)) ? without : with) = mid;
    }
    return std::exp(without);
}

/// The least C_OV over the band at alpha, or a value <= tolerance as soon as one is found: the band's cell
/// centres (`beta_grid`), then Brent on the best one's neighbouring cells. (beta, C_OV); +inf on an empty band.
HAPTICOPT_DEFERRED
ScalarMinimum least_overshoot(const SampledPlant<double>& sampled, const VelocityEstimator& estimator,
                              const std::pair<double, double>& band, double a, int beta_grid,
                              const OvershootOptions& ov) {
    if (!(band.second > band.first)) return {band.first, HUGE_VAL};
    auto c_ov = [&](double b) { return static_cast<double>(estimator_overshoot(sampled, estimator, a, b, ov).value); };
    const double step = (band.second - band.first) / beta_grid;
    int best = 0;
    double best_value = HUGE_VAL;
    for (int i = 0; i < beta_grid; ++i) {
        const double b = band.first + (i + 0.5) * step;
        const double v = c_ov(b);
        if (v <= ov.tolerance) return {b, v};
        if (v < best_value) {
            best_value = v;
            best = i;
        }
    }
    const double centre = band.first + (best + 0.5) * step;
    const ScalarMinimum m =
        minimize_scalar(c_ov, std::max(band.first, centre - step), std::min(band.second, centre + step),
                        1e-12 * std::max(std::abs(centre), band.second - band.first));
    return m.value <= best_value ? m : ScalarMinimum{centre, best_value};
}

/// amax, OV and CEx+OV under the budget (optimal_point_under_noise_budget; arguments checked there).
HAPTICOPT_DEFERRED
NoiseBudgetOptimum largest_alpha_under_noise_budget(Criterion criterion, const NormalizedPlant& plant,
                                                    const VelocityEstimator& estimator, double noise_budget,
                                                    const NoiseBudgetOptions& options) {
    const char* fn = "hapticopt::optimal_point_under_noise_budget";
    NoiseBudgetOptimum out;
    out.criterion = criterion;
    out.estimator = estimator;
    out.noise_budget = noise_budget;
    const NoiseBudgetBand budget(plant, estimator, noise_budget, options.beta_grid);
    out.alpha_max = budget.region().alpha_max();
    const SampledPlant<double> sampled(plant);
    OvershootOptions ov;
    ov.tolerance = options.unconstrained.overshoot_tolerance;
    const int index = energy_index(criterion).value_or(0);
    auto energy = [&](double a, double b) {
        const EnergyCosts c = estimator_energy_costs(sampled, estimator, a, b);
        return index == 0 ? c.ce0 : index == 1 ? c.ce1 : c.ce2;
    };
    // The criterion's beta in the band at alpha and whether its property holds there: (beta, holds).
    auto choose = [&](double a) -> std::pair<double, bool> {
        const NoiseBudgetBand::Band band = budget.band(a);
        if (band.empty()) return {std::nan(""), false};
        if (criterion == Criterion::AlphaMax) return {band.least_noise_beta, true};
        double b = 0;
        if (criterion == Criterion::Overshoot) {
            b = least_overshoot(sampled, estimator, {band.lo, band.hi}, a, options.beta_grid, ov).x;
        } else {
            auto range = [&](double) { return std::pair<double, double>{band.lo, band.hi}; };
            const ScalarMinimum m = minimize_over_beta(energy, range, a, options.beta_grid);
            if (!std::isfinite(m.value)) return {m.x, false};
            b = m.x;
        }
        return {b, estimator_overshoot(sampled, estimator, a, b, ov).within_tolerance};
    };
    const double a = out.alpha_max > 0
                         ? largest_alpha_where([&](double x) { return choose(x).second; }, out.alpha_max,
                                               options.alpha_floor, options.alpha_grid, options.alpha_tolerance)
                         : std::nan("");
    if (std::isnan(a) && std::isinf(noise_budget)) {
        throw InvalidParameter(fn, "overshoot_tolerance", ov.tolerance,
                               "a tolerance met by some stable gains with alpha >= alpha_floor alpha_max (none found "
                               "on the scan)");
    }
    if (std::isnan(a)) {
        throw InvalidParameter(fn, "noise_budget", noise_budget,
                               criterion == Criterion::AlphaMax
                                   ? "a g_F met by some stable gains with alpha >= alpha_floor alpha_max (none "
                                     "found on the scan)"
                                   : "a g_F met without overshoot by some stable gains with alpha >= alpha_floor "
                                     "alpha_max (none found on the scan)");
    }
    out.alpha = a;
    out.beta = choose(a).first;
    out.force_noise_gain = budget.noise(out.alpha, out.beta);
    out.cost = criterion == Criterion::AlphaMax ? out.alpha
               : criterion == Criterion::Overshoot
                   ? static_cast<double>(estimator_overshoot(sampled, estimator, a, out.beta, ov).value)
                   : energy(out.alpha, out.beta);
    out.budget_active = std::isfinite(noise_budget);
    return out;
}

}  // namespace detail

/// The optimum of a criterion subject to g_F <= noise_budget, over the main stable region with the estimator:
///  - CE0..2: the method and accuracy of the header comment;
///  - amax: the stiffest wall that meets the budget, the largest alpha whose band (detail::NoiseBudgetBand) is not
///    empty, with the beta of least g_F there; cost = alpha. It lies inside the region (g_F finite), so no back-off
///    from the boundary is needed;
///  - OV: the largest alpha at which some beta of the band has C_OV <= options.unconstrained.overshoot_tolerance,
///    with the first such beta of detail::least_overshoot (the band's cell centres, then Brent towards the least
///    C_OV); cost = C_OV there;
///  - CE0+OV..CE2+OV: the largest alpha at which the band's least C_Ex (beta_opt restricted to the band: grid and
///    Brent, detail::minimize_over_beta) has C_OV <= the tolerance, with that beta; cost = C_Ex there.
/// OV and CEx+OV: the point without the budget (the same search with the band equal to the stable interval) when
/// it meets the budget (budget_active false), else the search on the band (budget_active true). A budget that cuts
/// the C_Ex curve at every alpha leaves only the band's edges, which overshoot: no CEx+OV point (the error below).
/// The three "largest alpha" searches: detail::largest_alpha_where down from alpha_max over `alpha_grid` points
/// log-spaced to alpha_floor alpha_max, then bisection in log alpha to `alpha_tolerance` (the property is taken
/// to hold below its largest alpha, as in optimum.hpp; tests/core/test_noise_budget.cpp checks each point against
/// grids of the region). The returned point meets g_F <= g_max as computed (every beta is chosen inside the band);
/// amax's budget_active is always true (g_F is infinite at the region's tip).
/// Throws InvalidParameter naming `noise_budget` when it is not finite and > 0 or when no stable gains with
/// alpha >= alpha_floor alpha_max meet it (for OV and CEx+OV: meet it without overshoot), and the options' names.
HAPTICOPT_DEFERRED
NoiseBudgetOptimum optimal_point_under_noise_budget(Criterion criterion, const NormalizedPlant& plant,
                                                    const VelocityEstimator& estimator, double noise_budget,
                                                    const NoiseBudgetOptions& options = {}) {
    const char* fn = "hapticopt::optimal_point_under_noise_budget";
    validate(plant, fn);
    validate(estimator, fn);
    detail::require_in_range(fn, "noise_budget", noise_budget, 0.0, true, HUGE_VAL,
                             "finite and > 0 (normalised g_max = sigma_max T^2 / (m q))");
    detail::require_in_range(fn, "alpha_grid", options.alpha_grid, 8, false, 1e5, "8 <= alpha_grid <= 10^5");
    detail::require_in_range(fn, "beta_grid", options.beta_grid, 4, false, 1e5, "4 <= beta_grid <= 10^5");
    detail::require_in_range(fn, "alpha_floor", options.alpha_floor, 0.0, true, 0.1, "0 < alpha_floor <= 0.1");
    detail::require_in_range(fn, "alpha_tolerance", options.alpha_tolerance, 0.0, true, 1e-3,
                             "0 < alpha_tolerance <= 1e-3");
    if (criterion == Criterion::Overshoot || requires_no_overshoot(criterion)) {
        // The point without the budget when it meets the budget (as for CE0..2); else the search on the band.
        NoiseBudgetOptimum free =
            detail::largest_alpha_under_noise_budget(criterion, plant, estimator, HUGE_VAL, options);
        if (free.force_noise_gain <= noise_budget) {
            free.noise_budget = noise_budget;
            free.budget_active = false;
            free.unconstrained_cost = free.cost;
            free.unconstrained_force_noise_gain = free.force_noise_gain;
            return free;
        }
        NoiseBudgetOptimum out =
            detail::largest_alpha_under_noise_budget(criterion, plant, estimator, noise_budget, options);
        out.budget_active = true;
        out.unconstrained_cost = free.cost;
        out.unconstrained_force_noise_gain = free.force_noise_gain;
        return out;
    }
    if (criterion == Criterion::AlphaMax) {
        return detail::largest_alpha_under_noise_budget(criterion, plant, estimator, noise_budget, options);
    }
    const int index = *energy_index(criterion);
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

    const detail::NoiseBudgetBand band(plant, estimator, noise_budget, options.beta_grid);
    auto branch_cost = [&](double log_a, int side) {
        const double a = std::exp(log_a);
        const double b = band.edge(a, side);
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
    out.beta = band.edge(out.alpha, best_side);
    out.cost = cost(out.alpha, out.beta);
    out.force_noise_gain = noise(out.alpha, out.beta);
    return out;
}

/// The OV point with the estimator and no budget: the largest alpha at which some beta of the main region's stable
/// interval has C_OV <= options.unconstrained.overshoot_tolerance, with that beta; cost = C_OV there. The search of
/// optimal_point_under_noise_budget for OV with the band equal to the stable interval (g_max = +inf). The backward
/// difference's OV point is optimal_point(Criterion::Overshoot, plant) (optimum.hpp). Throws InvalidParameter
/// naming `overshoot_tolerance` when no scanned alpha meets it, and the options' names.
HAPTICOPT_DEFERRED
NoiseBudgetOptimum estimator_overshoot_point(const NormalizedPlant& plant, const VelocityEstimator& estimator,
                                             const NoiseBudgetOptions& options = {}) {
    const char* fn = "hapticopt::estimator_overshoot_point";
    validate(plant, fn);
    validate(estimator, fn);
    detail::require_in_range(fn, "alpha_grid", options.alpha_grid, 8, false, 1e5, "8 <= alpha_grid <= 10^5");
    detail::require_in_range(fn, "beta_grid", options.beta_grid, 4, false, 1e5, "4 <= beta_grid <= 10^5");
    detail::require_in_range(fn, "alpha_floor", options.alpha_floor, 0.0, true, 0.1, "0 < alpha_floor <= 0.1");
    detail::require_in_range(fn, "alpha_tolerance", options.alpha_tolerance, 0.0, true, 1e-3,
                             "0 < alpha_tolerance <= 1e-3");
    detail::require_in_range(fn, "overshoot_tolerance", options.unconstrained.overshoot_tolerance, 0.0, true, 1.0,
                             "0 < tolerance <= 1");
    NoiseBudgetOptimum out =
        detail::largest_alpha_under_noise_budget(Criterion::Overshoot, plant, estimator, HUGE_VAL, options);
    out.budget_active = false;
    return out;
}

/// The optimum of every criterion with the estimator, as optimal_point (estimator_optimum.hpp) reports it: OV with
/// an estimator other than backward by estimator_overshoot_point (cost = C_OV there; beta_at_alpha_max from the main
/// region), every other case by optimal_point. Throws what they throw.
HAPTICOPT_DEFERRED
EstimatorOptimum estimator_optimum(Criterion criterion, const NormalizedPlant& plant,
                                   const VelocityEstimator& estimator, const EstimatorOptimumOptions& options = {}) {
    if (criterion != Criterion::Overshoot || estimator.kind == VelocityEstimatorKind::backward) {
        return optimal_point(criterion, plant, estimator, options);
    }
    NoiseBudgetOptions nbo;
    nbo.unconstrained = options;
    const NoiseBudgetOptimum ov = estimator_overshoot_point(plant, estimator, nbo);
    EstimatorOptimum out;
    out.criterion = criterion;
    out.alpha = ov.alpha;
    out.beta = ov.beta;
    out.cost = ov.cost;
    const EstimatorStabilityRegion region(plant, estimator);
    out.alpha_max = region.alpha_max();
    out.beta_at_alpha_max = region.beta_at_alpha_max();
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
