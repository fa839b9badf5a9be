// SPDX-License-Identifier: Apache-2.0
// The hapticopt CLI's --velocity option and the JSON fields it adds (apps/hapticopt: cli_output.cpp,
// cost_command.cpp, optimum_command.cpp), run in-process.
#include <gtest/gtest.h>

#include <cmath>
#include <iostream>
#include <sstream>
#include <string>
#include <vector>

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
    std::streambuf* old = std::cout.rdbuf(captured.rdbuf());
    const int code = run();
    std::cout.rdbuf(old);
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
    EXPECT_TRUE(out["CI0"].is_null());
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
    const auto [code2, refused] = run_velocity_command(
        add_optimum_command, {"optimum", "--criterion", "OV", "--velocity", "window:15", "--json"});
    EXPECT_EQ(code2, int{kUsage});
    const auto [code3, ov] = run_velocity_command(
        add_optimum_command, {"optimum", "--criterion", "CE2+OV", "--velocity", "lowpass:0.1", "--json"});
    ASSERT_EQ(code3, 0);
    EXPECT_LT(ov["alpha"].get<double>(), ov["alpha_max"].get<double>());
}

}  // namespace
}  // namespace hapticopt::cli
