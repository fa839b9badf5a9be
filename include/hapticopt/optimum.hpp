// SPDX-License-Identifier: Apache-2.0
// Optimal curves beta_opt(alpha) and optimal points of the eight criteria of Tables III and IV.
//
// Definitions (Hulin et al. 2011, Sect. IV): optimal curve of C = argmin over stable beta of C(alpha, beta); CEx
// point = global minimum of C_Ex over the stable region; amax point = tip of the region; OV point =
// largest alpha for which some beta gives C_OV <= tol; CEx+OV point = largest alpha on the C_Ex
// optimal curve with C_OV <= tol, its cost C_Ex there.
//
// Global search (OptimumMethod::brent for the energy optima; the fast path below). The cost surfaces
// are not convex everywhere, so every search starts coarse over the whole exact stable region
// (stability_region.hpp gives the stable beta interval at each alpha) and refines locally:
//  - beta_opt(alpha): `beta_grid` points spanning the stable beta interval, Brent's method on the
//    best point's neighbours, then Newton steps on central differences (h = 1e-5 beta) that take
//    beta from Brent's sqrt(eps) flatness limit to ~1e-10;
//  - CEx: `alpha_grid` alphas across (-gamma, alpha_max), each with the coarse beta grid, then
//    Brent over alpha (to `alpha_tolerance`) on the best grid alpha's neighbours with beta_opt(alpha)
//    inside;
//  - OV and CEx+OV: a scan down from alpha_max in `alpha_grid` steps to the first alpha without
//    overshoot, then bisection to `alpha_tolerance` between it and the previous scan point. The overshoot
//    evaluations stop early (OvershootOptions::stop_above): for CEx+OV above the tolerance (only the
//    comparison with it is needed); for the OV point, inside the minimum over beta, the grid's evaluations
//    above the lowest value found so far, and all of them above max(1 %, 100 tol) (far from the OV point,
//    near alpha_max, the loop is barely damped and its overshoot would be followed for thousands of periods).
//    Bisection, not a secant method: min over beta of C_OV, and C_OV along beta_opt(alpha), jump at the
//    alpha where they reach the tolerance (a new peak crosses it), so a secant step gains nothing.
// The tests check each optimum against a 120 x 120 grid of the stable region (no grid point is
// better) and the optimal curves against the sign change of dC/dbeta evaluated in long double.
// Cost: a few thousand cost evaluations for a CEx point; measured times in docs/benchmarks.md.
//
// Fast path (OptimumMethod::newton, the default) for the energy criteria, with the analytic gradient of
// energy_gradient.hpp (adjoint Stein equation):
//  - CEx point: a start grid of alpha_grid / 3 alphas x 3 beta_grid / 8 betas (at least 4 each; 8 x 6 by
//    default) across the stable region, then damped Newton (newton_search.hpp: Levenberg-Marquardt on the
//    analytic gradient, Hessian from its forward differences) from the best grid point, in coordinates scaled
//    by the region's alpha range and the stable beta interval's width there, to a step below 1e-12 of those
//    (16 to 60 gradient evaluations at d = 0, 1, 6);
//  - beta_opt(alpha) of C_Ex (also inside the CEx+OV bisection): 3 beta_grid / 8 betas (6 by default) across
//    the stable interval, then the one-dimensional damped Newton on dC/dbeta.
// It stops where the gradient vanishes to rounding, so its point is at least as accurate as the nested
// Brent search's (OptimumMethod::brent, kept as the independent slower method); the tests require both to
// give the same point and cost on every table row and at d = 0, 1, 6 (tests/core/test_fast_optimum.cpp).
// The OV point (overshoot only) does not use it. Measured times of both: docs/benchmarks.md.
#pragma once

#include <algorithm>
#include <optional>

#include "config.hpp"
#include "criterion.hpp"
#include "energy_costs.hpp"
#include "energy_gradient.hpp"
#include "newton_search.hpp"
#include "overshoot.hpp"
#include "stability_region.hpp"

namespace hapticopt {

/// How the energy optima (CEx points and the C_Ex optimal curves) are searched (header comment).
enum class OptimumMethod {
    newton,  ///< start grid, then damped Newton on the analytic gradient (fast; the default)
    brent,   ///< coarse grid, then nested Brent (derivative-free; the slower independent method)
};

struct OptimumOptions {
    double overshoot_tolerance = 1e-12;            ///< "no overshoot" means C_OV <= this (relative), (0, 1]
    int alpha_grid = 24;                           ///< coarse alphas across the stable region, >= 4
    int beta_grid = 16;                            ///< coarse betas across the stable interval, >= 4
    double alpha_tolerance = 1e-10;                ///< bisection tolerance of the OV and CEx+OV points, and Brent's
                                                   ///< tolerance over alpha for the CEx points (time against
                                                   ///< error: docs/accuracy.md)
    OptimumMethod method = OptimumMethod::newton;  ///< search of the energy optima (header comment); newton
                                                   ///< thins the grids for its start and has no alpha_tolerance
};

struct Optimum {
    Criterion criterion = Criterion::CE2;
    double alpha = 0;
    double beta = 0;
    std::optional<double> cost;  ///< C_Ex at the point; none for amax and OV
    double alpha_max = 0;        ///< of the stable region, for the stability margin alpha / alpha_max
    double beta_at_alpha_max = 0;
};

class WallOptimizer {
  public:
    HAPTICOPT_DEFERRED
    explicit WallOptimizer(const NormalizedPlant& plant, const OptimumOptions& options = {})
        : region_(plant), sampled_(plant), options_(options) {
        const char* fn = "hapticopt::WallOptimizer";
        detail::require_in_range(fn, "overshoot_tolerance", options.overshoot_tolerance, 0.0, true, 1.0,
                                 "0 < tolerance <= 1");
        detail::require_in_range(fn, "alpha_grid", options.alpha_grid, 4, false, 1e6, "4 <= alpha_grid <= 10^6");
        detail::require_in_range(fn, "beta_grid", options.beta_grid, 4, false, 1e6, "4 <= beta_grid <= 10^6");
        detail::require_in_range(fn, "alpha_tolerance", options.alpha_tolerance, 0.0, true, 1e-2,
                                 "0 < alpha_tolerance <= 0.01");
    }

    const StabilityRegion& region() const { return region_; }
    const SampledPlant<double>& sampled_plant() const { return sampled_; }

    /// C_E<index>(alpha, beta), +inf when unstable (solves only the index + 1 Stein equations needed).
    HAPTICOPT_DEFERRED
    double energy_cost(int index, double alpha, double beta) const {
        return hapticopt::energy_cost(sampled_, alpha, beta, index);
    }

    /// C_OV(alpha, beta) with the configured tolerance, +inf when unstable. With `stop_above` finite, a value
    /// above it is only a lower bound (OvershootOptions::stop_above).
    HAPTICOPT_DEFERRED
    double overshoot_cost(double alpha, double beta, double stop_above = HUGE_VAL) const {
        OvershootOptions o;
        o.tolerance = options_.overshoot_tolerance;
        o.stop_above = stop_above;
        return overshoot(sampled_, alpha, beta, o).value;
    }

    /// beta_opt(alpha) of C_E<index> (0..2), or of C_OV for index 3 (where a whole beta interval has
    /// no overshoot the minimiser is not unique and one point of the interval is returned).
    HAPTICOPT_DEFERRED
    double optimal_beta(int index, double alpha) const {
        if (index < 3 && options_.method == OptimumMethod::newton) return newton_curve_point(index, alpha).x;
        return curve_point(index, alpha, /*polish=*/index < 3).x;
    }

    /// C_E<index>(alpha, beta) and its gradient (energy_gradient.hpp); value +inf when unstable.
    HAPTICOPT_DEFERRED
    EnergyCostGradient energy_cost_gradient(int index, double alpha, double beta) const {
        return hapticopt::energy_cost_gradient(sampled_, alpha, beta, index);
    }

    HAPTICOPT_DEFERRED
    Optimum optimum(Criterion criterion) const {
        Optimum out;
        out.criterion = criterion;
        out.alpha_max = region_.alpha_max();
        out.beta_at_alpha_max = region_.beta_at_alpha_max();
        switch (criterion) {
            case Criterion::AlphaMax:
                out.alpha = out.alpha_max;
                out.beta = out.beta_at_alpha_max;
                return out;
            case Criterion::Overshoot: {
                const double ceiling = std::max(1e-2, 100 * options_.overshoot_tolerance);
                auto no_overshoot = [&](double a) {
                    return curve_point(3, a, false, ceiling).value <= options_.overshoot_tolerance;
                };
                const auto [lo, hi] = largest_alpha_where(no_overshoot);
                out.alpha = lo;
                out.beta = curve_point(3, hi, false).x;  // the tip's beta: minimal overshoot just outside
                return out;
            }
            case Criterion::CE0:
            case Criterion::CE1:
            case Criterion::CE2: {
                const int k = *energy_index(criterion);
                if (options_.method == OptimumMethod::newton) {
                    const detail::NewtonMinimum2 m = newton_energy_minimum(k);
                    out.alpha = m.x;
                    out.beta = m.y;
                    out.cost = energy_cost(k, out.alpha, out.beta);
                    return out;
                }
                const auto best = global_energy_minimum(k);
                out.alpha = best.first;
                out.beta = optimal_beta(k, best.first);
                out.cost = energy_cost(k, out.alpha, out.beta);
                return out;
            }
            case Criterion::CE0_OV:
            case Criterion::CE1_OV:
            case Criterion::CE2_OV: {
                const int k = *energy_index(criterion);
                const double tol = options_.overshoot_tolerance;
                auto no_overshoot = [&](double a) { return overshoot_cost(a, optimal_beta(k, a), tol) <= tol; };
                out.alpha = largest_alpha_where(no_overshoot).first;
                out.beta = optimal_beta(k, out.alpha);
                out.cost = energy_cost(k, out.alpha, out.beta);
                return out;
            }
        }
        return out;
    }

  private:
    /// Coarse grid over the stable beta interval at alpha; Brent on the best point's neighbours;
    /// optional Newton polish. Returns (beta, value). For C_OV (index 3) each grid evaluation stops above the
    /// lowest value found so far: the grid's choice depends only on comparisons with it. Brent gets whole
    /// values (its parabolas use them; C_OV over beta can have two minima in one grid cell). With a finite
    /// `ceiling` (the OV point's search) every evaluation, Brent's too, also stops above it: values above the ceiling
    /// are then only lower bounds above it.
    HAPTICOPT_DEFERRED
    detail::ScalarMinimum curve_point(int index, double alpha, bool polish, double ceiling = HUGE_VAL) const {
        const auto [lo, hi] = region_.beta_range(alpha);
        const int n = options_.beta_grid;
        const double step = (hi - lo) / n;
        bool on_grid = true;
        double lowest = HUGE_VAL;
        auto f = [&](double b) {
            if (index < 3) return energy_cost(index, alpha, b);
            const double v = overshoot_cost(alpha, b, std::min(on_grid ? lowest : HUGE_VAL, ceiling));
            lowest = std::min(lowest, v);
            return v;
        };
        int best = 0;
        double best_value = HUGE_VAL;
        for (int i = 0; i < n; ++i) {
            const double v = f(lo + (i + 0.5) * step);
            if (v < best_value) {
                best_value = v;
                best = i;
            }
        }
        on_grid = false;
        const double center = lo + (best + 0.5) * step;
        detail::ScalarMinimum m = detail::minimize_scalar(f, std::max(lo, center - step), std::min(hi, center + step),
                                                          1e-12 * std::max(1.0, std::abs(center)));
        if (polish) m = newton_polish(f, m, lo, hi);
        return m;
    }

    /// Newton steps on central differences (h = 1e-5 |x|): they take x from Brent's sqrt(eps)
    /// flatness limit to ~1e-10. A step is kept unless it leaves the bracket, is large, or raises f
    /// by more than rounding (values at a minimum differ by ~eps only, so a strict "lower" test
    /// would reject good steps).
    template <typename F>
    static detail::ScalarMinimum newton_polish(F& f, detail::ScalarMinimum m, double lo, double hi) {
        const double h = 1e-5 * std::max(1e-3, std::abs(m.x));
        for (int it = 0; it < 4; ++it) {
            if (m.x - h <= lo || m.x + h >= hi) break;
            const double fp = f(m.x + h), fm = f(m.x - h);
            const double curvature = (fp - 2 * m.value + fm) / (h * h);
            if (!(curvature > 0)) break;
            const double step = (fp - fm) / (2 * h) / curvature;
            const double x = m.x - step;
            if (!(x > lo && x < hi) || std::abs(step) > 10 * h) break;
            const double v = f(x);
            if (!(v <= m.value * (1 + 1e-12))) break;
            m = {x, v};
            if (std::abs(step) < 1e-12 * std::max(1.0, std::abs(x))) break;
        }
        return m;
    }

    /// (alpha, min over beta) of C_E<index> over the region: coarse grid, then Brent over alpha.
    HAPTICOPT_DEFERRED
    std::pair<double, double> global_energy_minimum(int index) const {
        const double a0 = region_.alpha_min(), a1 = region_.alpha_max();
        const int n = options_.alpha_grid;
        const double step = (a1 - a0) / n;
        int best = 0;
        double best_value = HUGE_VAL;
        for (int i = 0; i < n; ++i) {
            const double a = a0 + (i + 0.5) * step;
            const auto [lo, hi] = region_.beta_range(a);
            for (int j = 0; j < options_.beta_grid; ++j) {
                const double v = energy_cost(index, a, lo + (j + 0.5) * (hi - lo) / options_.beta_grid);
                if (v < best_value) {
                    best_value = v;
                    best = i;
                }
            }
        }
        const double center = a0 + (best + 0.5) * step;
        auto c = [&](double a) { return curve_point(index, a, false).value; };
        const auto m = detail::minimize_scalar(c, std::max(a0 + 1e-12, center - step), std::min(a1, center + step),
                                               options_.alpha_tolerance);
        return {m.x, m.value};
    }

    /// The CEx point by the fast path (header comment).
    HAPTICOPT_DEFERRED
    detail::NewtonMinimum2 newton_energy_minimum(int index) const {
        const int kAlphas = std::max(4, options_.alpha_grid / 3), kBetas = std::max(4, options_.beta_grid * 3 / 8);
        const double a0 = region_.alpha_min(), a1 = region_.alpha_max();
        double best_a = a0 + 0.5 * (a1 - a0), best_b = 0, best_width = 1, best_value = HUGE_VAL;
        for (int i = 0; i < kAlphas; ++i) {
            const double a = a0 + (i + 0.5) * (a1 - a0) / kAlphas;
            const auto [lo, hi] = region_.beta_range(a);
            for (int j = 0; j < kBetas; ++j) {
                const double b = lo + (j + 0.5) * (hi - lo) / kBetas;
                const double v = energy_cost(index, a, b);
                if (v < best_value) {
                    best_value = v;
                    best_a = a;
                    best_b = b;
                    best_width = hi - lo;
                }
            }
        }
        auto fg = [&](double a, double b) {
            if (!(a > a0 && a < a1)) return detail::ValueAndGradient2{HUGE_VAL, 0, 0};
            const EnergyCostGradient g = energy_cost_gradient(index, a, b);
            return detail::ValueAndGradient2{g.value, g.d_alpha, g.d_beta};
        };
        return detail::minimize_newton_2d(fg, best_a, best_b, a1 - a0, best_width);
    }

    /// beta_opt(alpha) of C_E<index> by the fast path (header comment). Returns (beta, value).
    HAPTICOPT_DEFERRED
    detail::ScalarMinimum newton_curve_point(int index, double alpha) const {
        const int kBetas = std::max(4, options_.beta_grid * 3 / 8);
        const auto [lo, hi] = region_.beta_range(alpha);
        double best_b = (lo + hi) / 2, best_value = HUGE_VAL;
        for (int j = 0; j < kBetas; ++j) {
            const double b = lo + (j + 0.5) * (hi - lo) / kBetas;
            const double v = energy_cost(index, alpha, b);
            if (v < best_value) {
                best_value = v;
                best_b = b;
            }
        }
        auto fd = [&](double b) {
            const EnergyCostGradient g = energy_cost_gradient(index, alpha, b);
            return detail::ValueAndDerivative{g.value, g.d_beta};
        };
        const detail::NewtonMinimum2 m = detail::minimize_newton_1d(fd, best_b, lo, hi);
        return {m.x, m.value};
    }

    /// Scan down from alpha_max to the first alpha where `ok` holds, bisect to alpha_tolerance.
    /// Returns the bracket (ok at first, not ok at second).
    template <typename Ok>
    std::pair<double, double> largest_alpha_where(Ok&& ok) const {
        const double a0 = region_.alpha_min(), a1 = region_.alpha_max();
        const int n = options_.alpha_grid;
        double previous = a1 - 1e-9 * (a1 - a0);
        for (int k = 1; k < n; ++k) {
            const double a = a1 - (a1 - a0) * k / n;
            if (ok(a)) return detail::bisect(ok, a, previous, options_.alpha_tolerance);
            previous = a;
        }
        throw InvalidParameter("hapticopt::WallOptimizer", "overshoot_tolerance", options_.overshoot_tolerance,
                               "a tolerance met somewhere in the stable region (none found on the scan)");
    }

    StabilityRegion region_;
    SampledPlant<double> sampled_;
    OptimumOptions options_;
};

/// The optimum of one criterion for a normalised plant (only that criterion is computed).
HAPTICOPT_FUNC Optimum optimal_point(Criterion criterion, const NormalizedPlant& plant,
                                     const OptimumOptions& options = {})
#if HAPTICOPT_DEFINITIONS
{
    return WallOptimizer(plant, options).optimum(criterion);
}
#else
    ;
#endif

}  // namespace hapticopt
