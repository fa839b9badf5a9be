// SPDX-License-Identifier: Apache-2.0
// The hapticopt CLI's --velocity option and the JSON fields it adds (apps/hapticopt: cli_output.cpp,
// cost_command.cpp, optimum_command.cpp), run in-process.
#include <gtest/gtest.h>

#include <cmath>
#include <iostream>
#include <sstream>
#include <string>
#include <vector>

#include <hapticopt/estimator_impulse.hpp>
#include <hapticopt/estimator_passivity.hpp>
#include <hapticopt/noise_budget.hpp>
#include <hapticopt/robust_optimum.hpp>
#include <hapticopt/stability_region.hpp>

#include "cli_output.hpp"
#include "commands.hpp"

namespace hapticopt::cli {
namespace {

VelocityEstimator parse_velocity_text(const std::string& text, double period) {
    VelocityOption o;
    o.text = text;
    return o.parse(period);
}

/// Runs one subcommand with `args` and returns (exit code, stdout as JSON).
std::pair<int, nlohmann::json> run_velocity_command(CommandRunner (*add)(CLI::App&), std::vector<std::string> args) {
    CLI::App app;
    const CommandRunner run = add(app);
    std::vector<const char*> argv{"hapticopt"};
    for (const std::string& a : args) argv.push_back(a.c_str());
    app.parse(static_cast<int>(argv.size()), argv.data());
    std::ostringstream captured;
    // std::cout writes to `captured` until this returns or throws (a throwing command must not leave it there).
    struct Restore {
        std::streambuf* old;
        ~Restore() { std::cout.rdbuf(old); }
    } restore{std::cout.rdbuf(captured.rdbuf())};
    const int code = run();
    return {code, captured.str().empty() ? nlohmann::json() : nlohmann::json::parse(captured.str())};
}

TEST(VelocityCli, ParsesEveryForm) {
    EXPECT_EQ(parse_velocity_text("backward", 0).kind, VelocityEstimatorKind::backward);
    const VelocityEstimator lp = parse_velocity_text("lowpass:0.02", 0);
    EXPECT_EQ(lp.kind, VelocityEstimatorKind::lowpass);
    EXPECT_EQ(lp.cutoff, 0.02);
    // 20 Hz at T = 1 ms: nu = f_c T = 0.02 (to the rounding of one product).
    EXPECT_NEAR(parse_velocity_text("lowpass:20Hz", 0.001).cutoff, 0.02, 1e-17);
    const VelocityEstimator w = parse_velocity_text("window:15", 0);
    EXPECT_EQ(w.kind, VelocityEstimatorKind::window);
    EXPECT_EQ(w.window, 15);
    EXPECT_EQ(velocity_json(w).dump(), R"({"kind":"window","window":15})");
    EXPECT_EQ(velocity_json(lp).dump(), R"({"cutoff":0.02,"kind":"lowpass"})");
}

TEST(VelocityCli, RefusesBadValuesNamingTheRange) {
    for (const auto& [text, period, expected] : std::vector<std::tuple<std::string, double, std::string>>{
             {"lowpass:20Hz", 0.0, "--period T > 0"},
             {"lowpass:0", 0.0, "finite and > 0"},
             {"lowpass:-1", 0.0, "finite and > 0"},
             {"lowpass:abc", 0.0, "lowpass:NU with NU > 0"},
             {"window:0", 0.0, "1 <= N <= 1000"},
             {"window:1001", 0.0, "1 <= N <= 1000"},
             {"window:1.5", 0.0, "integer 1 <= N <= 1000"},
             {"forward", 0.0, "backward, lowpass:NU, lowpass:FHz or window:N"}}) {
        try {
            parse_velocity_text(text, period);
            ADD_FAILURE() << text << " accepted";
        } catch (const InvalidParameter& e) {
            EXPECT_NE(std::string(e.what()).find(expected), std::string::npos) << text << ": " << e.what();
        }
    }
}

TEST(VelocityCli, CostReportsEstimatorAndNoise) {
    const auto [code, out] = run_velocity_command(
        add_cost_command, {"cost", "--alpha", "0.0046", "--beta", "0.107", "--delay", "1", "--velocity", "lowpass:20Hz",
                           "--period", "0.001", "--mass", "0.3", "--position-resolution", "2e-5", "--json"});
    ASSERT_EQ(code, 0);
    EXPECT_EQ(out["velocity_estimator"]["kind"], "lowpass");
    EXPECT_TRUE(out["stable"].get<bool>());
    const double g = force_noise_gain({0, 0, 1}, {0.0046, 0.107}, VelocityEstimator::low_pass(0.02));
    EXPECT_NEAR(out["force_noise_gain"].get<double>(), g, 1e-9 * g);
    EXPECT_NEAR(out["force_noise_std"].get<double>(), 0.3 * 2e-5 / 1e-6 * g, 1e-9 * g);
    EXPECT_EQ(out["OV"].get<double>(), overshoot({0, 0, 1}, {0.0046, 0.107}, VelocityEstimator::low_pass(0.02)).value);
    const ImpulseCosts ic = impulse_costs({0, 0, 1}, {0.0046, 0.107}, VelocityEstimator::low_pass(0.02));
    EXPECT_EQ(out["CI0"].get<double>(), ic.ci0);
    EXPECT_EQ(out["CI2"].get<double>(), ic.ci2);
    EXPECT_EQ(out["passivity_margin"].get<double>(),
              passivity_margin({0, 0, 1}, {0.0046, 0.107}, VelocityEstimator::low_pass(0.02)));
    // The paper's C_E2 optimum at d = 0 with the 20 Hz low-pass: unstable, costs and noise null.
    const auto [code2, unstable] = run_velocity_command(
        add_cost_command, {"cost", "--alpha", "0.2474", "--beta", "0.7445", "--velocity", "lowpass:0.02", "--json"});
    ASSERT_EQ(code2, 0);
    EXPECT_FALSE(unstable["stable"].get<bool>());
    EXPECT_TRUE(unstable["CE2"].is_null());
    EXPECT_TRUE(unstable["force_noise_gain"].is_null());
    // The backward default: the existing output plus the new fields.
    const auto [code3, backward] = run_velocity_command(
        add_cost_command, {"cost", "--alpha", "0.0582", "--beta", "0.3796", "--delay", "1", "--json"});
    ASSERT_EQ(code3, 0);
    EXPECT_EQ(backward["velocity_estimator"]["kind"], "backward");
    EXPECT_FALSE(backward["OV"].is_null());
}

TEST(VelocityCli, OptimumWithEstimator) {
    const auto [code, out] = run_velocity_command(
        add_optimum_command, {"optimum", "--criterion", "CE2", "--velocity", "window:15", "--json"});
    ASSERT_EQ(code, 0);
    EXPECT_EQ(out["velocity_estimator"]["window"], 15);
    EXPECT_LT(out["alpha"].get<double>(), out["alpha_max"].get<double>());
    EXPECT_EQ(out["stable_islands"].size(), 1u);
    // OV with the estimator: estimator_overshoot_point's point (no overshoot there). Window 5 (0.08 s in a release
    // build, against 0.8 s for window 15 and nine times that under ASan): the CLI's plumbing is the same.
    const auto [code2, ov_point] =
        run_velocity_command(add_optimum_command, {"optimum", "--criterion", "OV", "--velocity", "window:5", "--json"});
    ASSERT_EQ(code2, 0);
    const NoiseBudgetOptimum expected_ov = estimator_overshoot_point({0, 0, 0}, VelocityEstimator::moving_window(5));
    EXPECT_EQ(ov_point["alpha"].get<double>(), expected_ov.alpha);
    EXPECT_EQ(ov_point["beta"].get<double>(), expected_ov.beta);
    EXPECT_LE(ov_point["cost"].get<double>(), 1e-12);
    const auto [code3, ov] = run_velocity_command(
        add_optimum_command, {"optimum", "--criterion", "CE2+OV", "--velocity", "lowpass:0.1", "--json"});
    ASSERT_EQ(code3, 0);
    EXPECT_LT(ov["alpha"].get<double>(), ov["alpha_max"].get<double>());
    EXPECT_FALSE(ov["passivity_margin"].is_null());
    // The collision criteria with the estimator: the library's optimum, reported with its penetration and margin
    // (window 5: 0.3 s in a release build, against 2 s for window 15).
    const auto [code4, ci] = run_velocity_command(
        add_optimum_command,
        {"optimum", "--criterion", "CI2", "--velocity", "window:5", "--delay", "1", "--delta", "0.02", "--json"});
    ASSERT_EQ(code4, 0);
    const ImpulseOptimum o = optimal_point(ImpulseCriterion::CI2, {0, 0.02, 1}, VelocityEstimator::moving_window(5));
    EXPECT_EQ(ci["alpha"].get<double>(), o.alpha);
    EXPECT_EQ(ci["cost"].get<double>(), o.cost);
    EXPECT_EQ(ci["penetration"].get<double>(), o.penetration);
    EXPECT_EQ(ci["passivity_margin"].get<double>(),
              passivity_margin({0, 0.02, 1}, {o.alpha, o.beta}, VelocityEstimator::moving_window(5)));
    // --passive with the estimator: estimator_passivity.hpp's passive optimum, its margin and the main region's tip.
    const auto [code5, passive] =
        run_velocity_command(add_optimum_command, {"optimum", "--criterion", "CE2", "--passive", "--velocity",
                                                   "lowpass:0.1", "--delay", "1", "--delta", "0.02", "--json"});
    ASSERT_EQ(code5, 0);
    const VelocityEstimator lp = VelocityEstimator::low_pass(0.1);
    const auto po = passive_optimum(2, {0, 0.02, 1}, lp);
    ASSERT_TRUE(po.has_value());
    EXPECT_EQ(passive["alpha"].get<double>(), po->alpha);
    EXPECT_EQ(passive["beta"].get<double>(), po->beta);
    EXPECT_EQ(passive["cost"].get<double>(), po->cost);
    EXPECT_EQ(passive["passivity_margin"].get<double>(), passivity_margin({0, 0.02, 1}, {po->alpha, po->beta}, lp));
    EXPECT_TRUE(passive["passive"].get<bool>());
    EXPECT_EQ(passive["alpha_max"].get<double>(), EstimatorStabilityRegion({0, 0.02, 1}, lp).alpha_max());
    EXPECT_EQ(passive["velocity_estimator"]["kind"], "lowpass");
    // The robust optimum of the loop with the estimator: robust_optimum with RobustOptions::estimator.
    const auto [code6, robust] =
        run_velocity_command(add_optimum_command, {"optimum", "--criterion", "CE2", "--robust", "--mass", "0.2:0.3",
                                                   "--period", "0.001", "--velocity", "window:5", "--json"});
    ASSERT_EQ(code6, 0);
    RobustOptions ro;
    ro.estimator = VelocityEstimator::moving_window(5);
    UncertainPlant box;
    box.mass = {0.2, 0.3};
    box.period = 0.001;
    const RobustOptimum expected = robust_optimum(Criterion::CE2, box, ro);
    EXPECT_EQ(robust["K"].get<double>(), expected.gains.stiffness);
    EXPECT_EQ(robust["B"].get<double>(), expected.gains.damping);
    EXPECT_TRUE(robust["stable_over_box"].get<bool>());
    EXPECT_EQ(robust["velocity_estimator"]["window"], 5);
    // The collision criteria need the backward difference in the robust optimum: a clear error, not a wrong answer.
    EXPECT_THROW(robust_optimum(ImpulseCriterion::CI2, box, ro), InvalidParameter);
}

// `boundary --velocity`: the main region's boundary by estimator_region_boundary. Window 1 is the backward
// difference's loop, so its points lie on StabilityRegion's exact (D-decomposition) boundary: each point's beta is
// an end of StabilityRegion::beta_range at its alpha, to the bisections' 1e-13 relative plus the exact boundary's
// root solve (1e-12 checked, 1e-9 allowed); alpha_max agrees with the exact 12 - 8 sqrt(2) (d = 0) to the tip
// search's 1e-12. Other estimators: alpha_max is the region's, and every point is on the edge: stable 1e-7
// (relative) inside it and unstable 1e-7 outside it, in beta.
TEST(VelocityCli, BoundaryWithAnEstimatorIsTheMainRegionsEdge) {
    for (const double d : {0.0, 1.0}) {
        const auto [code, out] = run_velocity_command(
            add_boundary_command,
            {"boundary", "--velocity", "window:1", "--delay", d == 0 ? "0" : "1", "--points", "64", "--json"});
        ASSERT_EQ(code, 0);
        const NormalizedPlant plant{0, 0, d};
        const StabilityRegion exact(plant);
        EXPECT_NEAR(out["alpha_max"].get<double>(), exact.alpha_max(), 1e-12 * exact.alpha_max());
        if (d == 0) {
            EXPECT_NEAR(out["alpha_max"].get<double>(), 12 - 8 * std::sqrt(2.0), 1e-12);
        }
        EXPECT_TRUE(out["stable_islands"].empty());
        const auto& pts = out["points"];
        ASSERT_GE(pts.size(), 120u);
        EXPECT_EQ(pts.front(), pts.back());
        int checked = 0;
        for (const auto& p : pts) {
            const double a = p["alpha"], b = p["beta"];
            if (a >= exact.alpha_max() * (1 - 1e-9)) continue;  // the tip: checked through alpha_max
            const auto [lo, hi] = exact.beta_range(a);
            EXPECT_LT(std::min(std::abs(b - lo), std::abs(b - hi)), 1e-9 * std::max(1.0, hi - lo))
                << "d " << d << " alpha " << a << " beta " << b << " exact [" << lo << ", " << hi << "]";
            ++checked;
        }
        EXPECT_GE(checked, 120);
    }
    for (const std::string v : {"lowpass:0.02", "window:5"}) {
        const auto [code, out] =
            run_velocity_command(add_boundary_command, {"boundary", "--velocity", v, "--delay", "1", "--json"});
        ASSERT_EQ(code, 0);
        VelocityOption option;
        option.text = v;
        const VelocityEstimator e = option.parse(0);
        const NormalizedPlant plant{0, 0, 1};
        const EstimatorStabilityRegion region(plant, e);
        EXPECT_EQ(out["alpha_max"].get<double>(), region.alpha_max());
        const EstimatorStabilityTest test(plant, e);
        const auto& pts = out["points"];
        ASSERT_GE(pts.size(), 500u) << v;
        const std::size_t n = pts.size();
        for (std::size_t i = 1; i + 1 < n; ++i) {
            const double a = pts[i]["alpha"], b = pts[i]["beta"];
            if (a >= region.alpha_max() * (1 - 1e-6)) continue;  // the tip (alpha_max checked above)
            const double inward = i < n / 2 ? 1 : -1;            // lower edge first, then the upper edge
            const double step = 1e-7 * std::max(1e-3, std::abs(b));
            EXPECT_TRUE(test.stable(a, b + inward * step)) << v << " alpha " << a << " beta " << b;
            EXPECT_FALSE(test.stable(a, b - inward * step)) << v << " alpha " << a << " beta " << b;
        }
        double widest = 0;
        for (const auto& p : pts) widest = std::max(widest, p["alpha"].get<double>());
        EXPECT_EQ(widest, region.alpha_max()) << v;
    }
    EXPECT_THROW(
        run_velocity_command(add_boundary_command, {"boundary", "--velocity", "window:3", "--points", "4", "--json"}),
        InvalidParameter);
    // The passive set with the estimator (estimator_passivity.hpp): its largest alpha.
    const auto [pcode, passive] = run_velocity_command(
        add_boundary_command,
        {"boundary", "--velocity", "lowpass:0.1", "--passivity", "--delay", "1", "--delta", "0.02", "--json"});
    ASSERT_EQ(pcode, 0);
    EXPECT_EQ(passive["largest_passive_alpha"].get<double>(),
              largest_passive_alpha({0, 0.02, 1}, VelocityEstimator::low_pass(0.1)).alpha);
    EXPECT_FALSE(passive["points"].empty());
}

}  // namespace
}  // namespace hapticopt::cli
