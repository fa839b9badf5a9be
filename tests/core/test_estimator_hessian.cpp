// SPDX-License-Identifier: Apache-2.0
// The exact Hessian of C_E0..2 with the velocity estimator (estimator_hessian.hpp: estimator_energy_cost_hessian)
// checked against (a) central differences of the analytic gradient (estimator_energy_cost_gradient, an
// independent code path through the adjoint only) and (b) the same Hessian in long double, for the backward
// difference, low-pass filters and windows at d = 0, 1, 6, at a point inside the main region and at the CE2
// optimum; and the damped Newton search (newton_search.hpp) with a Hessian callback.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <string>
#include <utility>
#include <vector>

#include <hapticopt/hapticopt.hpp>

namespace hapticopt {
namespace estimator_hessian_test {

std::string describe(const VelocityEstimator& e, double d, int p, double a, double b) {
    return "kind=" + std::to_string(static_cast<int>(e.kind)) + " nu=" + std::to_string(e.cutoff) +
           " N=" + std::to_string(e.window) + " d=" + std::to_string(d) + " p=" + std::to_string(p) +
           " alpha=" + std::to_string(a) + " beta=" + std::to_string(b);
}

struct Point {
    double alpha, beta;
};

// A point inside every main region of these estimators (as in test_estimator_fast_optimum.cpp) and the CE2
// optimum, where the gradient vanishes and the Hessian alone carries the Newton step.
std::vector<Point> points(const NormalizedPlant& np, const VelocityEstimator& e) {
    const double d = np.delay;
    const EstimatorOptimum o = optimal_point(Criterion::CE2, np, e);
    return {{d >= 6 ? 0.0013 : 0.003, d >= 6 ? 0.05 : 0.09}, {o.alpha, o.beta}};
}

const std::vector<VelocityEstimator>& estimators() {
    static const std::vector<VelocityEstimator> list = {
        VelocityEstimator::backward_difference(), VelocityEstimator::low_pass(0.02), VelocityEstimator::low_pass(0.2),
        VelocityEstimator::moving_window(5), VelocityEstimator::moving_window(15)};
    return list;
}

TEST(EstimatorEnergyCostHessian, MatchesCentralDifferencesOfTheGradient) {
    // Central differences of the double gradient with step h_x = 1e-4 x (x = alpha or beta): truncation
    // (h^2 / 6) |g'''| ~ 2e-9 C / (x y) for costs that vary on the scale of the gains, rounding e_g |g| / h with
    // the gradient's relative error e_g <= 1e-12 (Stein solutions ~1e-13 / (1 - rho)^2, rho <= 0.99 here), so
    // <= 1e-8 C / (x y). Tolerance 1e-6 C / (x y) + 1e-6 |H|: 100x above that estimate (measured: the largest
    // error is 7.3e-8 (C / (x y) + |H|), where the cost varies faster than on the gains' scale, 14x below it; with a
    // sixth of the <L_0, E_alpha,alpha> term left out it is 0.44 (C / (x y) + |H|)). Each mixed entry is checked
    // against both differences (d_alpha along beta and d_beta along alpha), which also checks the symmetry.
    int checked = 0;
    for (const VelocityEstimator& e : estimators()) {
        for (double d : {0.0, 1.0, 6.0}) {
            const NormalizedPlant np{0.001, 0.02, d};
            const SampledPlant<double> plant(np);
            for (const Point& pt : points(np, e)) {
                const double a = pt.alpha, b = pt.beta;
                for (int p = 0; p < 3; ++p) {
                    const std::string where = describe(e, d, p, a, b);
                    const EnergyCostHessian h = estimator_energy_cost_hessian(plant, e, a, b, p);
                    const EnergyCostGradient g = estimator_energy_cost_gradient(plant, e, a, b, p);
                    ASSERT_TRUE(std::isfinite(h.value)) << where;
                    // The value and gradient are the gradient's by the same solves: rounding only.
                    EXPECT_NEAR(h.value / g.value, 1.0, 1e-13) << where;
                    EXPECT_NEAR(h.d_alpha, g.d_alpha, 1e-12 * g.value / a) << where;
                    EXPECT_NEAR(h.d_beta, g.d_beta, 1e-12 * g.value / b) << where;
                    const double ha = 1e-4 * a, hb = 1e-4 * b;
                    const EnergyCostGradient ap = estimator_energy_cost_gradient(plant, e, a + ha, b, p);
                    const EnergyCostGradient am = estimator_energy_cost_gradient(plant, e, a - ha, b, p);
                    const EnergyCostGradient bp = estimator_energy_cost_gradient(plant, e, a, b + hb, p);
                    const EnergyCostGradient bm = estimator_energy_cost_gradient(plant, e, a, b - hb, p);
                    const double aa = (ap.d_alpha - am.d_alpha) / (2 * ha);
                    const double ab = (bp.d_alpha - bm.d_alpha) / (2 * hb);
                    const double ba = (ap.d_beta - am.d_beta) / (2 * ha);
                    const double bb = (bp.d_beta - bm.d_beta) / (2 * hb);
                    const double c = g.value;
                    EXPECT_NEAR(h.d_alpha_alpha, aa, 1e-6 * (c / (a * a) + std::abs(aa))) << where;
                    EXPECT_NEAR(h.d_alpha_beta, ab, 1e-6 * (c / (a * b) + std::abs(ab))) << where;
                    EXPECT_NEAR(h.d_alpha_beta, ba, 1e-6 * (c / (a * b) + std::abs(ba))) << where;
                    EXPECT_NEAR(h.d_beta_beta, bb, 1e-6 * (c / (b * b) + std::abs(bb))) << where;
                    ++checked;
                }
            }
        }
    }
    EXPECT_EQ(checked, 5 * 3 * 2 * 3);
}

TEST(EstimatorEnergyCostHessian, MatchesLongDouble) {
    // The same equations in long double (eps 1.1e-19 on x86-64): the double Hessian's error is its rounding,
    // ~eps / (1 - rho)^2 relative for the Stein solutions, <= 1e-12 at rho <= 0.99, times the terms' cancellation
    // (C_ab / (C / (a b)) ~ 1e-2 at worst here). Tolerance 1e-9 C / (x y): 10x above (measured: 1.8e-12 C / (x y),
    // and 6.3e-12 between the two routes below). Also the complex Schur
    // route (dense = true) against the structured one, both in double, to the same tolerance.
    using LD = long double;
    for (const VelocityEstimator& e : estimators()) {
        for (double d : {0.0, 1.0, 6.0}) {
            const NormalizedPlant np{0.001, 0.02, d};
            const SampledPlant<double> plant(np);
            const SampledPlant<LD> fine(np);
            for (const Point& pt : points(np, e)) {
                const double a = pt.alpha, b = pt.beta;
                for (int p = 0; p < 3; ++p) {
                    const std::string where = describe(e, d, p, a, b);
                    const EnergyCostHessian h = estimator_energy_cost_hessian(plant, e, a, b, p);
                    const EnergyCostHessianT<LD> r = estimator_energy_cost_hessian<LD>(fine, e, a, b, p);
                    const EnergyCostHessian s = estimator_energy_cost_hessian(plant, e, a, b, p, true);
                    const double c = h.value;
                    ASSERT_TRUE(std::isfinite(c)) << where;
                    EXPECT_NEAR(h.d_alpha_alpha, static_cast<double>(r.d_alpha_alpha), 1e-9 * c / (a * a)) << where;
                    EXPECT_NEAR(h.d_alpha_beta, static_cast<double>(r.d_alpha_beta), 1e-9 * c / (a * b)) << where;
                    EXPECT_NEAR(h.d_beta_beta, static_cast<double>(r.d_beta_beta), 1e-9 * c / (b * b)) << where;
                    EXPECT_NEAR(s.d_alpha_alpha, h.d_alpha_alpha, 1e-9 * c / (a * a)) << where;
                    EXPECT_NEAR(s.d_alpha_beta, h.d_alpha_beta, 1e-9 * c / (a * b)) << where;
                    EXPECT_NEAR(s.d_beta_beta, h.d_beta_beta, 1e-9 * c / (b * b)) << where;
                }
            }
        }
    }
}

TEST(EstimatorEnergyCostHessian, UnstableAndInvalid) {
    const SampledPlant<double> plant(NormalizedPlant{0.001, 0.02, 6.0});
    const VelocityEstimator e = VelocityEstimator::moving_window(15);
    const EnergyCostHessian h = estimator_energy_cost_hessian(plant, e, 0.5, 0.1, 2);  // far beyond alpha_max
    EXPECT_TRUE(std::isinf(h.value));
    EXPECT_TRUE(std::isnan(h.d_alpha_alpha));
    EXPECT_TRUE(std::isnan(h.d_beta_beta));
    EXPECT_THROW(estimator_energy_cost_hessian(plant, e, 0.003, 0.09, 3), InvalidParameter);
}

TEST(NewtonSearch, HessianCallbackConvergesQuadratically) {
    // Rosenbrock's function f = (1 - x)^2 + 100 (y - x^2)^2 from (-1.2, 1): minimum (1, 1). With its exact
    // Hessian the damped Newton reaches the minimum to the step tolerance's resolution with fewer calls than with
    // the forward-difference Hessian (which needs two more gradients per fresh Hessian).
    auto f = [](double x, double y) { return (1 - x) * (1 - x) + 100 * (y - x * x) * (y - x * x); };
    auto fg = [&](double x, double y) {
        return detail::ValueAndGradient2{f(x, y), -2 * (1 - x) - 400 * x * (y - x * x), 200 * (y - x * x)};
    };
    auto fgh = [&](double x, double y) {
        const auto g = fg(x, y);
        return detail::ValueGradientHessian2{g.value, g.dx, g.dy, 2 - 400 * (y - 3 * x * x), -400 * x, 200};
    };
    static_assert(detail::has_hessian2<detail::ValueGradientHessian2>::value, "callback with a Hessian");
    static_assert(!detail::has_hessian2<detail::ValueAndGradient2>::value, "callback without one");
    const detail::NewtonMinimum2 exact = detail::minimize_newton_2d(fgh, -1.2, 1.0, 1.0, 1.0);
    const detail::NewtonMinimum2 differences = detail::minimize_newton_2d(fg, -1.2, 1.0, 1.0, 1.0);
    // At the minimum f ~ |dx|^2: a point 1e-7 off has f ~ 1e-12 relative to the start's 24; the step tolerance
    // (1e-12) and the rounding stop (kUnresolvedStep = 1e-8) leave the point within 1e-7.
    EXPECT_NEAR(exact.x, 1.0, 1e-7);
    EXPECT_NEAR(exact.y, 1.0, 1e-7);
    EXPECT_NEAR(differences.x, 1.0, 1e-7);
    EXPECT_NEAR(differences.y, 1.0, 1e-7);
    EXPECT_LT(exact.evaluations, differences.evaluations);
}

TEST(NewtonSearch, TakesTheLastStepUnevaluatedWhereTheContractionPredictsTheTolerance) {
    // f = exp(x - 1) - x + (1 + x^2) (y - 2)^2 + 3 from (0.3, 2.5): minimum (1, 2), value 4, Hessian diag(1, 4)
    // there. With the exact Hessian the search ends on a step it does not evaluate (newton_search.hpp): the point
    // returned is none the callback saw, yet within the step tolerance (1e-12, the error the observed contraction
    // predicts; a margin of 10 for the estimate) of the minimum, and the value returned (the quadratic model's) is
    // f there to rounding (4 eps |f|).
    auto f = [](double x, double y) { return std::exp(x - 1) - x + (1 + x * x) * (y - 2) * (y - 2) + 3; };
    std::vector<std::pair<double, double>> seen;
    auto fgh = [&](double x, double y) {
        seen.emplace_back(x, y);
        const double e = std::exp(x - 1), dy = y - 2;
        return detail::ValueGradientHessian2{f(x, y),    e - 1 + 2 * x * dy * dy, 2 * (1 + x * x) * dy, e + 2 * dy * dy,
                                             4 * x * dy, 2 * (1 + x * x)};
    };
    const detail::NewtonMinimum2 m = detail::minimize_newton_2d(fgh, 0.3, 2.5, 1.0, 1.0);
    EXPECT_NEAR(m.x, 1.0, 1e-11);
    EXPECT_NEAR(m.y, 2.0, 1e-11);
    EXPECT_NEAR(m.value, f(m.x, m.y), 4 * std::numeric_limits<double>::epsilon() * std::abs(f(m.x, m.y)));
    EXPECT_EQ(static_cast<int>(seen.size()), m.evaluations);
    for (const auto& [x, y] : seen) EXPECT_FALSE(x == m.x && y == m.y) << x << " " << y;
}

}  // namespace estimator_hessian_test
}  // namespace hapticopt
