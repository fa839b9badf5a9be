// SPDX-License-Identifier: Apache-2.0
// The optimum under a force-noise budget (include/hapticopt/noise_budget.hpp) and the CLI's --noise-budget
// and --force-noise-budget (apps/hapticopt/optimum_command.cpp, run in-process).
//
// The check that can fail: no point of a fine grid of the main stable region that meets the budget has a
// lower cost than the constrained optimum. The grid's costs are exact (the same closed form); the optimum is
// the exact minimum on the curve g_F = g_max up to Brent's tolerance (a relative cost error of order
// 1e-16 at a smooth minimum) and the bisection in beta to 1e-13 of the interval (|dC/dbeta| x 1e-13 (hi - lo),
// below 1e-9 relative here): 1e-9 relative.
#include <gtest/gtest.h>

#include <cmath>
#include <iostream>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include <hapticopt/hapticopt.hpp>

#include "cli_output.hpp"
#include "commands.hpp"

namespace hapticopt {
namespace {

struct BudgetCase {
    const char* name;
    VelocityEstimator estimator;
    double delay;
    double fraction;  ///< the budget as a fraction of g_F at the unconstrained optimum
};

void PrintTo(const BudgetCase& c, std::ostream* os) { *os << c.name; }

std::vector<BudgetCase> budget_cases() {
    return {{"backward_d1_half", VelocityEstimator::backward_difference(), 1, 0.5},
            {"lowpass002_d1_half", VelocityEstimator::low_pass(0.02), 1, 0.5},
            {"lowpass002_d1_tenth", VelocityEstimator::low_pass(0.02), 1, 0.1},
            {"window15_d1_third", VelocityEstimator::moving_window(15), 1, 1.0 / 3},
            {"lowpass01_d0_half", VelocityEstimator::low_pass(0.1), 0, 0.5}};
}

class NoiseBudgetGrid : public ::testing::TestWithParam<BudgetCase> {};

TEST_P(NoiseBudgetGrid, MeetsTheBudgetAndNoGridPointIsBetter) {
    const BudgetCase& c = GetParam();
    const NormalizedPlant plant{0, 0, c.delay};
    const SampledPlant<double> sampled(plant);
    const EstimatorOptimum free = optimal_point(Criterion::CE2, plant, c.estimator);
    const double g_free = estimator_force_noise_gain(sampled, c.estimator, free.alpha, free.beta);
    const double budget = c.fraction * g_free;
    const NoiseBudgetOptimum o = optimal_point_under_noise_budget(Criterion::CE2, plant, c.estimator, budget);
    ASSERT_TRUE(o.budget_active);
    EXPECT_LE(o.force_noise_gain, budget);               // the bisection keeps the feasible side
    EXPECT_GE(o.force_noise_gain, budget * (1 - 1e-9));  // and the budget binds (the optimum is on the curve)
    EXPECT_GT(o.cost, *free.cost);                       // a binding constraint costs something
    EXPECT_NEAR(o.force_noise_gain, force_noise_gain(plant, {o.alpha, o.beta}, c.estimator), 1e-12 * budget);
    // A 150 x 150 grid of the main region: alpha cell centres over (0, alpha_max), beta over its stable interval.
    const EstimatorStabilityRegion region(plant, c.estimator);
    const int n = 150;
    double best_feasible = HUGE_VAL;
    int feasible = 0;
    for (int i = 0; i < n; ++i) {
        const double a = region.alpha_max() * (i + 0.5) / n;
        const auto [lo, hi] = region.beta_interval(a);
        for (int j = 0; j < n; ++j) {
            const double b = lo + (hi - lo) * (j + 0.5) / n;
            if (!(estimator_force_noise_gain(sampled, c.estimator, a, b) <= budget)) continue;
            ++feasible;
            best_feasible = std::min(best_feasible, estimator_energy_costs(sampled, c.estimator, a, b).ce2);
        }
    }
    ASSERT_GT(feasible, 10) << "the grid does not resolve the feasible set";
    EXPECT_GE(best_feasible, o.cost * (1 - 1e-9)) << c.name;
    // A fine local grid around the optimum (+-2 % in alpha and beta, 61 x 61, stable points only): the same.
    double best_local = HUGE_VAL;
    for (int i = -30; i <= 30; ++i) {
        for (int j = -30; j <= 30; ++j) {
            const double a = o.alpha * (1 + 0.02 * i / 30), b = o.beta * (1 + 0.02 * j / 30);
            if (!region.stable(a, b) || !(estimator_force_noise_gain(sampled, c.estimator, a, b) <= budget)) continue;
            best_local = std::min(best_local, estimator_energy_costs(sampled, c.estimator, a, b).ce2);
        }
    }
    EXPECT_GE(best_local, o.cost * (1 - 1e-9)) << c.name;
    EXPECT_LE(best_local, o.cost * 1.01) << c.name;  // the local grid has feasible points next to the optimum
    std::cout << c.name << ": budget " << budget << " cost " << o.cost << " (unconstrained " << *free.cost
              << "), best of " << feasible << " feasible grid points " << best_feasible << ", local grid " << best_local
              << '\n';
}

INSTANTIATE_TEST_SUITE_P(Estimators, NoiseBudgetGrid, ::testing::ValuesIn(budget_cases()),
                         [](const ::testing::TestParamInfo<BudgetCase>& info) { return std::string(info.param.name); });

TEST(NoiseBudget, LooseBudgetIsTheUnconstrainedOptimum) {
    const NormalizedPlant plant{0, 0, 1};
    for (const VelocityEstimator& e : {VelocityEstimator::backward_difference(), VelocityEstimator::low_pass(0.02),
                                       VelocityEstimator::moving_window(15)}) {
        const EstimatorOptimum free = optimal_point(Criterion::CE1, plant, e);
        const NoiseBudgetOptimum o = optimal_point_under_noise_budget(Criterion::CE1, plant, e, 1e3);
        EXPECT_FALSE(o.budget_active);
        EXPECT_EQ(o.alpha, free.alpha);
        EXPECT_EQ(o.beta, free.beta);
        EXPECT_EQ(o.cost, *free.cost);
        EXPECT_LE(o.force_noise_gain, 1e3);
    }
}

TEST(NoiseBudget, BadBudgetsAndCriteriaNameTheParameter) {
    const NormalizedPlant plant{0, 0, 1};
    const VelocityEstimator e = VelocityEstimator::low_pass(0.02);
    for (const double budget : {1e-12, 0.0, -1.0, std::nan(""), HUGE_VAL}) {
        try {
            optimal_point_under_noise_budget(Criterion::CE2, plant, e, budget);
            ADD_FAILURE() << budget << " accepted";
        } catch (const InvalidParameter& x) {
            EXPECT_EQ(x.parameter(), "noise_budget") << x.what();
        }
    }
    // A budget no stable gains meet: every criterion names the budget.
    for (const Criterion c : {Criterion::AlphaMax, Criterion::Overshoot, Criterion::CE2_OV, Criterion::CE2}) {
        try {
            optimal_point_under_noise_budget(c, plant, e, 1e-14);
            ADD_FAILURE() << to_string(c) << " accepted";
        } catch (const InvalidParameter& x) {
            EXPECT_EQ(x.parameter(), "noise_budget") << x.what();
        }
    }
}

// amax, OV and CEx+OV under a budget: the largest alpha where the criterion's property holds on the budget's band.
// What can fail: (1) the returned point meets the budget (an independent Stein solve, force_noise_gain) and has no
// overshoot (estimator_overshoot within the tolerance) where the criterion asks for none; (2) just above it,
// alpha (1 + 1e-6) (the bisection stops at 1e-10 in log alpha, so this is 10^4 tolerances beyond), no beta of a
// 400-point grid over the stable interval has the property: for amax none meets the budget; for OV none meets the
// budget without overshoot; for CEx+OV the band's C_Ex minimum (grid and Brent, 64 cells instead of the search's 16)
// overshoots. The budgets bind (below).
struct LargestAlphaCase {
    const char* name;
    Criterion criterion;
    VelocityEstimator estimator;
    double delay;
};

void PrintTo(const LargestAlphaCase& c, std::ostream* os) { *os << c.name; }

class NoiseBudgetLargestAlpha : public ::testing::TestWithParam<LargestAlphaCase> {};

TEST_P(NoiseBudgetLargestAlpha, HoldsAtThePointAndNowhereJustAbove) {
    const LargestAlphaCase& c = GetParam();
    const NormalizedPlant plant{0, 0, c.delay};
    const SampledPlant<double> sampled(plant);
    // CEx+OV: 0.9 of g_F at the unconstrained CEx+OV point (a budget that cuts the CEx curve everywhere leaves
    // only band edges, which overshoot: no point, an error naming the budget); the others: half of CE2's.
    const bool on_curve = energy_index(c.criterion).has_value() && requires_no_overshoot(c.criterion);
    const EstimatorOptimum free = optimal_point(on_curve ? c.criterion : Criterion::CE2, plant, c.estimator);
    const double budget =
        (on_curve ? 0.9 : 0.5) * estimator_force_noise_gain(sampled, c.estimator, free.alpha, free.beta);
    const NoiseBudgetOptimum o = optimal_point_under_noise_budget(c.criterion, plant, c.estimator, budget);
    const EstimatorStabilityRegion region(plant, c.estimator);
    if (on_curve) {
        EXPECT_TRUE(o.budget_active);
        EXPECT_LT(o.alpha, free.alpha);  // the budget moves the point to a softer wall
    }
    OvershootOptions ov;  // the search's tolerance, 1e-12
    ASSERT_GT(o.alpha, 0.0);
    ASSERT_LT(o.alpha, region.alpha_max());
    EXPECT_TRUE(region.stable(o.alpha, o.beta));
    EXPECT_LE(force_noise_gain(plant, {o.alpha, o.beta}, c.estimator), budget);
    if (c.criterion == Criterion::AlphaMax) {
        EXPECT_TRUE(o.budget_active);
        EXPECT_DOUBLE_EQ(o.cost, o.alpha);
    } else {
        EXPECT_TRUE(estimator_overshoot(sampled, c.estimator, o.alpha, o.beta, ov).within_tolerance) << c.name;
    }
    const double above = o.alpha * (1 + 1e-6);
    const auto [lo, hi] = region.beta_interval(above);
    const int n = 400;
    if (c.criterion == Criterion::CE0_OV || c.criterion == Criterion::CE2_OV) {
        const int index = *energy_index(c.criterion);
        auto noise = [&](double b) { return estimator_force_noise_gain(sampled, c.estimator, above, b); };
        auto cost = [&](double a, double b) {
            if (!(noise(b) <= budget)) return HUGE_VAL;
            const EnergyCosts e = estimator_energy_costs(sampled, c.estimator, a, b);
            return index == 0 ? e.ce0 : e.ce2;
        };
        // The band is where the cost is finite: the 64-cell minimum over the whole stable interval.
        auto range = [&](double) { return std::pair<double, double>{lo, hi}; };
        const detail::ScalarMinimum m = detail::minimize_over_beta(cost, range, above, 64);
        ASSERT_TRUE(std::isfinite(m.value)) << c.name << ": the band is empty just above the point";
        EXPECT_FALSE(estimator_overshoot(sampled, c.estimator, above, m.x, ov).within_tolerance) << c.name;
    } else {
        int with_property = 0;
        for (int j = 0; j < n; ++j) {
            const double b = lo + (hi - lo) * (j + 0.5) / n;
            if (!(estimator_force_noise_gain(sampled, c.estimator, above, b) <= budget)) continue;
            if (c.criterion == Criterion::AlphaMax ||
                estimator_overshoot(sampled, c.estimator, above, b, ov).within_tolerance) {
                ++with_property;
            }
        }
        EXPECT_EQ(with_property, 0) << c.name;
    }
    std::cout << c.name << ": budget " << budget << " alpha " << o.alpha << " (alpha_max " << region.alpha_max()
              << ") beta " << o.beta << " cost " << o.cost << " g_F " << o.force_noise_gain << '\n';
}

INSTANTIATE_TEST_SUITE_P(
    Criteria, NoiseBudgetLargestAlpha,
    ::testing::Values(
        LargestAlphaCase{"amax_window15_d6", Criterion::AlphaMax, VelocityEstimator::moving_window(15), 6},
        LargestAlphaCase{"amax_lowpass002_d1", Criterion::AlphaMax, VelocityEstimator::low_pass(0.02), 1},
        LargestAlphaCase{"ov_window15_d1", Criterion::Overshoot, VelocityEstimator::moving_window(15), 1},
        LargestAlphaCase{"ov_backward_d1", Criterion::Overshoot, VelocityEstimator::backward_difference(), 1},
        LargestAlphaCase{"ce2ov_window15_d6", Criterion::CE2_OV, VelocityEstimator::moving_window(15), 6},
        LargestAlphaCase{"ce0ov_lowpass01_d0", Criterion::CE0_OV, VelocityEstimator::low_pass(0.1), 0}),
    [](const ::testing::TestParamInfo<LargestAlphaCase>& info) { return std::string(info.param.name); });

// With a budget no point of the search reaches, the CEx+OV search is the unconstrained one's definition: it agrees
// with optimal_point's CEx+OV point (a linear scan from alpha_max and bisection to 1e-10 alpha_max, where this one
// scans in log alpha). Both stop where C_OV along the curve crosses 1e-12; the curve's beta is found by each to
// ~1e-12 of its interval and C_OV rises steeply there, so the two crossings agree to 1e-6 relative in alpha.
// estimator_overshoot_point is the OV search with the stable interval as the band: no budget, the same point as a
// budget that never binds.
TEST(NoiseBudget, TheLargestAlphaSearchesWithoutABindingBudget) {
    const NormalizedPlant plant{0, 0, 1};
    for (const VelocityEstimator& e : {VelocityEstimator::moving_window(15), VelocityEstimator::low_pass(0.02)}) {
        const EstimatorOptimum free = optimal_point(Criterion::CE2_OV, plant, e);
        const NoiseBudgetOptimum loose = optimal_point_under_noise_budget(Criterion::CE2_OV, plant, e, 1e3);
        EXPECT_NEAR(loose.alpha, free.alpha, 1e-6 * free.alpha);
        EXPECT_NEAR(loose.cost, *free.cost, 1e-5 * *free.cost);
        EXPECT_FALSE(loose.budget_active);
        const NoiseBudgetOptimum ov = estimator_overshoot_point(plant, e);
        const NoiseBudgetOptimum ov_loose = optimal_point_under_noise_budget(Criterion::Overshoot, plant, e, 1e3);
        EXPECT_EQ(ov.alpha, ov_loose.alpha);
        EXPECT_FALSE(ov.budget_active);
        EXPECT_LE(ov.cost, 1e-12);
        // The OV point is at least as stiff as CE2+OV's (the latter restricts beta to the CE2 curve).
        EXPECT_GE(ov.alpha, loose.alpha * (1 - 1e-9));
    }
    // The backward difference's OV point of optimum.hpp (the paper's Table III/IV method): the same largest alpha
    // (its bisection stops at 1e-10 alpha_max, this one at 1e-10 in log alpha; both to the 1e-12 tolerance's
    // crossing, which the grid of 16 or 3 betas finds to 1e-6 relative).
    const Optimum paper = optimal_point(Criterion::Overshoot, plant);
    const NoiseBudgetOptimum ours = estimator_overshoot_point(plant, VelocityEstimator::backward_difference());
    EXPECT_NEAR(ours.alpha, paper.alpha, 1e-6 * paper.alpha);
    NoiseBudgetOptions bad;
    bad.unconstrained.overshoot_tolerance = 0;
    EXPECT_THROW(estimator_overshoot_point(plant, VelocityEstimator::low_pass(0.02), bad), InvalidParameter);
}

TEST(NoiseBudget, ParetoFrontIsMonotone) {
    const NormalizedPlant plant{0, 0, 1};
    const VelocityEstimator e = VelocityEstimator::low_pass(0.02);
    const std::vector<double> budgets{1e-4, 3e-4, 1e-3, 3e-3, 1e-2};
    const std::vector<NoiseBudgetOptimum> front = noise_pareto_front(Criterion::CE2, plant, e, budgets);
    ASSERT_EQ(front.size(), budgets.size());
    for (std::size_t i = 0; i < front.size(); ++i) {
        EXPECT_LE(front[i].force_noise_gain, budgets[i]);
        // A looser budget admits every point of a tighter one: its least cost is not higher (to the optimiser's 1e-9).
        if (i > 0) {
            EXPECT_LE(front[i].cost, front[i - 1].cost * (1 + 1e-9));
        }
    }
    EXPECT_FALSE(front.back().budget_active);  // 1e-2 > g_F of the unconstrained optimum (5.4e-3)
}

TEST(NoiseBudget, JointOverTheWindowIsTheBestCandidate) {
    const NormalizedPlant plant{0, 0, 1};
    std::vector<VelocityEstimator> windows;
    for (int n = 1; n <= 6; ++n) windows.push_back(VelocityEstimator::moving_window(n));
    const double budget = 2e-3;
    const NoiseBudgetOptimum best = optimal_estimator_under_noise_budget(Criterion::CE2, plant, windows, budget);
    EXPECT_LE(best.force_noise_gain, budget);
    for (const VelocityEstimator& w : windows) {
        EXPECT_LE(best.cost, optimal_point_under_noise_budget(Criterion::CE2, plant, w, budget).cost) << w.window;
    }
    EXPECT_THROW(optimal_estimator_under_noise_budget(Criterion::CE2, plant, {}, budget), InvalidParameter);
}

TEST(NoiseBudget, JointOverTheLowPassCutoffBeatsEveryFixedCutoff) {
    const NormalizedPlant plant{0, 0, 1};
    const double budget = 3e-3;
    const NoiseBudgetOptimum best = optimal_lowpass_under_noise_budget(Criterion::CE2, plant, 0.005, 0.2, budget);
    ASSERT_EQ(best.estimator.kind, VelocityEstimatorKind::lowpass);
    EXPECT_GE(best.estimator.cutoff, 0.005);
    EXPECT_LE(best.estimator.cutoff, 0.2);
    EXPECT_LE(best.force_noise_gain, budget);
    // Cut-offs off the scan's points: none is cheaper (the inner optimum's 1e-9 relative).
    for (const double nu : {0.007, 0.013, 0.02, 0.03, 0.05, 0.1, 0.17}) {
        const NoiseBudgetOptimum o =
            optimal_point_under_noise_budget(Criterion::CE2, plant, VelocityEstimator::low_pass(nu), budget);
        EXPECT_LE(best.cost, o.cost * (1 + 1e-9)) << nu;
    }
    std::cout << "lowpass joint, budget " << budget << ": nu " << best.estimator.cutoff << " cost " << best.cost
              << " alpha " << best.alpha << " beta " << best.beta << '\n';
    for (const auto& [lo, hi] : std::vector<std::pair<double, double>>{{0.0, 0.1}, {0.1, 0.05}}) {
        EXPECT_THROW(optimal_lowpass_under_noise_budget(Criterion::CE2, plant, lo, hi, budget), InvalidParameter);
    }
}

}  // namespace

namespace cli {
namespace {

std::pair<int, nlohmann::json> run_budget_command(std::vector<std::string> args) {
    CLI::App app;
    const CommandRunner run = add_optimum_command(app);
    std::vector<const char*> argv{"hapticopt"};
    for (const std::string& a : args) argv.push_back(a.c_str());
    app.parse(static_cast<int>(argv.size()), argv.data());
    std::ostringstream captured;
    std::streambuf* old = std::cout.rdbuf(captured.rdbuf());
    const int code = run();
    std::cout.rdbuf(old);
    return {code, captured.str().empty() ? nlohmann::json() : nlohmann::json::parse(captured.str())};
}

TEST(NoiseBudgetCli, NormalisedAndPhysicalBudgets) {
    const auto [code, out] = run_budget_command(
        {"optimum", "--criterion", "CE2", "--velocity", "lowpass:0.02", "--noise-budget", "0.002", "--json"});
    ASSERT_EQ(code, 0);
    EXPECT_EQ(out["noise_budget"].get<double>(), 0.002);
    EXPECT_LE(out["force_noise_gain"].get<double>(), 0.002);
    EXPECT_TRUE(out["budget_active"].get<bool>());
    const NoiseBudgetOptimum o =
        optimal_point_under_noise_budget(Criterion::CE2, {0, 0, 0}, VelocityEstimator::low_pass(0.02), 0.002);
    EXPECT_EQ(out["alpha"].get<double>(), o.alpha);
    EXPECT_EQ(out["cost"].get<double>(), o.cost);
    // 0.3 kg, 1 kHz, q = 20 um, sigma_F <= 0.05 N: g_max = 0.05 x 1e-6 / (0.3 x 2e-5) = 8.33e-3.
    const auto [code2, phys] = run_budget_command(
        {"optimum", "--criterion", "CE2", "--mass", "0.3", "--period", "0.001", "--time-delay", "0.001", "--velocity",
         "lowpass:20Hz", "--force-noise-budget", "0.05", "--position-resolution", "2e-5", "--json"});
    ASSERT_EQ(code2, 0);
    EXPECT_NEAR(phys["noise_budget"].get<double>(), 0.05 * 1e-6 / (0.3 * 2e-5), 1e-15);
    EXPECT_LE(phys["force_noise_std"].get<double>(), 0.05 * (1 + 1e-12));
    EXPECT_GT(phys["K"].get<double>(), 0);
    EXPECT_GT(phys["B"].get<double>(), 0);
    // Every step criterion takes a budget (CE2+OV: its point meets 0.5 here, so it is the unconstrained one); the
    // collision criteria do not.
    const auto [code3, ce2ov] =
        run_budget_command({"optimum", "--criterion", "CE2+OV", "--noise-budget", "0.5", "--json"});
    ASSERT_EQ(code3, 0);
    EXPECT_LE(ce2ov["force_noise_gain"].get<double>(), 0.5);
    EXPECT_EQ(ce2ov["alpha"].get<double>(),
              optimal_point_under_noise_budget(Criterion::CE2_OV, {0, 0, 0}, VelocityEstimator{}, 0.5).alpha);
    const auto [code4, refused] =
        run_budget_command({"optimum", "--criterion", "CI2", "--noise-budget", "0.002", "--json"});
    EXPECT_EQ(code4, int{kUsage});
}

}  // namespace
}  // namespace cli
}  // namespace hapticopt
