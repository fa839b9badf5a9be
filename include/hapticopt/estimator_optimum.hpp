// SPDX-License-Identifier: Apache-2.0
// The optimal gains of amax, CE0..2 and CE0+OV..CE2+OV with the wall's velocity estimator
// (velocity_estimator.hpp) over the main stable region of estimator_region.hpp (normalised units m = T = 1).
#pragma once

#include <algorithm>
#include <cmath>
#include <iterator>
#include <optional>

#include "characteristic_polynomial.hpp"
#include "config.hpp"
#include "criterion.hpp"
#include "energy_costs.hpp"
#include "energy_gradient.hpp"
#include "errors.hpp"
#include "estimator_costs.hpp"
#include "estimator_gradient.hpp"
#include "estimator_hessian.hpp"
#include "estimator_region.hpp"
#include "estimator_stability.hpp"
#include "loop_schur_form.hpp"
#include "newton_search.hpp"
#include "optimum.hpp"
#include "overshoot.hpp"
#include "parameters.hpp"
#include "region_minimum.hpp"
#include "sampled_plant.hpp"
#include "scalar_search.hpp"
#include "schur_cohn.hpp"
#include "estimator_types.hpp"

namespace hapticopt {

/// An optimum with the estimator: the criterion's point, its cost (none for amax) and the main region's tip.
struct EstimatorOptimum {
    Criterion criterion = Criterion::CE2;
    double alpha = 0;
    double beta = 0;
    std::optional<double> cost;
    double alpha_max = 0;
    double beta_at_alpha_max = 0;
};

/// Options of optimal_point with an estimator.
struct EstimatorOptimumOptions {
    RegionSearchOptions search;                    ///< grids of brent's CEx search and of the CEx+OV curve
                                                   ///< (region_minimum.hpp); newton starts from kStartAlphaFractions
    double overshoot_tolerance = 1e-12;            ///< "no overshoot" means C_OV <= this (relative), (0, 1]
    double alpha_tolerance = 1e-10;                ///< bisection tolerance of the CEx+OV points, relative to alpha_max
    OptimumMethod method = OptimumMethod::newton;  ///< search of the CE0..2 points (optimal_point below); brent is
                                                   ///< the slower independent one; CEx+OV always use brent's curve
};

/// Scan grid of the main region used by OptimumMethod::newton (optimal_point with an estimator): 16 x 16 cells,
/// no islands (EstimatorStabilityRegion: a corner tip re-scanned at 40 x 40; nothing found, again at 40 x 40 and
/// 160 x 160). The optimum needs only the main region's tip (the curve's maximum) and its stable beta intervals
/// (the Schur-Cohn verdict marched and bisected), whatever the grid, once the grid resolves the region (the scan
/// re-fits its box until the region fills at least 60 % of it, so 16 cells give it about 10 in each direction);
/// the tests require alpha_max of this grid and the default one to agree to 1e-10 at smooth tips.
inline constexpr EstimatorRegionOptions kFastOptimumRegionGrid{16, 16, false};

/// OptimumMethod::newton with an estimator: a minimum found below this fraction of alpha_max is on the edge
/// alpha -> 0+, and its beta is polished there by a 1-d Newton (optimal_point; the polished point is kept only
/// where its cost is lower). Near that edge the cost's rounding grows (the loop nears marginal stability; ~1e-9
/// relative at 1e-9 alpha_max for window 30, d = 0, gamma = 0.01), so the 2-d steps stop wherever rounding
/// swamps their decrease, between ~1e-10 and ~2e-9 alpha_max in the sweep (scripts/estimator-optimum-sweep.sh),
/// with beta not yet minimised; 1e-6 lies well above that.
inline constexpr double kAlphaEdge = 1e-6;

/// The start grid's alphas of OptimumMethod::newton with an estimator, as fractions of alpha_max: spaced
/// geometrically towards alpha -> 0+, where the CE2 minima of slow estimators lie (0.022-0.43 alpha_max over the
/// 180 cases of scripts/estimator-optimum-sweep.sh). A uniform grid of 6 x 4 points starts Newton in a local
/// minimum's basin for window 30, d = 0, delta = 0.05 (global minimum at 0.026 alpha_max); this one does not, with
/// 15 costs instead of 24. A start point whose loop lies within kStabilityRefinementMargin of instability
/// (Schur-Cohn margin) is skipped: its cost would take the complex-Schur route (333 us against 27 us for window 15,
/// d = 6, at 0.03 alpha_max), and a loop that close to instability is no candidate for a minimum of the energy.
inline constexpr double kStartAlphaFractions[] = {0.75, 0.4, 0.15, 0.06, 0.025};
/// The start grid's betas at each start alpha: cell centres of the main region's beta interval there.
inline constexpr int kStartBetas = 3;
/// Start rows that compete with the best start point (OptimumMethod::newton with an estimator): a start row other
/// than the best point's whose middle point costs at most kRowRefineRatio times the best point, in a steep valley
/// (both its neighbours at least kRowValleySteepness times its cost). A slow window's CE2 minima lie in beta valleys
/// about a quarter of the interval wide near alpha -> 0+, which can fall between a row's three points (window 60,
/// d = 0, delta = 0.05: the 0.025 row's points 2.3e5, 4.6e4, 1.5e6, its minimum 1.6e4, the best point 2.1e4 in a
/// local minimum's basin) or hold a row's minimum below the best point's in another basin (d = 1: the 0.15 row
/// 2.9e4 against the best point's 4.0e4, whose own row holds 1.8e4). Where a row competes, each competing row and
/// the best point's row have their minimum over beta by Brent (minimize_scalar: kRowRefineSteps steps after the
/// first point, to kRowRefineTolerance of the row's interval width, between the neighbours of the row's lowest
/// point or an interval end), and Newton starts from the lowest point. Where none competes (window 15 and the
/// low-pass 0.02 at d = 6 for CE0..2), the start grid's 15 costs are all.
inline constexpr double kRowRefineRatio = 3;
/// See kRowRefineRatio.
inline constexpr double kRowValleySteepness = 2;
/// See kRowRefineRatio: Newton polishes the start, so the row's minimum is needed only to pick the basin.
inline constexpr double kRowRefineTolerance = 1e-2;
/// See kRowRefineRatio.
inline constexpr int kRowRefineSteps = 7;

/// The optimum of amax, CE0..2 or CE0+OV..CE2+OV with the estimator over the main stable region. The backward
/// difference is optimal_point() (optimum.hpp, with options.method). Others: alpha_max from
/// EstimatorStabilityRegion; the CEx points by options.method:
///  - newton (default): the region on the kFastOptimumRegionGrid scan; a start grid of the kStartAlphaFractions
///    of alpha_max x kStartBetas betas across the main region's beta interval at each (cell centres; the
///    interval's ends to 1e-3; points within the Schur-Cohn margin skipped); the minimum over beta of the start
///    rows that compete with the best start point, and of the best point's row, where a row competes
///    (kRowRefineRatio); then damped Newton (newton_search.hpp, minimize_newton_2d) from the lowest start point on the
///    analytic gradient and exact Hessian (estimator_energy_cost_hessian, estimator_hessian.hpp), in coordinates scaled
///    by alpha_max and that point's interval width, to a step below 1e-12 of them or the function's resolution; the
///    cost is the one Newton's last evaluation gives (newton_search.hpp). A minimum below kAlphaEdge alpha_max lies on
///    the edge alpha -> 0+ (gamma > 0): its beta is then minimised at that alpha by minimize_newton_1d. A point outside
///    the main region's beta interval there, or a start grid without a finite cost, goes to brent's region search on
///    the same region;
///  - brent: the region on the default 160 x 160 scan; minimize_on_region (region_minimum.hpp: coarse grid over
///    (0, alpha_max) x the main region's beta interval, then Brent over alpha with Brent over beta inside).
/// The tests require both to agree (tests/core/test_estimator_fast_optimum.cpp); measured times of both:
/// docs/benchmarks.md. The CEx+OV points (either method) as in optimum.hpp:
/// the optimal curve beta_opt(alpha) (grid + Brent over the main region's beta interval), a scan down from
/// alpha_max in `search.alpha_grid` steps to the first alpha whose curve point has C_OV <= tolerance
/// (estimator_overshoot), then bisection. Throws InvalidParameter for the OV criterion (its point is not
/// searched with an estimator) and when no scanned curve point meets the tolerance. An empty main region
/// (alpha_max = 0) gives cost +inf for the CEx criteria.
HAPTICOPT_FUNC EstimatorOptimum optimal_point(Criterion criterion, const NormalizedPlant& plant,
                                              const VelocityEstimator& estimator,
                                              const EstimatorOptimumOptions& options = {})
#if HAPTICOPT_DEFINITIONS
{
    const char* fn = "hapticopt::optimal_point";
    validate(estimator, fn);
    detail::require_in_range(fn, "overshoot_tolerance", options.overshoot_tolerance, 0.0, true, 1.0,
                             "0 < tolerance <= 1");
    detail::require_in_range(fn, "alpha_tolerance", options.alpha_tolerance, 0.0, true, 1e-2,
                             "0 < alpha_tolerance <= 0.01");
    EstimatorOptimum out;
    out.criterion = criterion;
    if (estimator.kind == VelocityEstimatorKind::backward) {
        OptimumOptions o;
        o.overshoot_tolerance = options.overshoot_tolerance;
        o.method = options.method;
        const Optimum b = optimal_point(criterion, plant, o);
        out.alpha = b.alpha;
        out.beta = b.beta;
        out.cost = b.cost;
        out.alpha_max = b.alpha_max;
        out.beta_at_alpha_max = b.beta_at_alpha_max;
        return out;
    }
    if (criterion == Criterion::Overshoot) {
        throw InvalidParameter(fn, "criterion", static_cast<double>(criterion),
                               "amax, CE0..2 or CE0+OV..CE2+OV with a velocity estimator other than backward");
    }
    // The fast method serves the CEx points; the CEx+OV points keep the nested Brent curve (their time goes to the
    // overshoot scans, and their bisection needs beta_opt only to the overshoot's resolution).
    const bool newton = options.method == OptimumMethod::newton && !requires_no_overshoot(criterion);
    const EstimatorStabilityRegion region(plant, estimator, newton ? kFastOptimumRegionGrid : EstimatorRegionOptions{});
    out.alpha_max = region.alpha_max();
    out.beta_at_alpha_max = region.beta_at_alpha_max();
    if (criterion == Criterion::AlphaMax) {
        out.alpha = out.alpha_max;
        out.beta = out.beta_at_alpha_max;
        return out;
    }
    if (!(out.alpha_max > 0) && !requires_no_overshoot(criterion)) {  // no main region: no CEx point
        out.cost = HUGE_VAL;
        return out;
    }
    const int index = *energy_index(criterion);
    const SampledPlant<double> sampled(plant);
    auto cost = [&](double a, double b) {
        const EnergyCosts c = estimator_energy_costs(sampled, estimator, a, b);
        return index == 0 ? c.ce0 : index == 1 ? c.ce1 : c.ce2;
    };
    auto interval = [&](double a) { return region.beta_interval(a); };
    auto gradient = [&](double a, double b) { return estimator_energy_cost_gradient(sampled, estimator, a, b, index); };
    if (!requires_no_overshoot(criterion) && newton) {
        // The start grid (kStartAlphaFractions x kStartBetas) over the main region, then damped Newton
        // (newton_search.hpp) in coordinates scaled by alpha_max and the start point's beta interval width.
        // The start grid's intervals need their ends to a small fraction of a grid cell only: 1e-3 (the march
        // brackets them to a quarter of a scan cell first).
        double best_a = out.alpha_max / 2, best_b = 0, best_width = 1, best_value = HUGE_VAL;
        const AffineCharacteristicPolynomial<double> p_est =
            estimator_characteristic_polynomial(characteristic_polynomial(sampled), estimator);
        constexpr int rows = static_cast<int>(std::size(kStartAlphaFractions));
        double row_lo[rows] = {}, row_hi[rows] = {}, row_value[rows][kStartBetas];
        for (int i = 0; i < rows; ++i) {
            const double a = kStartAlphaFractions[i] * out.alpha_max;
            const auto [lo, hi] = region.beta_interval(a, 1e-3);
            row_lo[i] = lo;
            row_hi[i] = hi;
            for (int j = 0; j < kStartBetas; ++j) {
                row_value[i][j] = HUGE_VAL;
                if (!(hi > lo)) continue;
                const double b = lo + (j + 0.5) * (hi - lo) / kStartBetas;
                // cost(a, b) on the verdict already taken here (estimator_energy_costs' structured route).
                const SchurCohnResult<double> sc = schur_cohn<double>(p_est.at(a, b));
                double v = HUGE_VAL;
                if (std::abs(sc.margin) >= kStabilityRefinementMargin && sc.stable) {
                    const EnergyCosts c = detail::structured_estimator_energy_costs(
                        sampled, estimator, make_estimator_loop(sampled, estimator, a, b, false).loop);
                    v = index == 0 ? c.ce0 : index == 1 ? c.ce1 : c.ce2;
                }
                row_value[i][j] = v;
                if (v < best_value) {
                    best_value = v;
                    best_a = a;
                    best_b = b;
                    best_width = hi - lo;
                }
            }
        }
        // The start rows that compete with the best start point (kRowRefineRatio) and, where one does, the best
        // point's row: their minima over beta between the neighbours of the row's lowest point (or its interval end).
        static_assert(kStartBetas == 3, "the valley test reads a row's three points");
        const double best_start = best_value;
        bool competing[rows] = {};
        bool any = false;
        int best_row = -1;
        for (int i = 0; i < rows; ++i) {
            const double* v = row_value[i];
            if (v[0] == best_start || v[1] == best_start || v[2] == best_start) {
                if (best_row < 0) best_row = i;
                continue;
            }
            competing[i] = v[1] <= kRowRefineRatio * best_start && v[0] >= kRowValleySteepness * v[1] &&
                           v[2] >= kRowValleySteepness * v[1];
            any = any || competing[i];
        }
        if (any && best_row >= 0) competing[best_row] = true;
        for (int i = 0; i < rows && any; ++i) {
            if (!competing[i]) continue;
            const double* v = row_value[i];
            const int k = v[0] <= v[1] && v[0] <= v[2] ? 0 : v[1] <= v[2] ? 1 : 2;
            const double a = kStartAlphaFractions[i] * out.alpha_max;
            const double width = row_hi[i] - row_lo[i];
            const detail::ScalarMinimum m = detail::minimize_scalar(
                [&](double b) { return cost(a, b); }, row_lo[i] + std::max(2 * k - 1, 0) * width / 6,
                row_lo[i] + std::min(2 * k + 3, 6) * width / 6, kRowRefineTolerance * width, kRowRefineSteps);
            if (m.value < best_value) {
                best_value = m.value;
                best_a = a;
                best_b = m.x;
                best_width = width;
            }
        }
        // No finite start cost (a region thinner than the start grid resolves): the region search below.
        if (std::isfinite(best_value)) {
            auto fg = [&](double a, double b) {
                if (!(a > 0 && a < out.alpha_max)) return detail::ValueGradientHessian2{HUGE_VAL, 0, 0, 0, 0, 0};
                const EnergyCostHessian g = estimator_energy_cost_hessian(sampled, estimator, a, b, index);
                return detail::ValueGradientHessian2{g.value,         g.d_alpha,      g.d_beta,
                                                     g.d_alpha_alpha, g.d_alpha_beta, g.d_beta_beta};
            };
            detail::NewtonMinimum2 m = detail::minimize_newton_2d(fg, best_a, best_b, out.alpha_max, best_width);
            // The steps are bounded in alpha only; a point outside the main region's beta interval (another stable
            // region, or within the ends' 1e-6 of them) leaves the answer to the region search below.
            const auto [lo, hi] = region.beta_interval(m.x, 1e-6);
            if (m.y > lo && m.y < hi) {
                if (m.x < kAlphaEdge * out.alpha_max) {
                    // The minimum lies on the edge alpha -> 0+ (with gamma > 0), where the damped 2-d steps move
                    // along alpha only: beta's minimum at that alpha by the 1-d Newton.
                    const double a = m.x;
                    auto fd = [&](double b) {
                        const EnergyCostGradient g = gradient(a, b);
                        return detail::ValueAndDerivative{g.value, g.d_beta};
                    };
                    const detail::NewtonMinimum2 e = detail::minimize_newton_1d(fd, m.y, lo, hi);
                    if (e.value < m.value) {
                        m.y = e.x;
                        m.value = e.value;
                    }
                }
                out.alpha = m.x;
                out.beta = m.y;
                out.cost = m.value;
                return out;
            }
        }
    }
    if (!requires_no_overshoot(criterion)) {
        const RegionMinimum m = minimize_on_region(cost, 0.0, out.alpha_max, interval, options.search);
        out.alpha = m.alpha;
        out.beta = m.beta;
        out.cost = m.value;
        return out;
    }
    OvershootOptions ov;
    ov.tolerance = options.overshoot_tolerance;
    auto curve = [&](double a) { return detail::minimize_over_beta(cost, interval, a, options.search.beta_grid); };
    auto no_overshoot = [&](double a) {
        const detail::ScalarMinimum m = curve(a);
        return std::isfinite(m.value) && estimator_overshoot(sampled, estimator, a, m.x, ov).within_tolerance;
    };
    const int n = options.search.alpha_grid;
    double without = -1, with = out.alpha_max;
    for (int i = 1; i < n; ++i) {
        const double a = out.alpha_max * (1 - static_cast<double>(i) / n);
        if (no_overshoot(a)) {
            without = a;
            break;
        }
        with = a;
    }
    if (without < 0) {
        throw InvalidParameter(fn, "overshoot_tolerance", options.overshoot_tolerance,
                               "a tolerance met somewhere on the optimal curve (none found on the scan)");
    }
    while (with - without > options.alpha_tolerance * out.alpha_max) {
        const double mid = (with + without) / 2;
        (no_overshoot(mid) ? without : with) = mid;
    }
    const detail::ScalarMinimum m = curve(without);
    out.alpha = without;
    out.beta = m.x;
    out.cost = m.value;
    return out;
}
#else
    ;
#endif

}  // namespace hapticopt
