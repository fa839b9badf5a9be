// SPDX-License-Identifier: Apache-2.0
// The fast CEx optimum with a velocity estimator (estimator_gradient.hpp: estimator_energy_cost_gradient, the
// adjoint Stein equation, and OptimumMethod::newton in optimal_point, estimator_optimum.hpp), checked two ways:
// (1) the gradient against central differences of estimator_energy_costs in long double (only the forward cost
//     is used there) and its Schur-form route against its shift-structured route;
// (2) the fast optimum against the derivative-free nested Brent search (OptimumMethod::brent, region_minimum.hpp)
//     for the backward difference, low-pass filters and windows at d = 0, 1, 2.5, 6, and with the plant's own
//     stiffness (gamma > 0), where the minimum can lie on the main region's edge alpha -> 0+.
#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <cmath>
#include <random>
#include <string>
#include <vector>

#include <hapticopt/hapticopt.hpp>

namespace hapticopt {
namespace estimator_fast_optimum_test {

std::string describe(const VelocityEstimator& e, double d) {
    return "kind=" + std::to_string(static_cast<int>(e.kind)) + " nu=" + std::to_string(e.cutoff) +
           " N=" + std::to_string(e.window) + " d=" + std::to_string(d);
}

TEST(EstimatorEnergyCostGradient, MatchesCentralDifferencesInLongDouble) {
    // Central differences of the long double cost with step h = 1e-5 x (x = alpha or beta), as in
    // tests/core/test_energy_gradient.cpp: truncation (h^2 / 6) |C'''| ~ 2e-11 C / x for costs that vary on the
    // scale of x, rounding eps_ld C_rel / h <= 1e-10 C / x (the cost's relative error in long double is below
    // 1e-15 at these radii, rho <= 0.999). Tolerance 1e-8 C / x, 100x above their sum.
    using LD = long double;
    const std::vector<VelocityEstimator> estimators = {
        VelocityEstimator::low_pass(0.02), VelocityEstimator::low_pass(0.2), VelocityEstimator::moving_window(5),
        VelocityEstimator::moving_window(15)};
    for (const VelocityEstimator& e : estimators) {
        for (double d : {0.0, 1.0, 2.5, 6.0}) {
            const NormalizedPlant np{0.001, 0.02, d};
            const SampledPlant<double> plant(np);
            const SampledPlant<LD> fine(np);
            // Inside every main region of these estimators (each region contains (0.0013, 0.05) at d <= 6 and
            // (0.003, 0.09) at d <= 2.5; the ASSERT below checks that the cost is finite).
            const double a = d >= 6 ? 0.0013 : 0.003, b = d >= 6 ? 0.05 : 0.09;
            for (int p = 0; p < 3; ++p) {
                const std::string where = describe(e, d) + " p=" + std::to_string(p);
                const EnergyCostGradient g = estimator_energy_cost_gradient(plant, e, a, b, p);
                const EnergyCosts c = estimator_energy_costs(plant, e, a, b);
                const double cost = p == 0 ? c.ce0 : p == 1 ? c.ce1 : c.ce2;
                ASSERT_TRUE(std::isfinite(cost)) << where;
                // The value is the cost by the same Stein solves: rounding only.
                EXPECT_NEAR(g.value / cost, 1.0, 1e-12) << where;
                auto fc = [&](LD x, LD y) {
                    const EnergyCostsT<LD> r = estimator_energy_costs(fine, e, x, y);
                    return p == 0 ? r.ce0 : p == 1 ? r.ce1 : r.ce2;
                };
                const LD ha = LD(1e-5) * a, hb = LD(1e-5) * b;
                const LD fd_alpha = (fc(a + ha, b) - fc(a - ha, b)) / (2 * ha);
                const LD fd_beta = (fc(a, b + hb) - fc(a, b - hb)) / (2 * hb);
                EXPECT_NEAR(g.d_alpha, static_cast<double>(fd_alpha), 1e-8 * cost / a) << where;
                EXPECT_NEAR(g.d_beta, static_cast<double>(fd_beta), 1e-8 * cost / b) << where;
                // The two routes (shift-structured: ShiftSteinSolver for the window, RowShiftSteinSolver for the
                // low-pass; and complex Schur) differ by rounding only: the Stein solutions' relative error is
                // ~1e-13 / (1 - rho)^2 (energy_costs.hpp), below 1e-10 here.
                const EnergyCostGradient dense = estimator_energy_cost_gradient(plant, e, a, b, p, true);
                EXPECT_NEAR(dense.d_alpha, g.d_alpha, 1e-10 * cost / a) << where;
                EXPECT_NEAR(dense.d_beta, g.d_beta, 1e-10 * cost / b) << where;
            }
        }
    }
}

TEST(RowShiftSteinSolver, MatchesTheKroneckerSolve) {
    // Independent method: vec(X) = (I - M (x) M)^-1 vec(C) and vec(L) = (I - M^T (x) M^T)^-1 vec(H) by a full-pivot
    // LU of the N^2-square Kronecker system. Loop matrices with dense rows {0, 1, 5} (the low-pass loop's pattern:
    // x, x' and v_j) and shift rows 2 <- 0, 3 <- 2, 4 <- 3, 6 <- 5, 7 <- 6, random dense rows drawn until the
    // spectral radius is at most 0.95. Both methods are backward stable with errors ~ eps cond, cond of the Stein
    // operator <= 1 / (1 - rho^2) ~ 10 here, times the Kronecker LU's growth: 1e-11 relative is 100x above.
    const int n = 8;
    const std::vector<int> dense = {0, 1, 5};
    const std::vector<int> source = {-1, -1, 0, 2, 3, -1, 5, 6};
    std::mt19937 rng(39);
    std::uniform_real_distribution<double> uniform(-0.6, 0.6);
    int checked = 0;
    for (int attempt = 0; attempt < 1000 && checked < 5; ++attempt) {
        Eigen::MatrixXd m = Eigen::MatrixXd::Zero(n, n);
        for (int k = 0; k < n; ++k) {
            if (source[static_cast<std::size_t>(k)] >= 0) {
                m(k, source[static_cast<std::size_t>(k)]) = 1;
            } else {
                for (int l = 0; l < n; ++l) m(k, l) = uniform(rng);
            }
        }
        const double rho = Eigen::EigenSolver<Eigen::MatrixXd>(m).eigenvalues().cwiseAbs().maxCoeff();
        if (!(rho <= 0.95)) continue;
        ++checked;
        const RowShiftSteinSolver<double> stein(m);
        ASSERT_TRUE(stein.ok());
        EXPECT_EQ(stein.dense_rows(), 3);
        EXPECT_EQ(stein.unknowns(), 3 * n - 3);
        Eigen::MatrixXd a = Eigen::MatrixXd::NullaryExpr(n, n, [&] { return uniform(rng); });
        const Eigen::MatrixXd c = a * a.transpose();
        a = Eigen::MatrixXd::NullaryExpr(n, n, [&] { return uniform(rng); });
        const Eigen::MatrixXd h = a + a.transpose();
        const Eigen::MatrixXd identity = Eigen::MatrixXd::Identity(n * n, n * n);
        Eigen::MatrixXd kron(n * n, n * n), kron_t(n * n, n * n);
        for (int i = 0; i < n; ++i) {
            for (int j = 0; j < n; ++j) {
                kron.block(i * n, j * n, n, n) = m(i, j) * m;
                kron_t.block(i * n, j * n, n, n) = m(j, i) * m.transpose();
            }
        }
        const Eigen::VectorXd x_ref =
            (identity - kron).fullPivLu().solve(Eigen::Map<const Eigen::VectorXd>(c.data(), n * n));
        const Eigen::VectorXd l_ref =
            (identity - kron_t).fullPivLu().solve(Eigen::Map<const Eigen::VectorXd>(h.data(), n * n));
        const Eigen::MatrixXd x = stein.solve(c);
        const Eigen::MatrixXd l = stein.adjoint_solve(h);
        EXPECT_LE((x - Eigen::Map<const Eigen::MatrixXd>(x_ref.data(), n, n)).norm(), 1e-11 * x.norm());
        EXPECT_LE((l - Eigen::Map<const Eigen::MatrixXd>(l_ref.data(), n, n)).norm(), 1e-11 * l.norm());
        // The residuals of the equations themselves, and the structured products against dense ones.
        EXPECT_LE((x - m * x * m.transpose() - c).norm(), 1e-11 * x.norm());
        EXPECT_LE((l - m.transpose() * l * m - h).norm(), 1e-11 * l.norm());
        EXPECT_LE((stein.propagate(c) - m * c * m.transpose()).norm(), 1e-13 * c.norm());
        EXPECT_LE((stein.transpose_congruence(h) - m.transpose() * h * m).norm(), 1e-13 * h.norm() * m.squaredNorm());
    }
    EXPECT_EQ(checked, 5);
    // A unit row whose one entry points at or above itself is not a shift row: treated as dense.
    Eigen::MatrixXd up = Eigen::MatrixXd::Zero(3, 3);
    up(0, 1) = 1;
    up(1, 0) = 0.5;
    up(2, 1) = 1;
    EXPECT_EQ(RowShiftSteinSolver<double>(up).dense_rows(), 2);
}

TEST(EstimatorEnergyCosts, LowPassStructuredRouteMatchesComplexSchur) {
    // RowShiftSteinSolver (three dense rows) against the complex Schur form of the dense loop matrix, over the
    // low-pass cutoffs and delays of the optimum tests at points inside their main regions: rounding only, the
    // Stein solutions' relative error ~1e-13 / (1 - rho)^2 (energy_costs.hpp), below 1e-10 here.
    for (double nu : {0.005, 0.02, 0.2}) {
        for (double d : {0.0, 1.0, 2.5, 6.0}) {
            const NormalizedPlant np{0.001, 0.02, d};
            const SampledPlant<double> plant(np);
            const VelocityEstimator e = VelocityEstimator::low_pass(nu);
            const EstimatorStabilityRegion region(np, e);
            for (double f : {0.2, 0.5, 0.8}) {
                const double a = f * region.alpha_max();
                const auto [lo, hi] = region.beta_interval(a);
                ASSERT_LT(lo, hi) << describe(e, d);
                for (double g : {0.25, 0.5, 0.75}) {
                    const double b = lo + g * (hi - lo);
                    const EnergyCosts fast = estimator_energy_costs(plant, e, a, b);
                    const EnergyCosts dense = estimator_energy_costs(plant, e, a, b, true);
                    ASSERT_TRUE(std::isfinite(dense.ce2)) << describe(e, d);
                    EXPECT_NEAR(fast.ce0 / dense.ce0, 1.0, 1e-10) << describe(e, d) << " " << a << " " << b;
                    EXPECT_NEAR(fast.ce1 / dense.ce1, 1.0, 1e-10) << describe(e, d) << " " << a << " " << b;
                    EXPECT_NEAR(fast.ce2 / dense.ce2, 1.0, 1e-10) << describe(e, d) << " " << a << " " << b;
                }
            }
        }
    }
}

TEST(EstimatorEnergyCostGradient, UnstableAndInvalid) {
    const SampledPlant<double> plant(NormalizedPlant{0, 0, 1});
    const VelocityEstimator e = VelocityEstimator::low_pass(0.02);
    const EnergyCostGradient g = estimator_energy_cost_gradient(plant, e, 0.5, 0.1, 2);  // far beyond alpha_max
    EXPECT_TRUE(std::isinf(g.value));
    EXPECT_TRUE(std::isnan(g.d_alpha));
    try {
        estimator_energy_cost_gradient(plant, e, 0.003, 0.09, 3);
        ADD_FAILURE() << "no exception";
    } catch (const InvalidParameter& x) {
        EXPECT_EQ(std::string(x.what()).rfind("hapticopt::estimator_energy_cost_gradient", 0), 0u) << x.what();
        EXPECT_NE(std::string(x.what()).find("index"), std::string::npos) << x.what();
    }
}

TEST(EstimatorFastOptimum, AgreesWithBrent) {
    // Tolerances: the fast method stops where the analytic gradient vanishes to rounding (its point is good to
    // ~1e-8 relative on these minima); Brent's nested search resolves the point only to ~sqrt(eps) ~ 1e-8 of the
    // cost's curvature scale, i.e. ~1e-7 relative in alpha and beta on these flat minima (measured <= 2e-7).
    // Point: 1e-5 relative. Cost: second order in the point's error, 1e-10 relative; and the fast cost is never
    // above the slow one beyond rounding (1e-12 relative). Where the slow method's default grids (24 x 16) do not
    // resolve the global minimum's basin (region_minimum.hpp's stated limit: a minimum close to the interval's
    // lower end, as for the low-pass nu = 0.005 at d = 1), the fast cost is lower; then the slow method with finer
    // grids (72 x 64) must reach the fast point.
    const std::vector<VelocityEstimator> estimators = {
        VelocityEstimator::backward_difference(), VelocityEstimator::low_pass(0.005),
        VelocityEstimator::low_pass(0.02),        VelocityEstimator::low_pass(0.2),
        VelocityEstimator::moving_window(2),      VelocityEstimator::moving_window(5),
        VelocityEstimator::moving_window(15)};
    int refined = 0;
    for (const VelocityEstimator& e : estimators) {
        for (double d : {0.0, 1.0, 2.5, 6.0}) {
            for (Criterion c : {Criterion::CE0, Criterion::CE2}) {
                const NormalizedPlant plant{0, 0, d};
                const std::string where = describe(e, d) + " " + std::string(to_string(c));
                EstimatorOptimumOptions fast_options, slow_options;
                slow_options.method = OptimumMethod::brent;
                const EstimatorOptimum fast = optimal_point(c, plant, e, fast_options);
                EstimatorOptimum slow = optimal_point(c, plant, e, slow_options);
                ASSERT_TRUE(fast.cost && slow.cost) << where;
                ASSERT_TRUE(std::isfinite(*fast.cost)) << where;
                EXPECT_LE(*fast.cost, *slow.cost * (1 + 1e-12)) << where;
                if (*fast.cost < *slow.cost * (1 - 1e-10)) {
                    ++refined;
                    slow_options.search = {72, 64};
                    slow = optimal_point(c, plant, e, slow_options);
                }
                EXPECT_NEAR(fast.alpha / slow.alpha, 1.0, 1e-5) << where;
                EXPECT_NEAR(fast.beta / slow.beta, 1.0, 1e-5) << where;
                EXPECT_NEAR(*fast.cost / *slow.cost, 1.0, 1e-10) << where;
                // The region's tip by the fast method's 16 x 16 scan and the default 160 x 160 one: the same curve
                // maximum (or, at a corner, the same edge bisected to ~1e-14), whatever the grid.
                EXPECT_NEAR(fast.alpha_max / slow.alpha_max, 1.0, 1e-10) << where;
                EXPECT_NEAR(fast.beta_at_alpha_max, slow.beta_at_alpha_max, 1e-5) << where;
            }
        }
    }
    // The one known case of a basin the slow default grids miss (measured: nu = 0.005, d = 1, C_E2); more would
    // mean the fast and slow methods drifted apart and is worth a look.
    EXPECT_LE(refined, 1);
}

TEST(EstimatorFastOptimum, StartGridReachesTheGlobalBasinOfASlowWindow) {
    // Window 30, d = 0, delta = 0.05: CE2 has a local minimum at alpha 0.030, beta -0.115 (cost 13850) besides the
    // global one at alpha 0.0044, beta 0.040 (cost 6228, brent's), 0.026 of alpha_max (measured by
    // scripts/estimator-optimum-sweep.sh; the region narrows to a waist at alpha 0.105 and ends at 0.169). The start
    // grid's alphas, spaced towards alpha -> 0+ (kStartAlphaFractions), must start Newton in the global basin: the
    // point and cost of AgreesWithBrent's tolerances.
    const NormalizedPlant plant{0, 0.05, 0};
    const VelocityEstimator e = VelocityEstimator::moving_window(30);
    EstimatorOptimumOptions slow_options;
    slow_options.method = OptimumMethod::brent;
    const EstimatorOptimum fast = optimal_point(Criterion::CE2, plant, e);
    const EstimatorOptimum slow = optimal_point(Criterion::CE2, plant, e, slow_options);
    ASSERT_TRUE(fast.cost && slow.cost);
    EXPECT_NEAR(*fast.cost / *slow.cost, 1.0, 1e-10);
    EXPECT_NEAR(fast.alpha / slow.alpha, 1.0, 1e-5);
    EXPECT_NEAR(fast.beta / slow.beta, 1.0, 1e-5);
}

TEST(EstimatorFastOptimum, CompetingStartRowsReachTheGlobalBasinOfASlowerWindow) {
    // Window 60, delta = 0.05: CE2 has local minima besides brent's global one in narrow beta valleys near
    // alpha -> 0+ (measured by scripts/estimator-optimum-sweep.sh and a 24-point beta scan of each start row):
    //  - d = 0: the best start point (0.15 alpha_max, cost 2.06e4) lies in the basin of a local minimum at 0.144
    //    alpha_max (cost 18230); the global one (15743) lies at 0.022 alpha_max, where the 0.025 row's valley (its
    //    minimum 1.61e4 at 0.35 of the beta interval) falls between the row's three points (2.3e5, 4.6e4, 1.5e6);
    //  - d = 1: the 0.15 row's minimum over beta (2.9e4) is lower than the best start point's (0.06 row, 4.0e4),
    //    but leads to a local minimum (28580); the 0.06 row's own minimum (1.8e4) leads to the global one (17781).
    // The competing rows' minima over beta (kRowRefineRatio, kRowValleySteepness) must start Newton in the global
    // basin: the point and cost of AgreesWithBrent's tolerances.
    const VelocityEstimator e = VelocityEstimator::moving_window(60);
    EstimatorOptimumOptions slow_options;
    slow_options.method = OptimumMethod::brent;
    for (const double d : {0.0, 1.0}) {
        const NormalizedPlant plant{0, 0.05, d};
        const EstimatorOptimum fast = optimal_point(Criterion::CE2, plant, e);
        const EstimatorOptimum slow = optimal_point(Criterion::CE2, plant, e, slow_options);
        ASSERT_TRUE(fast.cost && slow.cost) << "d=" << d;
        EXPECT_NEAR(*fast.cost / *slow.cost, 1.0, 1e-10) << "d=" << d;
        EXPECT_NEAR(fast.alpha / slow.alpha, 1.0, 1e-5) << "d=" << d;
        EXPECT_NEAR(fast.beta / slow.beta, 1.0, 1e-5) << "d=" << d;
    }
}

TEST(EstimatorFastOptimum, EdgeMinimaOfAStiffPlantAgreeWithBrent) {
    // gamma = 0.01 (the plant's own stiffness): the CE2 minimum of these cases lies on the main region's edge
    // alpha -> 0+ (measured: both methods end below 1e-9 alpha_max), and for the slow low-pass at d = 2.5 the main
    // region lies at beta < 0 (negative damping), below the box the 16 x 16 fitting shrinks towards. The fast
    // method's point must be brent's: the two points differ in alpha by their alpha tolerances near the edge, which
    // moves the cost by |dC/dalpha| |delta alpha| to first order (the analytic gradient, doubled for the second
    // order), plus the 1e-10 relative agreement of AgreesWithBrent for the beta minimum.
    struct Case {
        VelocityEstimator estimator;
        double d;
    };
    const std::vector<Case> cases = {{VelocityEstimator::low_pass(0.02), 1},
                                     {VelocityEstimator::low_pass(0.1), 6},
                                     {VelocityEstimator::moving_window(15), 1},
                                     {VelocityEstimator::moving_window(4), 6},
                                     {VelocityEstimator::low_pass(0.002), 2.5}};
    for (const Case& c : cases) {
        const NormalizedPlant plant{0.01, 0, c.d};
        const std::string where = describe(c.estimator, c.d);
        const EstimatorStabilityRegion coarse(plant, c.estimator, kFastOptimumRegionGrid);
        const EstimatorStabilityRegion fine(plant, c.estimator);
        ASSERT_GT(fine.alpha_max(), 0) << where;
        EXPECT_NEAR(coarse.alpha_max() / fine.alpha_max(), 1.0, 1e-10) << where;
        EstimatorOptimumOptions slow_options;
        slow_options.method = OptimumMethod::brent;
        const EstimatorOptimum fast = optimal_point(Criterion::CE2, plant, c.estimator);
        const EstimatorOptimum slow = optimal_point(Criterion::CE2, plant, c.estimator, slow_options);
        ASSERT_TRUE(fast.cost && slow.cost) << where;
        ASSERT_TRUE(std::isfinite(*fast.cost) && std::isfinite(*slow.cost)) << where;
        const EnergyCostGradient g =
            estimator_energy_cost_gradient(SampledPlant<double>(plant), c.estimator, fast.alpha, fast.beta, 2);
        const double tolerance = 2 * std::abs(g.d_alpha) * std::abs(fast.alpha - slow.alpha) + 1e-10 * *slow.cost;
        EXPECT_NEAR(*fast.cost, *slow.cost, tolerance) << where;
        EXPECT_NEAR(fast.beta / slow.beta, 1.0, 1e-5) << where;
    }
}

}  // namespace estimator_fast_optimum_test
}  // namespace hapticopt
