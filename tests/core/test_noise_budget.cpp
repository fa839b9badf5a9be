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
    for (const Criterion c : {Criterion::AlphaMax, Criterion::Overshoot, Criterion::CE2_OV}) {
        try {
            optimal_point_under_noise_budget(c, plant, e, 1e-3);
            ADD_FAILURE() << to_string(c) << " accepted";
        } catch (const InvalidParameter& x) {
            EXPECT_EQ(x.parameter(), "criterion") << x.what();
        }
    }
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
    const auto [code3, refused] =
        run_budget_command({"optimum", "--criterion", "CE2+OV", "--noise-budget", "0.002", "--json"});
    EXPECT_EQ(code3, int{kUsage});
}

}  // namespace
}  // namespace cli
}  // namespace hapticopt
