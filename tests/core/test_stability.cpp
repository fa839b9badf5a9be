// SPDX-License-Identifier: Apache-2.0
// Stability: the Schur-Cohn verdict against the exact d = 0 boundary, the alpha_max rows of the
// tables, the loop matrix's eigenvalues, and the exact region's polygon.
#include <gtest/gtest.h>

#include <cmath>
#include <complex>
#include <random>

#include <hapticopt/loop_schur_form.hpp>
#include <hapticopt/schur_cohn.hpp>
#include <hapticopt/stability.hpp>
#include <hapticopt/stability_region.hpp>

namespace hapticopt {
namespace {

const double kAlphaMaxD0 = 12 - 8 * std::sqrt(2.0);  // d = gamma = delta = 0, exact
const double kBetaAtMaxD0 = 2 * std::sqrt(2.0) - 2;

TEST(Stability, ExactBoundaryPointForZeroDelay) {
    const NormalizedPlant p{0, 0, 0};
    EXPECT_TRUE(is_stable(p, {kAlphaMaxD0 - 1e-10, kBetaAtMaxD0}));
    EXPECT_FALSE(is_stable(p, {kAlphaMaxD0 + 1e-10, kBetaAtMaxD0}));
    for (double db : {-1e-3, 1e-3, -0.1, 0.1}) EXPECT_FALSE(is_stable(p, {kAlphaMaxD0 + 1e-10, kBetaAtMaxD0 + db}));
    const StabilityRegion region(p);
    EXPECT_NEAR(region.alpha_max(), kAlphaMaxD0, 1e-12);
    EXPECT_NEAR(region.beta_at_alpha_max(), kBetaAtMaxD0, 1e-10);
    EXPECT_DOUBLE_EQ(region.alpha_min(), 0.0);
    // The left edge alpha = -gamma is the z = 1 branch: just right of it is stable.
    EXPECT_TRUE(is_stable(p, {1e-9, 0.5}));
    EXPECT_FALSE(is_stable(p, {-1e-9, 0.5}));
}

TEST(Stability, AlphaMaxRowsOfTheTablesStableInsideUnstableOutside) {
    struct Row {
        NormalizedPlant p;
        double printed_alpha;
    };
    const Row rows[] = {{{0, 0, 0}, 0.6863},        {{0.001, 0, 0}, 0.6858},   {{0, 0.02, 0}, 0.7132},
                        {{0.001, 0.02, 0}, 0.7127}, {{0, 0, 1}, 0.1445},       {{0.001, 0, 1}, 0.1440},
                        {{0, 0.02, 1}, 0.1548},     {{0.001, 0.02, 1}, 0.1543}};
    for (const Row& r : rows) {
        const StabilityRegion region(r.p);
        EXPECT_NEAR(region.alpha_max(), r.printed_alpha, 0.5e-4) << r.p.gamma << " " << r.p.delta << " " << r.p.delay;
        const double a = region.alpha_max(), b = region.beta_at_alpha_max();
        EXPECT_TRUE(is_stable(r.p, {a * (1 - 1e-9), b}));
        for (int i = 0; i <= 400; ++i) {  // no beta at all is stable just beyond alpha_max
            EXPECT_FALSE(is_stable(r.p, {a * (1 + 1e-9), -0.5 + 3.0 * i / 400}));
        }
    }
}

TEST(Stability, CharacteristicPolynomialRootsAreTheLoopEigenvalues) {
    for (const NormalizedPlant p : {NormalizedPlant{0, 0, 0}, NormalizedPlant{0.001, 0.02, 1},
                                    NormalizedPlant{0.0003, 0.01, 2.4}, NormalizedPlant{0, 0, 6}}) {
        const SampledPlant<double> s(p);
        const auto poly = characteristic_polynomial(s).at(0.05, 0.3);
        const auto loop = make_closed_loop(s, 0.05, 0.3);
        const Eigen::VectorXcd eig = loop.transition.eigenvalues();
        int nonzero = 0;
        for (Eigen::Index i = 0; i < eig.size(); ++i) {
            if (std::abs(eig(i)) < 1e-6) continue;
            ++nonzero;
            std::complex<double> v = 0;
            for (Eigen::Index k = poly.size() - 1; k >= 0; --k) v = v * eig(i) + poly(k);
            EXPECT_LT(std::abs(v), 1e-10) << "d=" << p.delay << " eigenvalue " << eig(i);
        }
        EXPECT_EQ(nonzero, poly.size() - 1) << "d=" << p.delay;
    }
}

TEST(Stability, SchurCohnVerdictAgreesWithEigenvaluesAwayFromTheBoundary) {
    std::mt19937 rng(11);
    std::uniform_real_distribution<double> ua(-0.05, 0.8), ub(-0.3, 2.5), ud(0, 8);
    int checked = 0;
    for (int i = 0; i < 3000; ++i) {
        const NormalizedPlant p{0.001 * (i % 3), 0.01 * (i % 5), std::round(ud(rng) * 4) / 4};
        const NormalizedGains g{ua(rng) / (1 + p.delay), ub(rng) / (1 + p.delay)};
        const StabilityReport r = stability(p, g);
        if (std::abs(r.spectral_radius - 1) < 1e-9) continue;
        ++checked;
        EXPECT_EQ(r.stable, r.spectral_radius < 1) << p.delay << " " << g.alpha << " " << g.beta;
        EXPECT_EQ(is_stable(p, g), r.stable);
    }
    EXPECT_GT(checked, 2900);
}

// A Schur-Cohn step within rounding of the circle (1 - |k| ~ 5e-15 here), then a failing step whose k is rounding
// (|k| = 1.012 in double, 0.9994 in long double): the margin must stay the near-circle step's, so that loop_verdict
// refines it (|margin| < 1e-4) and agrees with long double. The gains are a set of the stress test (tests/stress)
// where a margin of -0.0123 skipped the refinement and gave the opposite verdict.
TEST(Stability, AFailingStepAfterANearCircleStepKeepsItsSmallMargin) {
    const NormalizedPlant p{0.0059597990386868107, 0.043222233735992092, 1.0562015377175449};
    const double alpha = -0.0046997407473411482, beta = -0.050659820101998376;
    using LD = long double;
    const SchurCohnResult<double> plain =
        schur_cohn<double>(characteristic_polynomial(SampledPlant<double>(p)).at(alpha, beta));
    const SchurCohnResult<LD> fine =
        schur_cohn<LD>(characteristic_polynomial(SampledPlant<LD>(p)).at(LD(alpha), LD(beta)));
    EXPECT_LE(std::abs(plain.margin), 1e-12);  // 1 - |k| of the near-circle step, ~2^-47
    const LoopVerdict<double> v = loop_verdict(SampledPlant<double>(p), alpha, beta);
    EXPECT_TRUE(v.refined);
    EXPECT_EQ(v.stable, fine.stable);
}

TEST(Stability, RegionPolygonEnclosesExactlyTheStablePoints) {
    for (const NormalizedPlant p :
         {NormalizedPlant{0, 0, 0}, NormalizedPlant{0.001, 0.02, 1}, NormalizedPlant{0, 0.01, 2.5},
          NormalizedPlant{0.001, 0, 6}, NormalizedPlant{0.0001, 0.002, 20}}) {
        const StabilityRegion region(p);
        const auto poly = region.polygon(64);
        double ca = 0, cb = 0;
        for (const auto& q : poly) {
            ca += q.alpha;
            cb += q.beta;
        }
        ca /= static_cast<double>(poly.size());
        cb /= static_cast<double>(poly.size());
        ASSERT_TRUE(is_stable(p, {ca, cb}));
        for (std::size_t i = 1; i + 1 < poly.size(); ++i) {
            const auto& q = poly[i];
            const double inside_a = q.alpha + 1e-6 * (ca - q.alpha), inside_b = q.beta + 1e-6 * (cb - q.beta);
            const double outside_a = q.alpha - 1e-6 * (ca - q.alpha), outside_b = q.beta - 1e-6 * (cb - q.beta);
            EXPECT_TRUE(is_stable(p, {inside_a, inside_b})) << "d=" << p.delay << " theta=" << q.theta;
            EXPECT_FALSE(is_stable(p, {outside_a, outside_b})) << "d=" << p.delay << " theta=" << q.theta;
        }
        const auto [lo, hi] = region.beta_range(region.alpha_max() / 2);
        EXPECT_TRUE(is_stable(p, {region.alpha_max() / 2, lo + 1e-7}));
        EXPECT_FALSE(is_stable(p, {region.alpha_max() / 2, lo - 1e-7}));
        EXPECT_TRUE(is_stable(p, {region.alpha_max() / 2, hi - 1e-7}));
        EXPECT_FALSE(is_stable(p, {region.alpha_max() / 2, hi + 1e-7}));
    }
}

}  // namespace
}  // namespace hapticopt
