// SPDX-License-Identifier: Apache-2.0
// Stability over a box of masses and total delays (delay_range_stability.hpp), checked against independent models:
//  * the loop matrix's eigenvalues (hapticopt::stability: the state space of closed_loop.hpp / estimator_loop.hpp)
//    on a dense grid of masses and delays off any grid the test uses: a box accepted has every grid plant stable,
//    and a failing plant the test names has a root on or outside the unit circle;
//  * the time-stepping simulation (tests/common/loop_simulation.hpp): accepted gains decay at delays drawn from the
//    range (ends and interior fractional points), gains refused naming a delay grow at that delay;
//  * the polynomial family itself: the fit of the free-mass plant is exact to rounding, and phi = 0 of n is z p_n,
//    phi = 1 of n is p_(n+1).
#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <hapticopt/delay_range_stability.hpp>
#include <hapticopt/estimator_types.hpp>
#include <hapticopt/mass_scaling_stability.hpp>
#include <random>
#include <vector>

#include "common/estimator_loop_checks.hpp"
#include "common/loop_simulation.hpp"

namespace delay_range_test {

using hapticopt::DelayRangeTest;
using hapticopt::MassScalingTest;
using hapticopt::NormalizedGains;
using hapticopt::NormalizedPlant;
using hapticopt::VelocityEstimator;
using hapticopt::VelocityEstimatorKind;

using estimator_loop_checks::excursion_ratio;
using estimator_loop_checks::radius;

NormalizedPlant free_mass() { return NormalizedPlant{0.0, 0.0, 0.0}; }

// The free-mass family is a polynomial of degree 2 in phi: the degree-4 fit reproduces the exact discretisation at
// 4 further phi to rounding, and its ends join the whole delays: phi = 0 of n is z p_n, phi = 1 of n is p_(n+1).
TEST(DelayRange, TheFreeMassFamilyIsExactAndItsEndsAreTheWholeDelays) {
    for (const VelocityEstimator& e :
         {VelocityEstimator{}, VelocityEstimator::low_pass(0.02), VelocityEstimator::moving_window(15)}) {
        const DelayRangeTest test(free_mass(), e, 0.0, 7.0);
        EXPECT_TRUE(test.certified());
        ASSERT_EQ(test.families().size(), 7u);
        for (const hapticopt::DelaySegmentFamily& f : test.families()) {
            EXPECT_LE(f.residual, 1e-12) << f.whole_delay;
            EXPECT_EQ(f.degree, 4);
            for (std::size_t j = 3; j < f.alpha.size(); ++j)
                EXPECT_LE(f.alpha[j].cwiseAbs().maxCoeff(), 1e-12) << "phi^3 and higher are rounding";
            const auto at0 = test.polynomial(f, 0.0), at1 = test.polynomial(f, 1.0);
            NormalizedPlant p = free_mass();
            p.delay = f.whole_delay;
            const auto whole = MassScalingTest(p, e, hapticopt::ArmAlongRay::per_mass).polynomial();
            p.delay = f.whole_delay + 1;
            const auto next = MassScalingTest(p, e, hapticopt::ArmAlongRay::per_mass).polynomial();
            for (Eigen::Index k = 0; k < at0.base.size(); ++k) {
                const double z_pn_base = k == 0 || k - 1 >= whole.base.size() ? 0.0 : whole.base(k - 1);
                const double z_pn_alpha = k == 0 || k - 1 >= whole.alpha.size() ? 0.0 : whole.alpha(k - 1);
                EXPECT_NEAR(at0.base(k), z_pn_base, 1e-11) << k;
                EXPECT_NEAR(at0.alpha(k), z_pn_alpha, 1e-11) << k;
                EXPECT_NEAR(at1.base(k), k < next.base.size() ? next.base(k) : 0.0, 1e-11) << k;
                EXPECT_NEAR(at1.alpha(k), k < next.alpha.size() ? next.alpha(k) : 0.0, 1e-11) << k;
            }
        }
    }
}

// Random rays, scale intervals and delay intervals: an accepted box has every plant of a 40 x 23 grid (off the
// test's slabs: irrational offsets) stable by the loop matrix's eigenvalues; a refused one names a plant whose
// loop has a root on or outside the unit circle (radius >= 1 - 1e-6), or, not proven, one within 1e-3 of it.
TEST(DelayRange, TheVerdictOverABoxAgreesWithADenseScanOfTheLoopMatrix) {
    std::mt19937 rng(39);
    std::uniform_real_distribution<double> unit(0.0, 1.0);
    int accepted = 0, refused = 0;
    for (const VelocityEstimator& e : {VelocityEstimator{}, VelocityEstimator::moving_window(15)}) {
        const bool window = e.kind == VelocityEstimatorKind::window;
        for (int trial = 0; trial < 24; ++trial) {
            const double d_lo = (window ? 4.0 : 0.0) + 3.0 * unit(rng);
            const double d_hi = d_lo + 2.5 * unit(rng);
            const DelayRangeTest test(free_mass(), e, d_lo, d_hi);
            const double alpha = (window ? 0.004 : 0.08) * unit(rng), beta = (window ? 0.03 : 0.5) * unit(rng);
            const double s_lo = 0.6 + 0.4 * unit(rng), s_hi = s_lo * (1.0 + 0.6 * unit(rng));
            const hapticopt::DelayBoxStability v = test.over(alpha, beta, s_lo, s_hi);
            if (v.stable) {
                ++accepted;
                for (int i = 0; i < 40; ++i) {
                    for (int j = 0; j < 23; ++j) {
                        NormalizedPlant p = free_mass();
                        p.delay = d_lo + (d_hi - d_lo) * std::fmod(0.5 + i * 0.6180339887, 1.0);
                        const double s = s_lo + (s_hi - s_lo) * std::fmod(0.5 + j * 0.7548776662, 1.0);
                        EXPECT_LT(radius(p, e, s * alpha, s * beta), 1.0)
                            << "d " << p.delay << " s " << s << " alpha " << alpha << " beta " << beta;
                    }
                }
            } else {
                ++refused;
                EXPECT_GE(v.failing_delay, d_lo);
                EXPECT_LE(v.failing_delay, d_hi);
                EXPECT_GE(v.failing_scale, s_lo);
                EXPECT_LE(v.failing_scale, s_hi);
                NormalizedPlant p = free_mass();
                p.delay = v.failing_delay;
                const double r = radius(p, e, v.failing_scale * alpha, v.failing_scale * beta);
                EXPECT_GE(r, v.proven_unstable ? 1.0 - 1e-6 : 1.0 - 1e-3) << "d " << p.delay;
            }
        }
    }
    EXPECT_GT(accepted, 8);
    EXPECT_GT(refused, 8);
}

// The Falcon's loop (window 15, 0.30 kg, 1 kHz) with the delay 6 ms nominal and a range [5, 8] ms: the nominal
// delay's amax-like gains (stable at d = 6 for every mass) are refused over the range, naming a delay above 6
// periods where the independent simulation grows; the gains derated until accepted decay at the range's ends,
// at interior fractional delays and at masses drawn from the set.
TEST(DelayRange, StableAtTheNominalDelayButNotOverTheRangeAndTheSimulationAgrees) {
    const VelocityEstimator e = VelocityEstimator::moving_window(15);
    const double T = 1e-3, m = 0.30, s_lo = 0.30 / 0.33, s_hi = 0.30 / 0.20;
    NormalizedPlant nominal = free_mass();
    nominal.delay = 6.0;
    const MassScalingTest at_nominal(nominal, e, hapticopt::ArmAlongRay::per_mass);
    // The largest f of the ray (0.0034, 0.0527) stable over the masses at d = 6, less 1e-3.
    const double alpha0 = 0.0034, beta0 = 0.0527;
    double lo = 0.0, hi = 2.0;
    for (int i = 0; i < 50; ++i) {
        const double mid = (lo + hi) / 2;
        (at_nominal.over(mid * alpha0, mid * beta0, s_lo, s_hi).stable ? lo : hi) = mid;
    }
    const double alpha = lo * 0.999 * alpha0, beta = lo * 0.999 * beta0;
    ASSERT_TRUE(at_nominal.over(alpha, beta, s_lo, s_hi).stable);
    const DelayRangeTest range(free_mass(), e, 5.0, 8.0);
    const hapticopt::DelayBoxStability v = range.over(alpha, beta, s_lo, s_hi);
    ASSERT_FALSE(v.stable);
    EXPECT_TRUE(v.proven_unstable);
    EXPECT_GT(v.failing_delay, 6.0);
    const double failing_mass = m / v.failing_scale;
    EXPECT_GT(excursion_ratio(failing_mass, alpha * m / (T * T), beta * m / T, T, v.failing_delay, e, 40000), 1.0)
        << "d " << v.failing_delay << " mass " << failing_mass;
    // Derated along the ray until the range is accepted.
    lo = 0.0;
    hi = 1.0;
    for (int i = 0; i < 40; ++i) {
        const double mid = (lo + hi) / 2;
        (range.over(mid * alpha, mid * beta, s_lo, s_hi).stable ? lo : hi) = mid;
    }
    ASSERT_GT(lo, 0.3);
    const double a = lo * alpha, b = lo * beta;
    for (const double d : {5.0, 5.37, 6.0, 6.5, 7.2137, 7.8, 8.0}) {
        for (const double mass : {0.20, 0.26, 0.33}) {
            const double ratio = excursion_ratio(mass, a * m / (T * T), b * m / T, T, d, e, 60000);
            EXPECT_LT(ratio, 1.0) << "d " << d << " mass " << mass;
        }
    }
}

TEST(DelayRange, BadIntervalsAreRefusedByName) {
    EXPECT_THROW(DelayRangeTest(free_mass(), {}, -1.0, 2.0), hapticopt::InvalidParameter);
    EXPECT_THROW(DelayRangeTest(free_mass(), {}, 3.0, 2.0), hapticopt::InvalidParameter);
    EXPECT_THROW(DelayRangeTest(free_mass(), {}, 0.0, 100.0), hapticopt::InvalidParameter);
    EXPECT_THROW(DelayRangeTest(free_mass(), {}, 0.0, std::nan("")), hapticopt::InvalidParameter);
}

}  // namespace delay_range_test
