// SPDX-License-Identifier: Apache-2.0
// The tuning's stability decisions with the loop's velocity estimator (tuning/tuning.hpp, tuning/object_checks.hpp):
// every verdict, alpha_max, optimum, predicted cost and noise figure is the one of the loop with the profile's
// velocity_estimator. Checked against hapticopt's estimator functions called directly (the same analysis: the
// adapter must not drop the estimator anywhere), against the coupled (matrix) check, whose radius
// tests/beyond/test_matrix_gain_estimator.cpp compares with an independently built state matrix, and against the
// reference figure of the paper's CE2 optimum with a 20 Hz low-pass at 1 kHz: spectral radius 1.0652 at d = 0.
#include <cmath>
#include <cstdio>
#include <functional>
#include <string>

#include <gtest/gtest.h>
#include <hapticopt/hapticopt.hpp>

#include "common/startup_error.hpp"
#include "tuning/object_checks.hpp"
#include "tuning/tuning.hpp"

namespace hapticd {
namespace estimator_checks_test {

constexpr double kPeriod = 1e-3;
constexpr double kMass = 0.3;

VelocityEstimatorSpec low_pass_hz(double hz) {
    VelocityEstimatorSpec s;
    s.kind = hapticopt::VelocityEstimatorKind::lowpass;
    s.cutoff_hz = hz;
    return s;
}

VelocityEstimatorSpec window_of(int n) {
    VelocityEstimatorSpec s;
    s.kind = hapticopt::VelocityEstimatorKind::window;
    s.window = n;
    return s;
}

GainCheckPlant plant_with(double delay_periods, const VelocityEstimatorSpec& velocity) {
    GainCheckPlant p;
    p.mass = kMass;
    p.period = kPeriod;
    p.time_delay = delay_periods * kPeriod;
    p.velocity = velocity;
    return p;
}

hapticopt::NormalizedPlant normalized(double delay_periods) { return {0.0, 0.0, delay_periods}; }

ErrorKind kind_of(const std::function<void()>& f) {
    try {
        f();
    } catch (const StartupError& e) {
        return e.kind();
    }
    ADD_FAILURE() << "no StartupError";
    return ErrorKind::Usage;
}

TEST(EstimatorChecks, TheConversionIsNuEqualsCutoffTimesPeriod) {
    const hapticopt::VelocityEstimator lp = to_hapticopt_estimator(low_pass_hz(20.0), kPeriod);
    EXPECT_EQ(lp.kind, hapticopt::VelocityEstimatorKind::lowpass);
    EXPECT_DOUBLE_EQ(lp.cutoff, 0.02);
    const hapticopt::VelocityEstimator w = to_hapticopt_estimator(window_of(7), kPeriod);
    EXPECT_EQ(w.kind, hapticopt::VelocityEstimatorKind::window);
    EXPECT_EQ(w.window, 7);
    EXPECT_EQ(to_hapticopt_estimator(VelocityEstimatorSpec{}, kPeriod).kind,
              hapticopt::VelocityEstimatorKind::backward);
    EXPECT_EQ(kind_of([] { (void)to_hapticopt_estimator(low_pass_hz(-1.0), kPeriod); }), ErrorKind::InvalidParameter);
}

// The paper's CE2 optimum (backward difference) at d = 0 and d = 1 is stable for the backward checker and
// unstable with a 20 Hz low-pass (nu = 0.02): spectral radius 1.0652 at d = 0 (the reference figure, four
// digits) and above 1 at d = 1; the coupled check of the same pair on all three axes says the same.
TEST(EstimatorChecks, ALowPassCheckerRefusesTheBackwardOptimum) {
    for (double d : {0.0, 1.0}) {
        const GainChecker backward(plant_with(d, {}));
        const GainChecker filtered(plant_with(d, low_pass_hz(20.0)));
        const TuningResult ce2 = tune_wall(hapticopt::Criterion::CE2, backward.plant());
        EXPECT_TRUE(backward.pair_is_stable(ce2.K, ce2.B, kMass));
        EXPECT_FALSE(filtered.pair_is_stable(ce2.K, ce2.B, kMass)) << "d " << d;
        const double rho =
            hapticopt::stability(normalized(d), hapticopt::NormalizedGains{ce2.alpha, ce2.beta}, filtered.estimator())
                .spectral_radius;
        EXPECT_GT(rho, 1.0);
        std::printf("[ low-pass ] d = %g: the backward CE2 optimum (alpha %.6f, beta %.6f) has radius %.6f\n", d,
                    ce2.alpha, ce2.beta, rho);
        if (d == 0.0) {
            EXPECT_NEAR(rho, 1.0652, 1e-4);
        }
        Matrix3 K{}, B{};
        for (std::size_t i = 0; i < 3; ++i) {
            K[i][i] = ce2.K;
            B[i][i] = ce2.B;
        }
        const hapticopt::MatrixGainStability coupled = filtered.coupled(K, B);
        EXPECT_FALSE(coupled.stable);
        EXPECT_NEAR(coupled.spectral_radius, rho, 1e-8);  // the same scalar loop per axis (commuting path)
        EXPECT_TRUE(backward.coupled(K, B).stable);
        std::string why;
        EXPECT_FALSE(filtered.sum_is_stable(K, B, why));
        EXPECT_NE(why.find("outside the stability region"), std::string::npos) << why;
        EXPECT_TRUE(backward.sum_is_stable(K, B, why)) << why;
        // A ramp over that scene (it as the base, nothing in or out) is refused with the low-pass only.
        const Matrix3 zero{};
        EXPECT_FALSE(filtered.ramp_is_stable(K, B, zero, zero, zero, zero, 0.5, why));
        EXPECT_TRUE(backward.ramp_is_stable(K, B, zero, zero, zero, zero, 0.5, why)) << why;
        // check_pair: the refusal's alpha_max is the low-pass main region's, and the largest stable K at that B
        // is on the estimator's boundary (stable 1e-9 below, unstable 1e-6 above: the bisection's 2^-60
        // relative resolution is far inside both).
        const PairVerdict v = filtered.check_pair(ce2.K, ce2.B, kMass);
        EXPECT_FALSE(v.stable);
        const hapticopt::EstimatorStabilityRegion region(normalized(d), filtered.estimator());
        EXPECT_DOUBLE_EQ(v.alpha_max, region.alpha_max());
        EXPECT_LT(v.alpha_max, ce2.alpha);
        ASSERT_GT(v.largest_stable_K, 0.0);
        const hapticopt::EstimatorStabilityTest test(normalized(d), filtered.estimator());
        const double a = v.largest_stable_K * kPeriod * kPeriod / kMass;
        EXPECT_TRUE(test.stable(a * (1 - 1e-9), ce2.beta));
        EXPECT_FALSE(test.stable(a * (1 + 1e-6), ce2.beta));
    }
}

// The estimator's own optimum is accepted, and it is hapticopt::optimal_point's with the estimator, scaled to the
// mass: tune_wall, the checker's criterion gains and check_explicit_gains (predicted cost) agree with it.
TEST(EstimatorChecks, TheEstimatorsOwnOptimumIsAcceptedAndIsTheLibrarys) {
    for (const VelocityEstimatorSpec& spec : {low_pass_hz(20.0), window_of(3)}) {
        for (double d : {0.0, 1.0}) {
            GainChecker checker(plant_with(d, spec));
            const hapticopt::EstimatorOptimum o =
                hapticopt::optimal_point(hapticopt::Criterion::CE2, normalized(d), checker.estimator());
            const TuningResult t = tune_wall(hapticopt::Criterion::CE2, checker.plant());
            EXPECT_DOUBLE_EQ(t.alpha, o.alpha);
            EXPECT_DOUBLE_EQ(t.beta, o.beta);
            EXPECT_DOUBLE_EQ(t.K, o.alpha * kMass / (kPeriod * kPeriod));
            EXPECT_DOUBLE_EQ(t.B, o.beta * kMass / kPeriod);
            ASSERT_TRUE(t.cost.has_value());
            EXPECT_DOUBLE_EQ(*t.cost, *o.cost);
            EXPECT_DOUBLE_EQ(t.alpha_max, o.alpha_max);
            const CriterionGains gains = checker.criterion_gains(hapticopt::Criterion::CE2, kMass);
            EXPECT_NEAR(gains.K, t.K, 1e-9 * t.K);
            EXPECT_NEAR(gains.B, t.B, 1e-9 * t.B);
            EXPECT_TRUE(checker.pair_is_stable(t.K, t.B, kMass));
            EXPECT_TRUE(checker.check_object(t.K, t.B, {kMass}).stable);
            const TuningResult e = check_explicit_gains(t.K, t.B, hapticopt::Criterion::CE2, checker.plant());
            ASSERT_TRUE(e.cost.has_value());
            // The explicit gains are the optimum's up to the K/B round trip (1 ulp): the cost agrees to 1e-9.
            EXPECT_NEAR(*e.cost, *o.cost, 1e-9 * *o.cost);
            // The optimum's region is the fast search's coarser grid (kFastOptimumRegionGrid), the explicit gains'
            // the default one: each locates the tip by Brent on the refined edge from its own bracket, to the
            // region's stated accuracy of ~1e-12 (EstimatorStabilityRegion).
            EXPECT_NEAR(e.alpha_max, o.alpha_max, 1e-12 * o.alpha_max);
            // amax: the main region's tip backed off by kAlphaMaxBackOff, stable with the estimator.
            const TuningResult amax = tune_wall(hapticopt::Criterion::AlphaMax, checker.plant());
            EXPECT_DOUBLE_EQ(amax.alpha, o.alpha_max * (1.0 - kAlphaMaxBackOff));
            EXPECT_TRUE(checker.pair_is_stable(amax.K, amax.B, kMass));
        }
    }
}

TEST(EstimatorChecks, ExplicitGainsAreJudgedWithTheEstimator) {
    const TuningPlant backward = plant_with(1.0, {});
    const TuningPlant filtered = plant_with(1.0, low_pass_hz(20.0));
    const TuningResult ce2 = tune_wall(hapticopt::Criterion::CE2, backward);
    EXPECT_NO_THROW((void)check_explicit_gains(ce2.K, ce2.B, hapticopt::Criterion::CE2, backward));
    try {
        (void)check_explicit_gains(ce2.K, ce2.B, hapticopt::Criterion::CE2, filtered);
        FAIL() << "the backward optimum accepted with the low-pass";
    } catch (const StartupError& e) {
        EXPECT_EQ(e.kind(), ErrorKind::UnstableGains);
        EXPECT_NE(std::string(e.what()).find("velocity_estimator = lowpass:20Hz"), std::string::npos) << e.what();
    }
    // --passivity-control models the backward difference: refused with another estimator.
    EXPECT_EQ(kind_of([&] { (void)check_explicit_gains(ce2.K, ce2.B, hapticopt::Criterion::CE2, filtered, true); }),
              ErrorKind::Usage);
    EXPECT_NO_THROW((void)check_explicit_gains(ce2.K, ce2.B, hapticopt::Criterion::CE2, backward, true));
    // OV with the estimator (hapticopt::estimator_overshoot_point): its gains, checked as explicit gains with the
    // loop's estimator, have no overshoot (C_OV <= 1e-12, the search's tolerance).
    const TuningResult ov = tune_wall(hapticopt::Criterion::Overshoot, filtered);
    const TuningResult ov_checked = check_explicit_gains(ov.K, ov.B, hapticopt::Criterion::Overshoot, filtered);
    ASSERT_TRUE(ov_checked.cost.has_value());
    EXPECT_LE(*ov_checked.cost, 1e-12);
}

// --robust with an estimator: the robust optimum of the loop with it (hapticopt::robust_optimum with
// RobustOptions::estimator), certified over the mass range by the crossing test with the estimator; each end of the
// box and its centre judged by the estimator's own Schur-Cohn verdict. A budget no robust gains meet is refused
// naming the key.
TEST(EstimatorChecks, TheRobustTuningAnalysesTheLoopsEstimator) {
    TuningBox box;
    box.mass_min = 0.25;
    box.mass_max = 0.35;
    box.delay_min = box.delay_max = kPeriod;
    box.period = kPeriod;
    box.velocity = window_of(2);
    const TuningResult r = tune_wall_robust(hapticopt::Criterion::CE2, box);
    ASSERT_TRUE(r.robust.has_value());
    EXPECT_TRUE(r.robust->mass_certified);
    EXPECT_GT(r.K, 0.0);
    for (const double m : {0.25, 0.30, 0.35}) {
        const hapticopt::NormalizedPlant np{0.0, 0.0, 1.0};
        const hapticopt::EstimatorStabilityTest test(np, hapticopt::VelocityEstimator::moving_window(2));
        EXPECT_TRUE(test.stable(r.K * kPeriod * kPeriod / m, r.B * kPeriod / m)) << m;
    }
    box.force_noise_budget = 1e-9;
    box.position_resolution = 1e-5;
    try {
        (void)tune_wall_robust(hapticopt::Criterion::CE2, box);
        FAIL() << "an unmeetable budget accepted";
    } catch (const StartupError& e) {
        EXPECT_EQ(e.kind(), ErrorKind::InvalidParameter);
        EXPECT_NE(std::string(e.what()).find("force_noise_budget"), std::string::npos) << e.what();
    }
}

// damping_range with the estimator: at a K inside the low-pass's main region, the stable B interval's ends are
// on the estimator's boundary (stable 1e-9 inside, unstable 1e-6 outside, relative). The accepted interval is the one
// stable over the plant set: for the nominal mass alone (no mass_range, mass_margin 0) the same interval to the
// bisection's precision; over 0.22 .. 0.30 kg widened by 10 % strictly inside it, its ends on the estimator's boundary
// at some mass of the set (stable over the set 1e-6 inside, not 1e-6 outside).
TEST(EstimatorChecks, DampingRangeIsTheEstimatorsInterval) {
    const GainChecker checker(plant_with(1.0, low_pass_hz(20.0)));
    const hapticopt::EstimatorStabilityRegion region(normalized(1.0), checker.estimator());
    const double alpha = 0.5 * region.alpha_max();
    const double K = alpha * kMass / (kPeriod * kPeriod);
    const auto range = checker.damping_range(K, {kMass});
    const auto accepted = checker.damping_range(K, {kMass}, true);
    ASSERT_TRUE(range.has_value());
    ASSERT_TRUE(accepted.has_value());
    const hapticopt::EstimatorStabilityTest test(normalized(1.0), checker.estimator());
    const double lo = range->first * kPeriod / kMass, hi = range->second * kPeriod / kMass;
    EXPECT_TRUE(test.stable(alpha, lo + 1e-9 * std::abs(lo)));
    EXPECT_FALSE(test.stable(alpha, lo - 1e-6 * std::abs(lo)));
    EXPECT_TRUE(test.stable(alpha, hi - 1e-9 * hi));
    EXPECT_FALSE(test.stable(alpha, hi + 1e-6 * hi));
    EXPECT_NEAR(accepted->first, range->first, 1e-9 * range->first);
    EXPECT_NEAR(accepted->second, range->second, 1e-9 * range->second);

    GainCheckPlant with_set = plant_with(1.0, low_pass_hz(20.0));
    with_set.mass_range = std::make_pair(0.22, kMass);
    with_set.mass_margin = 0.1;
    const GainChecker over_set(with_set);
    const auto set_accepted = over_set.damping_range(K, {kMass}, true);
    ASSERT_TRUE(set_accepted.has_value());
    EXPECT_GT(set_accepted->first, range->first);
    EXPECT_LT(set_accepted->second, range->second);
    EXPECT_TRUE(over_set.pair_is_stable(K, set_accepted->first * (1 + 1e-6), kMass));
    EXPECT_TRUE(over_set.pair_is_stable(K, set_accepted->second * (1 - 1e-6), kMass));
    EXPECT_FALSE(over_set.pair_is_stable(K, set_accepted->first * (1 - 1e-6), kMass));
    EXPECT_FALSE(over_set.pair_is_stable(K, set_accepted->second * (1 + 1e-6), kMass));
    // Beyond the main region's tip no B makes K stable.
    EXPECT_FALSE(checker.damping_range(1.01 * region.alpha_max() * kMass / (kPeriod * kPeriod), {kMass}).has_value());
}

// The noise figure is the estimator loop's (hapticopt::force_noise_std with the estimator); the Abbott-Okamura bound
// (backward difference only) is left out with another estimator, the describing function takes the estimator.
TEST(EstimatorChecks, EncoderEffectsUseTheEstimator) {
    const double q = 1e-5;
    const TuningPlant filtered = plant_with(1.0, window_of(3));
    TuningResult t = tune_wall(hapticopt::Criterion::CE2, filtered);
    predict_encoder_effects(t, filtered, q);
    ASSERT_TRUE(t.force_noise_std.has_value());
    const double expected = hapticopt::force_noise_std(to_hapticopt(filtered), hapticopt::WallGains{t.K, t.B}, q,
                                                       hapticopt::VelocityEstimator::moving_window(3));
    EXPECT_DOUBLE_EQ(*t.force_noise_std, expected);
    EXPECT_NE(*t.force_noise_std,
              hapticopt::force_noise_std(to_hapticopt(filtered), hapticopt::WallGains{t.K, t.B}, q));
    // At rest every estimate is 0, so the rest condition is the backward difference's; a count steps the window's
    // estimate by q / (3 T) on its first tick; the Abbott-Okamura bound models the backward difference only and
    // is not given; the cycle is hapticopt::predict_limit_cycle's with the window, at a push 20.5 counts deep.
    ASSERT_TRUE(t.chatter.has_value());
    EXPECT_FALSE(t.chatter->backward_difference);
    EXPECT_FALSE(t.chatter->abbott_okamura_passive);
    EXPECT_EQ(t.chatter->abbott_okamura_bound, 0.0);
    EXPECT_DOUBLE_EQ(t.chatter->count_kick, t.B * q / (3.0 * filtered.period));
    EXPECT_DOUBLE_EQ(t.chatter->friction_for_rest, t.K * q / 2.0);
    EXPECT_FALSE(t.chatter->rest_for_every_push);  // no Coulomb friction
    hapticopt::LimitCycleLoop loop{to_hapticopt(filtered), hapticopt::WallGains{t.K, t.B}, 0.0, q,
                                   (t.K + filtered.stiffness) * q * 20.5};
    loop.estimator = hapticopt::VelocityEstimator::moving_window(3);
    const hapticopt::LimitCyclePrediction cycle = hapticopt::predict_limit_cycle(loop);
    EXPECT_EQ(t.chatter->cycle_predicted, cycle.predicted && cycle.cycle.stable);
    EXPECT_TRUE(t.chatter->cycle_predicted);  // frictionless: the relay's cycle exists for this window wall
    EXPECT_DOUBLE_EQ(t.chatter->cycle_amplitude, cycle.cycle.amplitude);
    EXPECT_DOUBLE_EQ(t.chatter->cycle_frequency, cycle.cycle.frequency);
    const TuningPlant backward = plant_with(1.0, {});
    TuningResult b = tune_wall(hapticopt::Criterion::CE2, backward);
    predict_encoder_effects(b, backward, q);
    ASSERT_TRUE(b.chatter.has_value());
    EXPECT_TRUE(b.chatter->backward_difference);
    EXPECT_DOUBLE_EQ(b.chatter->count_kick, b.B * q / backward.period);
}

// The backward path is the paper's, unchanged: tune_wall equals hapticopt::optimal_wall bit for bit.
TEST(EstimatorChecks, TheBackwardPathIsOptimalWall) {
    const TuningPlant p = plant_with(1.0, {});
    const hapticopt::WallTuning w = hapticopt::optimal_wall(hapticopt::Criterion::CE2, to_hapticopt(p));
    const TuningResult t = tune_wall(hapticopt::Criterion::CE2, p);
    EXPECT_EQ(t.K, w.K);
    EXPECT_EQ(t.B, w.B);
    EXPECT_EQ(t.alpha_max, w.alpha_max);
    EXPECT_EQ(*t.cost, *w.cost);
}

}  // namespace estimator_checks_test
}  // namespace hapticd

namespace hapticd {
namespace estimator_checks_test {

// force_noise_budget: the auto-tuned wall minimises CE2 subject to sigma_F <= budget. With half the unconstrained
// optimum's sigma_F the budget is active: the wall is hapticopt::optimal_point_under_noise_budget's (g_max = budget
// T^2 / (m q)) scaled to the mass, its sigma_F (predict_encoder_effects, an independent Stein solve at the returned
// gains) is within the budget to the curve search's tolerance (1e-6 relative: Brent in log alpha to 1e-10 and the
// beta grid's refinement leave g_F = g_max to far better than that), and its cost is above the unconstrained one;
// with twice the unconstrained sigma_F the budget is slack and the wall is the unconstrained optimum.
TEST(EstimatorChecks, ForceNoiseBudgetBoundsTheTunedWall) {
    const double q = 1e-5;
    for (const VelocityEstimatorSpec& spec : {VelocityEstimatorSpec{}, low_pass_hz(50.0), window_of(3)}) {
        TuningPlant p = plant_with(1.0, spec);
        p.position_resolution = q;
        TuningResult free = tune_wall(hapticopt::Criterion::CE2, p);
        predict_encoder_effects(free, p, q);
        ASSERT_TRUE(free.force_noise_std.has_value());
        p.force_noise_budget = 0.5 * *free.force_noise_std;
        TuningResult tight = tune_wall(hapticopt::Criterion::CE2, p);
        const double g_max = *p.force_noise_budget * kPeriod * kPeriod / (kMass * q);
        const hapticopt::NoiseBudgetOptimum o = hapticopt::optimal_point_under_noise_budget(
            hapticopt::Criterion::CE2, normalized(1.0), to_hapticopt_estimator(spec, kPeriod), g_max);
        EXPECT_TRUE(o.budget_active);
        EXPECT_DOUBLE_EQ(tight.alpha, o.alpha);
        EXPECT_DOUBLE_EQ(tight.beta, o.beta);
        EXPECT_DOUBLE_EQ(tight.K, o.alpha * kMass / (kPeriod * kPeriod));
        ASSERT_TRUE(tight.cost.has_value());
        EXPECT_GT(*tight.cost, *free.cost);
        predict_encoder_effects(tight, p, q);
        ASSERT_TRUE(tight.force_noise_std.has_value());
        EXPECT_LE(*tight.force_noise_std, *p.force_noise_budget * (1 + 1e-6)) << to_string(spec);
        EXPECT_GT(*tight.force_noise_std, *p.force_noise_budget * 0.99) << to_string(spec);  // the budget binds
        p.force_noise_budget = 2.0 * *free.force_noise_std;
        const TuningResult slack = tune_wall(hapticopt::Criterion::CE2, p);
        EXPECT_NEAR(slack.K, free.K, 1e-9 * free.K) << to_string(spec);
        EXPECT_NEAR(slack.B, free.B, 1e-9 * free.B) << to_string(spec);
    }
}

// amax, OV and CE2+OV under a budget (hapticopt::optimal_point_under_noise_budget): each wall's sigma_F, from
// predict_encoder_effects (an independent Stein solve at the returned physical gains), is within the budget
// (1e-9 relative: the band's ends are bisected to 1e-13 of the stable interval on the feasible side); amax is the
// stiffest wall that meets it, so its sigma_F is the budget (to the bisection in log alpha, 1e-10: 1e-6 relative
// leaves room for g_F's slope there) and it is rendered as found, without amax's back-off. The budgets bind: half
// of CE2's sigma_F for amax and OV, 0.9 of the unconstrained CE2+OV's for CE2+OV.
TEST(EstimatorChecks, EveryCriterionMeetsTheForceNoiseBudget) {
    const double q = 1e-5;
    for (const VelocityEstimatorSpec& spec : {VelocityEstimatorSpec{}, window_of(3)}) {
        TuningPlant p = plant_with(1.0, spec);
        p.position_resolution = q;
        for (const hapticopt::Criterion c :
             {hapticopt::Criterion::AlphaMax, hapticopt::Criterion::Overshoot, hapticopt::Criterion::CE2_OV}) {
            const std::string criterion(hapticopt::to_string(c));
            const bool on_curve = c == hapticopt::Criterion::CE2_OV;
            TuningResult free = tune_wall(on_curve ? c : hapticopt::Criterion::CE2, p);
            predict_encoder_effects(free, p, q);
            ASSERT_TRUE(free.force_noise_std.has_value());
            p.force_noise_budget = (on_curve ? 0.9 : 0.5) * *free.force_noise_std;
            TuningResult t = tune_wall(c, p);
            EXPECT_TRUE(t.force_noise_budget_active) << criterion;
            predict_encoder_effects(t, p, q);
            ASSERT_TRUE(t.force_noise_std.has_value()) << criterion;
            EXPECT_LE(*t.force_noise_std, *p.force_noise_budget * (1 + 1e-9)) << criterion << " " << to_string(spec);
            if (c == hapticopt::Criterion::AlphaMax) {
                EXPECT_GT(*t.force_noise_std, *p.force_noise_budget * (1 - 1e-6)) << to_string(spec);
            }
            if (on_curve) {
                EXPECT_LT(t.K, free.K) << to_string(spec);
            }
            EXPECT_NO_THROW((void)check_explicit_gains(t.K, t.B, c, p)) << criterion;
            p.force_noise_budget.reset();
        }
    }
    TuningPlant p = plant_with(1.0, {});
    p.force_noise_budget = 0.1;
    p.position_resolution = 0.0;
    try {
        (void)tune_wall(hapticopt::Criterion::CE1, p);
        ADD_FAILURE() << "a budget without an encoder step accepted";
    } catch (const StartupError& e) {
        EXPECT_EQ(e.kind(), ErrorKind::InvalidParameter);
        EXPECT_NE(std::string(e.what()).find("position_resolution"), std::string::npos) << e.what();
    }
    // A budget no stable gains meet: an error naming the key and what is accepted.
    p.position_resolution = 1e-5;
    p.force_noise_budget = 1e-9;
    try {
        (void)tune_wall(hapticopt::Criterion::CE2, p);
        ADD_FAILURE() << "an unmeetable budget accepted";
    } catch (const StartupError& e) {
        EXPECT_EQ(e.kind(), ErrorKind::InvalidParameter);
        EXPECT_NE(std::string(e.what()).find("a larger force_noise_budget"), std::string::npos) << e.what();
    }
    // The scene objects' criterion gains keep the budget: at the profile's mass the config wall's optimum, and for a
    // lighter mass the same normalised gains, whose sigma_F = (m q / T^2) g_F is then smaller.
    GainCheckPlant gp = plant_with(1.0, {});
    gp.position_resolution = 1e-5;
    TuningResult plain = tune_wall(hapticopt::Criterion::CE2, plant_with(1.0, {}));
    predict_encoder_effects(plain, plant_with(1.0, {}), gp.position_resolution);
    ASSERT_TRUE(plain.force_noise_std.has_value());
    gp.force_noise_budget = 0.5 * *plain.force_noise_std;
    GainChecker checker(gp);
    const TuningResult wall = tune_wall(hapticopt::Criterion::CE2, gp);
    EXPECT_TRUE(wall.force_noise_budget_active);
    for (const double m : {kMass, 0.5 * kMass}) {
        const CriterionGains gains = checker.criterion_gains(hapticopt::Criterion::CE2, m);
        EXPECT_NEAR(gains.K, wall.K * m / kMass, 1e-12 * wall.K) << m;
        EXPECT_NEAR(gains.B, wall.B * m / kMass, 1e-12 * wall.B) << m;
        TuningPlant at = gp;
        at.mass = m;
        TuningResult judged;
        judged.K = gains.K;
        judged.B = gains.B;
        predict_encoder_effects(judged, at, gp.position_resolution);
        ASSERT_TRUE(judged.force_noise_std.has_value());
        EXPECT_LE(*judged.force_noise_std, *gp.force_noise_budget * (m / kMass) * (1 + 1e-9)) << m;
    }
    EXPECT_LT(checker.criterion_gains(hapticopt::Criterion::CE2, kMass).K, plain.K);
    // An unmeetable budget: an error naming the key (the server refuses the object with it).
    gp.force_noise_budget = 1e-9;
    GainChecker unmeetable(gp);
    try {
        (void)unmeetable.criterion_gains(hapticopt::Criterion::CE2, kMass);
        ADD_FAILURE() << "an unmeetable budget accepted for an object";
    } catch (const std::exception& e) {
        EXPECT_NE(std::string(e.what()).find("force_noise_budget"), std::string::npos) << e.what();
    }
}

}  // namespace estimator_checks_test
}  // namespace hapticd
