// SPDX-License-Identifier: Apache-2.0
// C_E0..2 in closed form, checked against (1) values from the paper's model (Hulin et al. 2011), (2) the independent
// time-stepping method converging as its step shrinks, (3) the same algorithm in long double
// (rounding error), and for continuity in a fractional delay.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include <hapticopt/energy_costs.hpp>
#include <hapticopt/stability_region.hpp>

#include "reference_simulation.hpp"

namespace hapticopt {
namespace {

double ce(const EnergyCosts& c, int p) { return p == 0 ? c.ce0 : p == 1 ? c.ce1 : c.ce2; }

TEST(EnergyCosts, ReproduceValuesVerifiedInTheModelNotes) {
    // The paper's values (docs/accuracy.md): C_E0(0.3220, 0.9800; d=0) = 2.58260..., C_E2(0.0582, 0.3796; d=1)
    // = 87.432...
    EXPECT_NEAR(energy_costs(NormalizedPlant{0, 0, 0}, {0.3220, 0.9800}).ce0, 2.58260, 1e-5);
    EXPECT_NEAR(energy_costs(NormalizedPlant{0, 0, 1}, {0.0582, 0.3796}).ce2, 87.432, 1e-3);
}

struct Case {
    NormalizedPlant plant;
    NormalizedGains gains;
};

TEST(EnergyCosts, TimeSteppingWithQuadratureConvergesToTheClosedForm) {
    // Simpson's rule has error O(h^4): each halving of the sub-step must cut the error ~16x (we
    // require >= 8x while above the rounding floor), and the finest must agree to 1e-9 relative.
    const Case cases[] = {
        {{0, 0, 0}, {0.3220, 0.9800}}, {{0.001, 0.02, 1}, {0.0618, 0.3778}}, {{0.0005, 0.01, 2.5}, {0.03, 0.25}}};
    for (const Case& c : cases) {
        const EnergyCosts exact = energy_costs(c.plant, c.gains);
        for (int p = 0; p < 3; ++p) {
            double previous_error = HUGE_VAL;
            for (int substeps : {8, 16, 32, 64}) {
                const auto sim = testing::simulate_step(c.plant.gamma, c.plant.delta, c.plant.delay, c.gains.alpha,
                                                        c.gains.beta, substeps, 1500);
                const double error = std::abs(sim.ce[static_cast<std::size_t>(p)] / ce(exact, p) - 1);
                if (previous_error > 1e-11) {
                    EXPECT_LT(error, previous_error / 8)
                        << "p=" << p << " substeps=" << substeps << " d=" << c.plant.delay;
                }
                previous_error = error;
            }
            EXPECT_LT(previous_error, 1e-9) << "p=" << p << " d=" << c.plant.delay;
        }
    }
}

/// Random stable points of the region for plant p, with their spectral radius.
std::vector<std::pair<NormalizedGains, double>> random_stable_points(const NormalizedPlant& p, int count, double shrink,
                                                                     unsigned seed) {
    const StabilityRegion region(p);
    std::mt19937 rng(seed);
    std::uniform_real_distribution<double> u(0, 1);
    std::vector<std::pair<NormalizedGains, double>> out;
    const SampledPlant<double> sampled(p);
    while (static_cast<int>(out.size()) < count) {
        const double a = region.alpha_min() + (region.alpha_max() - region.alpha_min()) * (1e-3 + (1 - 2e-3) * u(rng));
        const auto [lo, hi] = region.beta_range(a);
        const double mid = (lo + hi) / 2, half = (hi - lo) / 2 * shrink;
        const double b = mid + half * (2 * u(rng) - 1);
        const auto loop = make_closed_loop(sampled, a, b);
        out.push_back({{a, b}, loop_schur_form(loop.transition).spectral_radius});
    }
    return out;
}

TEST(EnergyCosts, DoubleAgreesWithLongDoubleToTheStatedAccuracy) {
    // Stated accuracy (energy_costs.hpp): relative error <= 1e-10 for rho <= 0.999, and
    // <= 1e-13 / (1 - rho)^2 closer to the boundary. Long double has 11 more bits, so its result is
    // the reference for the rounding error of the double one.
    for (const NormalizedPlant p : {NormalizedPlant{0, 0, 0}, NormalizedPlant{0.001, 0.02, 1},
                                    NormalizedPlant{0, 0, 3.5}, NormalizedPlant{0.0005, 0.01, 6}}) {
        const SampledPlant<double> d(p);
        const SampledPlant<long double> ld(p);
        for (double shrink : {0.98, 0.9999, 0.999999}) {
            for (const auto& [g, rho] : random_stable_points(p, 40, shrink, 7)) {
                const auto c = energy_costs(d, g.alpha, g.beta);
                const auto r = energy_costs(ld, static_cast<long double>(g.alpha), static_cast<long double>(g.beta));
                const double bound = rho <= 0.999 ? 1e-10 : 1e-13 / ((1 - rho) * (1 - rho));
                for (int k = 0; k < 3; ++k) {
                    const long double ref = k == 0 ? r.ce0 : k == 1 ? r.ce1 : r.ce2;
                    const double got = k == 0 ? c.ce0 : k == 1 ? c.ce1 : c.ce2;
                    ASSERT_TRUE(std::isfinite(got));
                    EXPECT_LE(std::abs(static_cast<double>((got - ref) / ref)), bound)
                        << "d=" << p.delay << " alpha=" << g.alpha << " beta=" << g.beta << " rho=" << rho
                        << " k=" << k;
                }
            }
        }
    }
}

TEST(EnergyCosts, FractionalDelayIsContinuousAtIntegers) {
    const NormalizedGains g{0.05, 0.37};
    const EnergyCosts at_one = energy_costs(NormalizedPlant{0, 0, 1}, g);
    double previous = HUGE_VAL;
    for (double eps : {1e-2, 1e-3, 1e-4, 1e-5, 1e-6, 1e-8}) {
        for (double d : {1 - eps, 1 + eps}) {
            const EnergyCosts c = energy_costs(NormalizedPlant{0, 0, d}, g);
            const double diff = std::abs(c.ce2 / at_one.ce2 - 1);
            EXPECT_LT(diff, 50 * eps) << "d=" << d;  // Lipschitz in d near the integer
        }
        const double diff = std::abs(energy_costs(NormalizedPlant{0, 0, 1 - eps}, g).ce0 / at_one.ce0 - 1);
        EXPECT_LT(diff, previous);
        previous = diff;
    }
}

TEST(EnergyCosts, UnstableGainsGiveInfinityNeverNaN) {
    const double inf = std::numeric_limits<double>::infinity();
    for (const NormalizedGains g : {NormalizedGains{0.7, 0.8284}, NormalizedGains{-0.1, 0.5}, NormalizedGains{0.3, 3.0},
                                    NormalizedGains{0.0, 0.5}, NormalizedGains{1e3, -1e3}}) {
        const EnergyCosts c = energy_costs(NormalizedPlant{0, 0, 0}, g);
        EXPECT_EQ(c.ce0, inf);
        EXPECT_EQ(c.ce1, inf);
        EXPECT_EQ(c.ce2, inf);
    }
    EXPECT_THROW(energy_costs(NormalizedPlant{0, 0, 0}, {std::nan(""), 0.5}), InvalidParameter);
    EXPECT_THROW(energy_costs(NormalizedPlant{0, -1, 0}, {0.1, 0.5}), InvalidParameter);
}

TEST(EnergyCosts, CostsArePositiveAndFiniteInsideTheRegion) {
    for (const NormalizedPlant p : {NormalizedPlant{0, 0, 0}, NormalizedPlant{0.001, 0.02, 2.25}}) {
        for (const auto& [g, rho] : random_stable_points(p, 30, 0.99, 3)) {
            const EnergyCosts c = energy_costs(p, g);
            EXPECT_GT(c.ce0, 0);
            EXPECT_GT(c.ce1, 0);
            EXPECT_GT(c.ce2, 0);
            EXPECT_TRUE(std::isfinite(c.ce2)) << rho;
        }
    }
}

TEST(EnergyCosts, StructuredSolverAgreesWithTheComplexSchurMethod) {
    // Two independent ways to the same sums: the shift-structured Stein solver (energy_costs) and the
    // complex Schur form with triangular Stein solves (detail::energy_costs_complex_schur). Each is within the
    // stated accuracy, so they agree within twice it; also beyond the fixed-capacity size (d > 13).
    for (const NormalizedPlant p :
         {NormalizedPlant{0, 0, 0}, NormalizedPlant{0.001, 0.02, 1}, NormalizedPlant{0.0005, 0.01, 2.5},
          NormalizedPlant{0, 0.01, 6}, NormalizedPlant{0.0001, 0.002, 20}}) {
        const SampledPlant<double> sampled(p);
        for (const auto& [g, rho] : random_stable_points(p, 20, 0.9999, 11)) {
            const EnergyCosts a = energy_costs(sampled, g.alpha, g.beta);
            const EnergyCosts b = hapticopt::detail::energy_costs_complex_schur(sampled, g.alpha, g.beta);
            const double bound = 2 * (rho <= 0.999 ? 1e-10 : 1e-13 / ((1 - rho) * (1 - rho)));
            for (int k = 0; k < 3; ++k) {
                EXPECT_LE(std::abs(ce(a, k) / ce(b, k) - 1), bound) << "d=" << p.delay << " rho=" << rho << " k=" << k;
                EXPECT_EQ(energy_cost(sampled, g.alpha, g.beta, k), ce(a, k)) << "single index k=" << k;
            }
        }
    }
}

TEST(EnergyCosts, ShiftSteinSolverSolvesBothLyapunovEquations) {
    // X = M X M^T + C and P = M^T P M + I, checked by their residuals against the dense M.
    for (const NormalizedPlant p : {NormalizedPlant{0, 0, 0}, NormalizedPlant{0.001, 0.02, 1.5},
                                    NormalizedPlant{0, 0, 6}, NormalizedPlant{0.0001, 0.002, 20}}) {
        const SampledPlant<double> sampled(p);
        for (const auto& [g, rho] : random_stable_points(p, 5, 0.99, 5)) {
            const ClosedLoop<double> loop = make_closed_loop(sampled, g.alpha, g.beta);
            const DynamicMatrix<double>& m = loop.transition;
            const ShiftSteinSolver<double> solver(m.topRows(2));
            ASSERT_TRUE(solver.ok());
            const DynamicMatrix<double> c = loop.initial_state * loop.initial_state.transpose();
            const DynamicMatrix<double> x = solver.solve(c);
            EXPECT_LE((m * x * m.transpose() + c - x).norm(), 1e-13 * x.norm() / (1 - rho)) << "d=" << p.delay;
            EXPECT_LE((solver.propagate(x) - m * x * m.transpose()).norm(), 1e-14 * x.norm()) << "d=" << p.delay;
            const DynamicMatrix<double> q = solver.observability_gramian();
            const DynamicMatrix<double> identity = DynamicMatrix<double>::Identity(m.rows(), m.cols());
            EXPECT_LE((m.transpose() * q * m + identity - q).norm(), 1e-13 * q.norm() / (1 - rho)) << "d=" << p.delay;
            EXPECT_NEAR(q.cwiseProduct(c).sum() / x.trace(), 1.0, 1e-12) << "<P, C> = tr X, d=" << p.delay;
        }
    }
}

}  // namespace
}  // namespace hapticopt
