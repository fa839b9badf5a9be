// SPDX-License-Identifier: Apache-2.0
// Optimal curves and points beyond the tables: global optimality against a dense grid, curve
// accuracy against dC/dbeta in long double, eq. 3 scaling, fractional delays.
#include <gtest/gtest.h>

#include <cmath>

#include <hapticopt/optimal_wall.hpp>
#include <hapticopt/stability.hpp>

namespace hapticopt {
namespace {

TEST(Optimum, EnergyOptimaBeatEveryPointOfADenseGrid) {
    // The optimiser's coarse grid is 24 x 16; this independent 120 x 120 grid over the exact stable
    // region must not find a lower cost (to rounding, 1e-12 relative).
    for (const NormalizedPlant p : {NormalizedPlant{0, 0, 0}, NormalizedPlant{0.001, 0.02, 1}}) {
        const WallOptimizer opt(p);
        const auto& region = opt.region();
        for (const Criterion c : {Criterion::CE0, Criterion::CE1, Criterion::CE2}) {
            const Optimum o = opt.optimum(c);
            const int k = *energy_index(c);
            ASSERT_TRUE(o.cost.has_value());
            EXPECT_TRUE(is_stable(p, {o.alpha, o.beta}));
            double grid_best = HUGE_VAL;
            for (int i = 0; i < 120; ++i) {
                const double a = region.alpha_min() + (region.alpha_max() - region.alpha_min()) * (i + 0.5) / 120;
                const auto [lo, hi] = region.beta_range(a);
                for (int j = 0; j < 120; ++j)
                    grid_best = std::min(grid_best, opt.energy_cost(k, a, lo + (hi - lo) * (j + 0.5) / 120));
            }
            EXPECT_LE(*o.cost, grid_best * (1 + 1e-12)) << to_string(c) << " d=" << p.delay;
            // Interior and locally minimal in every direction.
            for (double angle = 0; angle < 6.28; angle += 0.3927) {
                const double da = 1e-4 * std::cos(angle), db = 1e-4 * std::sin(angle);
                EXPECT_GT(opt.energy_cost(k, o.alpha + da, o.beta + db), *o.cost) << to_string(c) << " angle " << angle;
            }
        }
    }
}

TEST(Optimum, OptimalCurveIsAccurateTo1e8InBeta) {
    // Independent check in long double: dC/dbeta changes sign within +-1e-8 of beta_opt(alpha).
    const NormalizedPlant p{0.001, 0.02, 1};
    const WallOptimizer opt(p);
    const SampledPlant<long double> lp(p);
    for (int k = 0; k < 3; ++k) {
        for (double frac : {0.2, 0.45, 0.7, 0.9}) {
            const double a = opt.region().alpha_max() * frac;
            const double b = opt.optimal_beta(k, a);
            auto slope = [&](long double beta) {
                const long double h = 1e-7L;
                auto c = [&](long double x) {
                    const auto e = energy_costs(lp, static_cast<long double>(a), x);
                    return k == 0 ? e.ce0 : k == 1 ? e.ce1 : e.ce2;
                };
                return (c(beta + h) - c(beta - h)) / (2 * h);
            };
            EXPECT_LT(slope(static_cast<long double>(b) - 1e-8L), 0) << "k=" << k << " alpha=" << a;
            EXPECT_GT(slope(static_cast<long double>(b) + 1e-8L), 0) << "k=" << k << " alpha=" << a;
        }
    }
}

TEST(Optimum, OvershootPointAgreesWithBisectionOfTheNoOvershootPredicate) {
    // The OV point (scan and bisection with evaluations stopped above 1 %) against plain bisection of
    // "min over beta of C_OV <= tol" (WallOptimizer::optimal_beta(3, .) and overshoot_cost, whole values)
    // started from alpha_ov (1 -+ 1e-3): both brackets are 1e-10 wide (alpha_tolerance) and hold the same sign
    // change, so their ends agree to 2e-10.
    for (const NormalizedPlant p : {NormalizedPlant{0, 0, 0}, NormalizedPlant{0, 0.02, 0}, NormalizedPlant{0, 0, 1},
                                    NormalizedPlant{0.001, 0.02, 1}, NormalizedPlant{0.001, 0, 2.5}}) {
        const WallOptimizer opt(p);
        const Optimum o = opt.optimum(Criterion::Overshoot);
        const double tol = OptimumOptions{}.overshoot_tolerance;
        auto ok = [&](double a) { return opt.overshoot_cost(a, opt.optimal_beta(3, a)) <= tol; };
        const double lo = o.alpha * (1 - 1e-3), hi = o.alpha * (1 + 1e-3);
        ASSERT_TRUE(ok(lo)) << "d=" << p.delay;
        ASSERT_FALSE(ok(hi)) << "d=" << p.delay;
        const auto [b_ok, b_bad] = detail::bisect(ok, lo, hi, 1e-10);
        EXPECT_NEAR(o.alpha, b_ok, 2e-10) << "gamma=" << p.gamma << " delta=" << p.delta << " d=" << p.delay;
    }
}

TEST(Optimum, PhysicalGainsScaleWithMassAndSquaredRate) {
    const PhysicalPlant base{0.22, 0.0, 0.0, 0.001, 0.001};
    const WallTuning t = optimal_wall(Criterion::CE2, base);
    const WallTuning heavy = optimal_wall(Criterion::CE2, PhysicalPlant{0.44, 0.0, 0.0, 0.001, 0.001});
    const WallTuning fast = optimal_wall(Criterion::CE2, PhysicalPlant{0.22, 0.0, 0.0, 0.0005, 0.0005});
    EXPECT_NEAR(heavy.K / t.K, 2.0, 1e-9);
    EXPECT_NEAR(heavy.B / t.B, 2.0, 1e-9);
    EXPECT_NEAR(fast.K / t.K, 4.0, 1e-9);  // same d = 1: K ~ 1/T^2, B ~ 1/T
    EXPECT_NEAR(fast.B / t.B, 2.0, 1e-9);
    EXPECT_NEAR(t.K, t.alpha * 0.22 / 1e-6, 1e-9 * t.K);
    EXPECT_NEAR(t.stability_margin(), t.alpha / t.alpha_max, 0);
    EXPECT_GT(t.stability_margin(), 0.3);
    EXPECT_LT(t.stability_margin(), 0.6);
    EXPECT_THROW(optimal_wall(Criterion::CE2, PhysicalPlant{-0.2, 0, 0, 0.001, 0}), InvalidParameter);
}

TEST(Optimum, FractionalDelayOptimaLieBetweenTheNeighbouringIntegers) {
    for (const Criterion c : {Criterion::CE0, Criterion::CE2, Criterion::CE1_OV}) {
        const Optimum o1 = optimal_point(c, NormalizedPlant{0, 0, 1});
        const Optimum o15 = optimal_point(c, NormalizedPlant{0, 0, 1.5});
        const Optimum o2 = optimal_point(c, NormalizedPlant{0, 0, 2});
        EXPECT_LT(o15.alpha, o1.alpha) << to_string(c);
        EXPECT_GT(o15.alpha, o2.alpha) << to_string(c);
        EXPECT_LT(o15.beta, o1.beta) << to_string(c);
        EXPECT_GT(o15.beta, o2.beta) << to_string(c);
    }
}

TEST(Optimum, CriterionNamesRoundTrip) {
    for (const Criterion c : kAllCriteria) EXPECT_EQ(parse_criterion(to_string(c)), c);
    EXPECT_FALSE(parse_criterion("ce2").has_value());
    EXPECT_FALSE(parse_criterion("").has_value());
}

}  // namespace
}  // namespace hapticopt
