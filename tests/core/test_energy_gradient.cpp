// SPDX-License-Identifier: Apache-2.0
// The analytic gradient of C_E0..2 (energy_gradient.hpp, adjoint Stein equation), checked two ways:
// (1) central differences of the cost in long double (an independent route: only the forward cost is used),
// (2) the adjoint's residual for a general right-hand side against the dense loop matrix.
#include <gtest/gtest.h>

#include <cmath>

#include <hapticopt/energy_gradient.hpp>
#include <hapticopt/stability_region.hpp>

namespace hapticopt {
namespace gradient_test {

struct GradientCase {
    NormalizedPlant plant;
    NormalizedGains gains;
};

// Points at and away from the optima (gradient ~0 and large), whole and fractional delays (one and two
// segments per period), with and without the plant's own stiffness and damping.
const GradientCase kCases[] = {
    {{0, 0, 0}, {0.2474, 0.7445}},        {{0, 0, 0}, {0.1, 0.5}},
    {{0.001, 0.02, 1}, {0.0582, 0.3796}}, {{0, 0, 1}, {0.03, 0.5}},
    {{0.0005, 0.01, 1.5}, {0.03, 0.25}},  {{0, 0, 6}, {0.006, 0.09}},
    {{0.001, 0.02, 2.5}, {0.02, 0.3}},
};

TEST(EnergyCostGradient, MatchesCentralDifferencesInLongDouble) {
    // Central differences of the long double cost with step h = 1e-5 x (x = alpha or beta): truncation
    // (h^2 / 6) |C'''| ~ 2e-11 C / x for costs that vary on the scale of x (they do: C_E ~ 1 / alpha^(p+1) near
    // the boundary, and the region's width in beta is ~x), rounding eps_ld C_rel / h with the cost's relative
    // error <= 1e-15 in long double at these radii (tests/core/test_energy_costs.cpp: ~1e-13 in double, 2^11
    // smaller in long double), i.e. <= 1e-10 C / x. Tolerance: 1e-8 C / x, 100x above their sum. The double
    // gradient's own rounding (1e-13 / (1 - rho)^2 relative, rho <= 0.99 here) is below that too.
    using LD = long double;
    for (const GradientCase& c : kCases) {
        const SampledPlant<double> plant(c.plant);
        const SampledPlant<LD> fine(c.plant);
        for (int p = 0; p < 3; ++p) {
            const EnergyCostGradient g = energy_cost_gradient(plant, c.gains.alpha, c.gains.beta, p);
            const double cost = energy_cost(plant, c.gains.alpha, c.gains.beta, p);
            ASSERT_TRUE(std::isfinite(g.value));
            EXPECT_NEAR(g.value / cost, 1.0, 1e-12) << "p=" << p << " d=" << c.plant.delay;
            const LD a = c.gains.alpha, b = c.gains.beta;
            const LD ha = LD(1e-5) * a, hb = LD(1e-5) * b;
            const LD fd_alpha = (energy_cost(fine, a + ha, b, p) - energy_cost(fine, a - ha, b, p)) / (2 * ha);
            const LD fd_beta = (energy_cost(fine, a, b + hb, p) - energy_cost(fine, a, b - hb, p)) / (2 * hb);
            const std::string where = "p=" + std::to_string(p) + " d=" + std::to_string(c.plant.delay) +
                                      " alpha=" + std::to_string(c.gains.alpha) +
                                      " beta=" + std::to_string(c.gains.beta);
            EXPECT_NEAR(g.d_alpha, static_cast<double>(fd_alpha), 1e-8 * cost / c.gains.alpha) << where;
            EXPECT_NEAR(g.d_beta, static_cast<double>(fd_beta), 1e-8 * cost / c.gains.beta) << where;
            // The same algorithm in long double: the double gradient's rounding.
            const EnergyCostGradientT<LD> gl = energy_cost_gradient(fine, a, b, p);
            EXPECT_NEAR(g.d_alpha, static_cast<double>(gl.d_alpha), 1e-10 * cost / c.gains.alpha) << where;
            EXPECT_NEAR(g.d_beta, static_cast<double>(gl.d_beta), 1e-10 * cost / c.gains.beta) << where;
        }
    }
}

TEST(EnergyCostGradient, AwayFromTheOptimumTheGradientIsLarge) {
    // Guards the check above against comparing two near-zero numbers: at (0.1, 0.5), d = 0, C_E2 falls with
    // alpha (the optimum is at alpha = 0.2474) and the gradient is of the order of C / alpha.
    const SampledPlant<double> plant(NormalizedPlant{0, 0, 0});
    const EnergyCostGradient g = energy_cost_gradient(plant, 0.1, 0.5, 2);
    EXPECT_LT(g.d_alpha, -0.1 * g.value / 0.1);
}

TEST(EnergyCostGradient, UnstableGainsGiveInfiniteValueAndNaNDerivatives) {
    const SampledPlant<double> plant(NormalizedPlant{0, 0, 1});
    const EnergyCostGradient g = energy_cost_gradient(plant, 0.5, 0.3, 2);  // alpha_max(d = 1) ~ 0.1
    EXPECT_TRUE(std::isinf(g.value));
    EXPECT_TRUE(std::isnan(g.d_alpha));
    EXPECT_TRUE(std::isnan(g.d_beta));
    EXPECT_THROW(energy_cost_gradient(plant, 0.05, 0.3, 3), InvalidParameter);
}

TEST(EnergyCostGradient, AdjointSteinSolveHasASmallResidual) {
    // L = M^T L M + H for a general symmetric H (the gradient's adjoint), against the dense M, and the duality
    // <H, X(C)> = <L, C> that makes it the adjoint. Residual bound: eps times the Stein operator's condition
    // ~ 1 / (1 - rho^2), as for ShiftSteinSolver::solve (tests/core/test_energy_costs.cpp).
    for (const NormalizedPlant p :
         {NormalizedPlant{0, 0, 0}, NormalizedPlant{0.001, 0.02, 1.5}, NormalizedPlant{0, 0, 6}}) {
        const StabilityRegion region(p);
        const double a = 0.5 * region.alpha_max();
        const auto [lo, hi] = region.beta_range(a);
        const SampledPlant<double> sampled(p);
        const ClosedLoop<double> loop = make_closed_loop(sampled, a, (lo + hi) / 2);
        const DynamicMatrix<double>& m = loop.transition;
        const ShiftSteinSolver<double> solver(m.topRows(2));
        ASSERT_TRUE(solver.ok());
        const Eigen::Index n = m.rows();
        DynamicMatrix<double> h(n, n), c(n, n);
        for (Eigen::Index i = 0; i < n; ++i) {
            for (Eigen::Index j = 0; j < n; ++j) {
                h(i, j) = 1.0 / (1.0 + static_cast<double>(i + j));  // Hilbert-like, symmetric
                c(i, j) = std::cos(static_cast<double>(i * j));      // symmetric
            }
        }
        const DynamicMatrix<double> l = solver.adjoint_solve(h);
        const double rho = loop_schur_form(m).spectral_radius;
        EXPECT_LE((m.transpose() * l * m + h - l).norm(), 1e-13 * l.norm() / (1 - rho * rho)) << "d=" << p.delay;
        const DynamicMatrix<double> x = solver.solve(c);
        const double lhs = h.cwiseProduct(x).sum(), rhs = l.cwiseProduct(c).sum();
        EXPECT_NEAR(lhs / rhs, 1.0, 1e-12 / (1 - rho * rho)) << "d=" << p.delay;
    }
}

}  // namespace gradient_test
}  // namespace hapticopt
