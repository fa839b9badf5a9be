// SPDX-License-Identifier: Apache-2.0
// C_OV from the exact continuous maximum, against sample-based maxima of the independent
// time-stepping method, and the meaning of the tolerance; plus the step response.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>

#include <hapticopt/overshoot.hpp>
#include <hapticopt/step_response.hpp>

#include "reference_simulation.hpp"

namespace hapticopt {
namespace {

TEST(Overshoot, SampledMaximaConvergeFromBelowToTheExactMaximum) {
    // A sampled maximum misses the peak: the nearest grid point is within h/2 of it, so the gap is
    // at most a (h/2)^2 / 2 with a the acceleration bound near the peak, |x''| <= 1 + (alpha + 2 beta
    // + gamma) 2 x_inf (|x| <= 2 x_inf when C_OV < 1) + delta x_inf; it must never be negative.
    struct Case {
        NormalizedPlant p;
        NormalizedGains g;
    };
    for (const Case& c : {Case{{0, 0, 0}, {0.3220, 0.9800}}, Case{{0.001, 0.02, 1}, {0.0618, 0.3778}},
                          Case{{0, 0.01, 1.5}, {0.05, 0.3}}}) {
        const OvershootResult exact = overshoot(c.p, c.g);
        ASSERT_TRUE(exact.converged);
        ASSERT_GT(exact.value, 1e-4);
        const double x_inf = 1 / (c.g.alpha + c.p.gamma);
        const double accel = 1 + (c.g.alpha + 2 * c.g.beta + c.p.gamma) * 2 * x_inf + c.p.delta * x_inf;
        double previous_gap = HUGE_VAL;
        for (int substeps : {8, 16, 32, 64, 128}) {
            const auto sim =
                testing::simulate_step(c.p.gamma, c.p.delta, c.p.delay, c.g.alpha, c.g.beta, substeps, 400);
            const double gap = exact.value - sim.max_sampled_overshoot;
            const double h = 1.0 / substeps;
            EXPECT_GE(gap, -1e-12) << "sampled maximum above the exact one, substeps=" << substeps;
            EXPECT_LE(gap, accel * h * h / 8 / x_inf) << substeps;
            previous_gap = gap;
        }
        EXPECT_LT(previous_gap / exact.value, 1e-4);
    }
}

TEST(Overshoot, ProvenStopMissesNothingLater) {
    // The Lyapunov bound ends the search; a 3000-period simulation must not find a larger maximum.
    const NormalizedPlant p{0, 0, 1};
    for (const NormalizedGains g :
         {NormalizedGains{0.0702, 0.471}, NormalizedGains{0.14, 0.43}, NormalizedGains{0.03, 0.6}}) {
        const OvershootResult r = overshoot(p, g);
        ASSERT_TRUE(r.converged);
        const auto sim = testing::simulate_step(0, 0, 1, g.alpha, g.beta, 16, 3000);
        EXPECT_LE(sim.max_sampled_overshoot, r.value + 1e-12) << g.alpha << " " << g.beta;
    }
}

TEST(Overshoot, ToleranceDefinesNoOvershootAtTheRegionTip) {
    // d = 0, beta = 0.97: the no-overshoot region ends between alpha = 0.221 and 0.222 (Table III).
    const NormalizedPlant p{0, 0, 0};
    const OvershootResult inside = overshoot(p, {0.221, 0.97});
    const OvershootResult outside = overshoot(p, {0.2225, 0.97});
    EXPECT_TRUE(inside.within_tolerance);
    EXPECT_LE(inside.value, 1e-12);
    EXPECT_FALSE(outside.within_tolerance);
    EXPECT_GT(outside.value, 1e-12);
    OvershootOptions loose;
    loose.tolerance = 1e-6;
    EXPECT_TRUE(overshoot(p, {0.2225, 0.97}, loose).within_tolerance);
    EXPECT_FALSE(overshoot(p, {0.26, 0.97}, loose).within_tolerance);
    // A monotone response: no overshoot at all.
    const OvershootResult slow = overshoot(p, {0.05, 0.9});
    EXPECT_EQ(slow.value, 0.0);
    EXPECT_TRUE(slow.within_tolerance);
    EXPECT_TRUE(std::isnan(slow.time));
}

TEST(Overshoot, BadToleranceAndUnstableGains) {
    OvershootOptions bad;
    for (double t : {0.0, -1e-6, 2.0, std::nan("")}) {
        bad.tolerance = t;
        EXPECT_THROW(overshoot(NormalizedPlant{}, {0.1, 0.5}, bad), InvalidParameter);
    }
    const OvershootResult r = overshoot(NormalizedPlant{}, {0.9, 0.5});
    EXPECT_TRUE(std::isinf(r.value));
    EXPECT_FALSE(r.within_tolerance);
}

TEST(Overshoot, StopAboveGivesALowerBoundAboveItAndChangesNothingBelow) {
    // stop_above below the overshoot: the scan stops early at a value in (stop_above, C_OV]; above it: the
    // same scan, bit for bit.
    const NormalizedPlant p{0.001, 0.02, 1};
    for (const NormalizedGains g : {NormalizedGains{0.0702, 0.471}, NormalizedGains{0.14, 0.43}}) {
        const OvershootResult whole = overshoot(p, g);
        ASSERT_TRUE(whole.converged);
        ASSERT_GT(whole.value, 1e-6);
        OvershootOptions o;
        o.stop_above = whole.value / 2;
        const OvershootResult early = overshoot(p, g, o);
        EXPECT_TRUE(early.stopped_above);
        EXPECT_FALSE(early.converged);
        EXPECT_GT(early.value, o.stop_above);
        EXPECT_LE(early.value, whole.value);
        EXPECT_LT(early.periods, whole.periods);
        o.stop_above = whole.value * 2;
        const OvershootResult same = overshoot(p, g, o);
        EXPECT_FALSE(same.stopped_above);
        EXPECT_EQ(same.value, whole.value);
        EXPECT_EQ(same.periods, whole.periods);
    }
    OvershootOptions bad;
    for (double s : {-1e-9, std::nan("")}) {
        bad.stop_above = s;
        EXPECT_THROW(overshoot(p, {0.05, 0.3}, bad), InvalidParameter);
    }
}

TEST(Overshoot, PieceBoundIsAboveEveryPointOfThePiece) {
    // piece_maximum_bound lets the scan skip a piece's interior maximum; it must bound x on the whole piece.
    // Independent values: x(tau) = e1^T exp(A tau) xi by a 40-term Taylor series in long double on 1001
    // points (||A|| h <= 2 here, so the truncation error is below 2^40 / 40! ~ 1e-36 of |xi|).
    const NormalizedPlant p{0.001, 0.02, 1};
    const Matrix3<double> a = plant_augmented_matrix<double>(p);
    std::uint64_t seed = 12345;
    auto uniform = [&] {
        seed = seed * 6364136223846793005ULL + 1442695040888963407ULL;
        return static_cast<double>(seed >> 11) / 9007199254740992.0 * 2 - 1;
    };
    for (double h : {0.05, 0.25, 1.0}) {
        const detail::PieceBound<double> piece = detail::make_piece_bound(a, h);
        for (int trial = 0; trial < 100; ++trial) {
            const Eigen::Vector3d xi(uniform(), uniform(), uniform());
            long double top = -HUGE_VALL;
            for (int k = 0; k <= 1000; ++k) {
                const long double tau = static_cast<long double>(h) * k / 1000;
                Eigen::Matrix<long double, 3, 1> term = xi.cast<long double>(), sum = term;
                for (int n = 1; n < 40; ++n) {
                    term = (a.cast<long double>() * term) * (tau / n);
                    sum += term;
                }
                top = std::max(top, sum(0));
            }
            const double bound = detail::piece_maximum_bound(xi, h, piece);
            EXPECT_GE(bound, static_cast<double>(top)) << "h " << h << " trial " << trial;
            // Not vacuous: above the maximum by no more than twice the remainder term.
            EXPECT_LE(bound - static_cast<double>(top), 2 * piece.remainder_gain * xi.norm() + 1e-12) << "h " << h;
        }
    }
}

TEST(StepResponse, SamplesAndContinuousValuesAgreeWithTheSimulation) {
    const NormalizedPlant p{0.001, 0.02, 1.5};
    const NormalizedGains g{0.05, 0.3};
    const auto samples = sampled_step_response(p, g, 50);
    EXPECT_EQ(samples[0], 0.0);
    const auto point = step_response_at(p, g, 0.0);
    EXPECT_NEAR(point.energy, 0.5 / (g.alpha + p.gamma), 1e-15);
    // Continuous values at sample instants equal the samples; the motion is continuous across the
    // force switch at t = j + 0.5 (fractional delay).
    const SampledPlant<double> sp(p);
    const auto pts = step_response(sp, g.alpha, g.beta, std::vector<double>{37.0, 10.5 - 1e-9, 10.5 + 1e-9, 3.0});
    EXPECT_NEAR(pts[3].position, samples[3], 1e-14);
    EXPECT_NEAR(pts[0].position, samples[37], 1e-14);
    EXPECT_NEAR(pts[1].position, pts[2].position, 1e-8);
    EXPECT_NEAR(pts[1].velocity, pts[2].velocity, 1e-8);
    const auto far = step_response_at(p, g, 3000.0);
    EXPECT_NEAR(far.position, 1 / (g.alpha + p.gamma), 1e-12);
    EXPECT_THROW(step_response_at(p, g, -1.0), InvalidParameter);
}

}  // namespace
}  // namespace hapticopt
