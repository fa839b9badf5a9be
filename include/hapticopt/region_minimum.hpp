// SPDX-License-Identifier: Apache-2.0
// Global minimum of a cost c(a, b) over a region { a0 < a < a1, lo(a) < b < hi(a) } of the gain
// plane: the search of optimum.hpp, for any cost and any region given by its b interval per a
// (the exact stable region, the passive part of it, the robustly stable set).
//
//  - optimal curve b_opt(a): `beta_grid` cell centres spanning (lo(a), hi(a)), then Brent's method
//    (scalar_search.hpp) on the best cell and its neighbours;
//  - optimal point: `alpha_grid` cell centres across (a0, a1), each with the coarse b grid, then Brent
//    over a on the best cell and its neighbours with b_opt(a) inside.
// Converges to the global minimum when the grid resolves its basin (the costs of this library are
// smooth inside the region and grow towards its stability boundary); a minimum on the region's
// edge is approached to Brent's tolerance. Non-finite costs count as worse than any finite one; an
// empty interval (hi <= lo) means "no admissible b at this a".
// Cost: alpha_grid * beta_grid + about 40 * (beta_grid + 40) evaluations of c.
#pragma once

#include <algorithm>
#include <cmath>
#include <utility>

#include "errors.hpp"
#include "scalar_search.hpp"

namespace hapticopt {

struct RegionMinimum {
    double alpha = 0;
    double beta = 0;
    double value = HUGE_VAL;  ///< +inf when no admissible point has a finite cost
};

struct RegionSearchOptions {
    int alpha_grid = 24;  ///< >= 4
    int beta_grid = 16;   ///< >= 4
};

namespace detail {

/// b_opt(a) and the cost there; value +inf when the interval is empty.
template <typename Cost, typename Interval>
ScalarMinimum minimize_over_beta(Cost& cost, Interval& interval, double a, int beta_grid) {
    const auto [lo, hi] = interval(a);
    if (!(hi > lo)) return {lo, HUGE_VAL};
    const double step = (hi - lo) / beta_grid;
    int best = 0;
    double best_value = HUGE_VAL;
    for (int i = 0; i < beta_grid; ++i) {
        const double v = cost(a, lo + (i + 0.5) * step);
        if (v < best_value) {
            best_value = v;
            best = i;
        }
    }
    const double centre = lo + (best + 0.5) * step;
    auto f = [&](double b) { return cost(a, b); };
    const ScalarMinimum m = minimize_scalar(f, std::max(lo, centre - step), std::min(hi, centre + step),
                                            1e-12 * std::max(std::abs(centre), hi - lo));
    if (!(m.value <= best_value)) return {centre, best_value};
    return m;
}

}  // namespace detail

/// The global minimum of cost(a, b) over the region (header comment). `interval(a)` returns the
/// admissible (lo, hi) at a. Throws InvalidParameter unless a0 < a1 and the grids are >= 4.
template <typename Cost, typename Interval>
RegionMinimum minimize_on_region(Cost&& cost, double a0, double a1, Interval&& interval,
                                 const RegionSearchOptions& options = {}) {
    const char* fn = "hapticopt::minimize_on_region";
    detail::require_finite(fn, "a0", a0);
    detail::require_in_range(fn, "a1", a1, a0, true, HUGE_VAL, "finite and > a0");
    detail::require_in_range(fn, "alpha_grid", options.alpha_grid, 4, false, 1e6, "4 <= alpha_grid <= 10^6");
    detail::require_in_range(fn, "beta_grid", options.beta_grid, 4, false, 1e6, "4 <= beta_grid <= 10^6");
    const int n = options.alpha_grid;
    const double step = (a1 - a0) / n;
    int best = -1;
    double best_value = HUGE_VAL;
    for (int i = 0; i < n; ++i) {
        const double a = a0 + (i + 0.5) * step;
        const auto [lo, hi] = interval(a);
        if (!(hi > lo)) continue;
        for (int j = 0; j < options.beta_grid; ++j) {
            const double v = cost(a, lo + (j + 0.5) * (hi - lo) / options.beta_grid);
            if (v < best_value) {
                best_value = v;
                best = i;
            }
        }
    }
    RegionMinimum out;
    if (best < 0) return out;
    const double centre = a0 + (best + 0.5) * step;
    auto curve = [&](double a) { return detail::minimize_over_beta(cost, interval, a, options.beta_grid).value; };
    const double lo = std::max(a0 + 1e-12 * (a1 - a0), centre - step), hi = std::min(a1, centre + step);
    const detail::ScalarMinimum m = detail::minimize_scalar(curve, lo, hi, 1e-10 * (a1 - a0));
    const double a = std::isfinite(m.value) ? m.x : centre;
    const detail::ScalarMinimum b = detail::minimize_over_beta(cost, interval, a, options.beta_grid);
    out.alpha = a;
    out.beta = b.x;
    out.value = b.value;
    return out;
}

}  // namespace hapticopt
