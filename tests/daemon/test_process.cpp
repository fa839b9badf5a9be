// SPDX-License-Identifier: Apache-2.0
// hapticd as a process: SIGTERM, bad configuration, bad parameters, exit codes.
#include <fcntl.h>

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <nlohmann/json.hpp>

#include "daemon/exit_codes.hpp"
#include "common/process.hpp"
#include "common/trace_rows.hpp"

namespace hapticd {
namespace {

using test::Process;
using test::run;
using test::write_file;

// A config with the defaults but no reliance on the installed one.
const std::vector<std::string> kNoConfig{"--config", ""};

std::vector<std::string> args(std::initializer_list<std::string> extra) {
    std::vector<std::string> a = kNoConfig;
    a.insert(a.end(), extra);
    return a;
}

using Row = test::TraceRow;
using test::read_trace;

// Gains stable for the free device's nominal 0.30 kg (d = 0, near the region's large-beta edge: alpha 0.034,
// beta 1.965) are unstable with a simulated hand that has stiffness and no damping
// (SimulatedHand.TheFreeDeviceChecksStayConservativeForTheDefaultHand): on a profile certified for its nominal mass
// alone (mass_margin = 0, no mass_range) hapticd says so at start-up, and not for the default hand. On the shipped
// sim profile the same explicit gains are refused at start-up (exit 5): on that edge they are not stable for every
// mass of its plant set (0.200 .. 0.330 kg), and the message names the mass.
TEST(HapticdProcess, WarnsWhenAWallIsUnstableWithTheSimulatedHand) {
    const std::string nominal =
        test::write_file("sim_nominal_only.toml", "mass = 0.3\nmax_force = 10.0\nmass_margin = 0.0\n");
    const auto undamped = run(args({"--dry-run", "--device", nominal, "--stiffness", "10294", "--damping", "589.5",
                                    "--hand-damping", "0", "--hand-stiffness", "300"}),
                              "hand_warning");
    EXPECT_EQ(undamped.code, 0) << undamped.err;
    EXPECT_NE(undamped.err.find("is not stable with the simulated hand"), std::string::npos) << undamped.err;
    const auto held =
        run(args({"--dry-run", "--device", nominal, "--stiffness", "10294", "--damping", "589.5"}), "hand_default");
    EXPECT_EQ(held.code, 0) << held.err;
    EXPECT_EQ(held.err.find("simulated hand"), std::string::npos) << held.err;
    const auto set = run(args({"--dry-run", "--stiffness", "10294", "--damping", "589.5"}), "hand_set");
    EXPECT_EQ(set.code, 5) << set.err;
    EXPECT_NE(set.err.find("are unstable with the mass"), std::string::npos) << set.err;
    EXPECT_NE(set.err.find("plant set: masses 0.6667 .. 1.1 x 0.3 kg"), std::string::npos) << set.err;
}

TEST(HapticdProcess, HelpListsExitCodes) {
    const auto r = run({"--help"}, "help");
    EXPECT_EQ(r.code, 0);
    EXPECT_NE(r.out.find("Exit codes"), std::string::npos);
    EXPECT_NE(r.out.find("--criterion"), std::string::npos);
}

TEST(HapticdProcess, SigtermStopsWithZeroForceAndCompleteTrace) {
    const std::string trace = (test::scratch_dir() / "sigterm.csv").string();
    const std::string summary = (test::scratch_dir() / "sigterm.json").string();
    // Stiffness/damping explicit so that start-up does not depend on the optimiser's run time; the wall
    // pushes back during the run (unit force step into a bilateral wall).
    Process p(
        args({"--stiffness", "3000", "--damping", "10", "--bilateral", "--trace", trace, "--summary-json", summary,
              "--rt-priority", "0", "--watchdog-overruns", "1000000", "--watchdog-stall-periods", "1000000"}),
        "sigterm");
    ASSERT_GT(p.pid(), 0);
    // Wait until the loop is running (the trace has data), then stop it.
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(20);
    while (std::chrono::steady_clock::now() < deadline) {
        if (std::filesystem::exists(trace) && std::filesystem::file_size(trace) > 4000) break;
        std::this_thread::sleep_for(std::chrono::milliseconds(10));
    }
    ASSERT_EQ(::kill(p.pid(), SIGTERM), 0);
    const int code = p.wait(std::chrono::milliseconds(5000));
    ASSERT_EQ(code, 0) << p.err();
    const auto rows = read_trace(trace);
    ASSERT_GT(rows.size(), 10U);
    for (std::size_t i = 0; i < rows.size(); ++i) ASSERT_EQ(rows[i].tick, i) << "gap in the trace";
    EXPECT_EQ(rows.back().force, 0.0);
    bool pushed = false;
    for (const auto& r : rows) pushed = pushed || r.force != 0.0;
    EXPECT_TRUE(pushed) << "the wall never pushed";
    const auto j = nlohmann::json::parse(test::read_file(summary));
    EXPECT_EQ(j["ticks"].get<std::size_t>(), rows.size());
    EXPECT_EQ(j["trace_drops"], 0);
    EXPECT_EQ(j["stopped_by_signal"], true);
    EXPECT_EQ(j["fault"], "none");
    EXPECT_NE(p.out().find("stopped by signal 15"), std::string::npos) << p.out();
}

TEST(HapticdProcess, LockstepDurationWritesSummary) {
    const std::string summary = (test::scratch_dir() / "lockstep.json").string();
    const auto r = run(
        args({"--lockstep", "--duration", "0.5", "--stiffness", "2000", "--damping", "5", "--summary-json", summary}),
        "lockstep");
    ASSERT_EQ(r.code, 0) << r.err;
    const auto j = nlohmann::json::parse(test::read_file(summary));
    for (const char* key : {"criterion", "K", "B", "alpha", "beta", "mass", "damping", "stiffness", "period", "delay",
                            "ticks", "overruns", "predicted_cost", "alpha_max", "stability_margin", "wake_latency",
                            "compute_time", "trace_drops", "fault"}) {
        EXPECT_TRUE(j.contains(key)) << key;
    }
    EXPECT_EQ(j["ticks"], 500);
    EXPECT_EQ(j["K"], 2000.0);
    EXPECT_DOUBLE_EQ(j["alpha"].get<double>(), 2000.0 * 1e-6 / 0.3);
    // The shipped sim profile: one axis of 0.3 kg, no stiffness limit.
    EXPECT_EQ(j["mass_matrix"], nlohmann::json::parse("[[0.3]]"));
    EXPECT_EQ(j["axis_masses"], nlohmann::json::parse("[0.3]"));
    EXPECT_TRUE(j["max_stiffness"].is_null()) << j["max_stiffness"];
    // The force limiter's default: the shipped sim's max_force 10 N per 4 ms, 2.5 N per tick; the stop window
    // ceil(10 / 2.5) + 1 = 5 ticks; the 1 N step response never reaches the limit.
    EXPECT_DOUBLE_EQ(j["force_limiter"]["max_force_rate"].get<double>(), 2500.0);
    EXPECT_NEAR(j["force_limiter"]["max_step"].get<double>(), 2.5, 1e-12);
    EXPECT_EQ(j["force_limiter"]["stop_ticks"], 5);
    EXPECT_EQ(j["force_limiter"]["rate_limited_ticks"], 0);
    EXPECT_LE(j["force_limiter"]["largest_step"].get<double>(), 2.5);
}

// An anisotropic profile (a full mass matrix, the one of tests/server/sim3_aniso.toml: eigenvalues 0.176,
// 0.283, 0.541 kg): the summary gives M as written, per axis the mass a wall on that axis acts with,
// 1 / (M^-1)_aa, `mass` = axis 0's, and the limit. The reference for 1 / (M^-1)_aa is the closed form
// det(M) / C_aa (C_aa the cofactor), independent of the daemon's Eigen inverse; a wall on axis 1 shows that
// the tuning used axis_masses[1] (alpha = K T^2 / m_1). Tolerance 1e-12 relative: both sides round a 3 x 3
// inverse of condition 3.1 (a few ulp each); mistaking M_aa for the mass along axis a is 9 % off on axis 1.
TEST(HapticdProcess, SummaryGivesTheMassMatrixAndTheMassAlongEachAxis) {
    const double M[3][3] = {{0.45, 0.10, 0.12}, {0.10, 0.30, 0.00}, {0.12, 0.00, 0.25}};
    const std::string profile =
        write_file("aniso_summary_device.toml",
                   "name = \"aniso\"\nmass_matrix = [0.45, 0.10, 0.12, 0.10, 0.30, 0.00, 0.12, 0.00, 0.25]\n"
                   "damping = 0.0\nstiffness = 0.0\nmax_force = 10.0\nmax_stiffness = 100000.0\naxes = 3\n"
                   "workspace_min = [-0.06, -0.06, -0.06]\nworkspace_max = [0.06, 0.06, 0.06]\n");
    const std::string summary = (test::scratch_dir() / "aniso_summary.json").string();
    const auto r = run(
        args({"--device", profile, "--lockstep", "--duration", "0.05", "--wall", "axis=1 position=0.05 direction=+1",
              "--stiffness", "2000", "--damping", "5", "--summary-json", summary}),
        "aniso_summary");
    ASSERT_EQ(r.code, 0) << r.err;
    const auto j = nlohmann::json::parse(test::read_file(summary));
    ASSERT_TRUE(j["mass_matrix"].is_array() && j["mass_matrix"].size() == 3) << j.dump();
    ASSERT_TRUE(j["axis_masses"].is_array() && j["axis_masses"].size() == 3) << j.dump();
    for (std::size_t i = 0; i < 3; ++i) {
        ASSERT_EQ(j["mass_matrix"][i].size(), 3U) << j["mass_matrix"];
        for (std::size_t k = 0; k < 3; ++k) EXPECT_EQ(j["mass_matrix"][i][k].get<double>(), M[i][k]) << i << "," << k;
    }
    const double det = M[0][0] * (M[1][1] * M[2][2] - M[1][2] * M[2][1]) -
                       M[0][1] * (M[1][0] * M[2][2] - M[1][2] * M[2][0]) +
                       M[0][2] * (M[1][0] * M[2][1] - M[1][1] * M[2][0]);
    const double cofactor[3] = {M[1][1] * M[2][2] - M[1][2] * M[2][1], M[0][0] * M[2][2] - M[0][2] * M[2][0],
                                M[0][0] * M[1][1] - M[0][1] * M[1][0]};
    for (std::size_t a = 0; a < 3; ++a) {
        const double m_a = det / cofactor[a];
        EXPECT_NEAR(j["axis_masses"][a].get<double>(), m_a, 1e-12 * m_a) << "axis " << a;
    }
    // Hand values (the profile's comment: 0.359 kg along axis 0).
    EXPECT_NEAR(j["axis_masses"][0].get<double>(), 0.02693 / 0.075, 1e-12);
    EXPECT_EQ(j["mass"].get<double>(), j["axis_masses"][0].get<double>());
    EXPECT_NEAR(j["alpha"].get<double>(), 2000.0 * 1e-6 / j["axis_masses"][1].get<double>(),
                1e-12 * j["alpha"].get<double>());
    EXPECT_EQ(j["max_stiffness"].get<double>(), 100000.0);
}

struct BadCase {
    const char* name;
    std::string config;   // hapticd.toml contents ("" : none)
    std::string profile;  // device profile contents ("" : the shipped sim)
    std::vector<std::string> extra;
    int code;
    std::vector<std::string> message_parts;
};

void PrintTo(const BadCase& c, std::ostream* os) { *os << c.name; }

class HapticdBadInput : public ::testing::TestWithParam<BadCase> {};

TEST_P(HapticdBadInput, ClearMessageAndDistinctExitCode) {
    const BadCase& c = GetParam();
    std::vector<std::string> a;
    if (!c.config.empty()) {
        a = {"--config", write_file(std::string(c.name) + ".toml", c.config)};
    } else if (std::find(c.extra.begin(), c.extra.end(), "--config") == c.extra.end()) {
        a = kNoConfig;
    }
    if (!c.profile.empty()) {
        a.push_back("--device");
        a.push_back(write_file(std::string(c.name) + "_device.toml", c.profile));
    }
    a.insert(a.end(), c.extra.begin(), c.extra.end());
    a.push_back("--lockstep");
    if (std::find(c.extra.begin(), c.extra.end(), "--duration") == c.extra.end()) {
        a.push_back("--duration");
        a.push_back("0.01");
    }
    const auto r = run(a, c.name);
    EXPECT_EQ(r.code, c.code) << r.err;
    for (const auto& part : c.message_parts) {
        EXPECT_NE(r.err.find(part), std::string::npos) << "missing '" << part << "' in: " << r.err;
    }
    EXPECT_EQ(r.err.find("internal error"), std::string::npos) << r.err;
}

const std::string kProfileOk = "mass = 0.3\nmax_force = 10.0\n";

INSTANTIATE_TEST_SUITE_P(
    Cases, HapticdBadInput,
    ::testing::Values(
        BadCase{"unknown_key", "rate = 1000.0\nstiffnes = 3.0\n", "", {}, kExitBadConfig, {"unknown key", "stiffnes"}},
        BadCase{"wrong_type", "rate = \"fast\"\n", "", {}, kExitBadConfig, {"rate", "fast"}},
        BadCase{"wrong_type_int", "delay-buffer = 1.5\n", "", {}, kExitBadConfig, {"delay-buffer", "1.5"}},
        BadCase{"malformed_toml", "rate = 1000.0\nmass = 0.3.2\n", "", {}, kExitBadConfig, {"line 2", "mass"}},
        BadCase{"malformed_section", "[loop]\nrate = 1000.0\n", "", {}, kExitBadConfig, {"line 1", "[loop]"}},
        BadCase{"bad_choice_in_config", "criterion = \"CE9\"\n", "", {}, kExitBadConfig, {"criterion", "CE9"}},
        BadCase{"missing_config",
                "",
                "",
                {"--config", "/nonexistent/hapticd.toml"},
                kExitBadConfig,
                {"/nonexistent/hapticd.toml"}},
        BadCase{"negative_mass",
                "",
                "mass = -0.3\nmax_force = 10.0\n",
                {},
                kExitInvalidParameter,
                {"mass = -0.3", "accepted range"}},
        BadCase{"profile_unknown_key",
                "",
                "mass = 0.3\nmax_force = 10.0\nmas = 1\n",
                {},
                kExitBadConfig,
                {"unknown key", "mas"}},
        BadCase{"profile_missing_mass", "", "max_force = 10.0\n", {}, kExitBadConfig, {"missing key 'mass'"}},
        // A rate limit whose step per tick (10000 N/s x 1 ms = 10 N) is the whole max_force (10 N).
        BadCase{"max_force_rate_step_of_the_whole_limit",
                "",
                kProfileOk,
                {"--max-force-rate", "10000"},
                kExitInvalidParameter,
                {"--max-force-rate = 10000", "10 N", "max_force = 10 N",
                 "accepted range: > 0 and < max_force / T = 10000 N/s"}},
        BadCase{"max_force_rate_negative",
                "",
                "",
                {"--max-force-rate", "-5"},
                kExitInvalidParameter,
                {"max-force-rate = -5", "accepted range"}},
        BadCase{"nan_rate", "", "", {"--rate", "nan"}, kExitInvalidParameter, {"rate = nan", "accepted range"}},
        BadCase{"inf_duration", "", "", {"--duration", "inf"}, kExitInvalidParameter, {"duration = inf"}},
        BadCase{"hand_stiffness",
                "",
                "",
                {"--hand-stiffness", "-5"},
                kExitInvalidParameter,
                {"hand-stiffness = -5", "0 .. 1e9 N/m"}},
        BadCase{"hand_damping", "", "", {"--hand-damping", "nan"}, kExitInvalidParameter, {"hand-damping = nan"}},
        BadCase{
            "hand_mass", "", "", {"--hand-mass", "-0.1"}, kExitInvalidParameter, {"hand-mass = -0.1", "0 .. 1000 kg"}},
        BadCase{
            "activation_speed", "", "", {"--activation-speed", "-1"}, kExitInvalidParameter, {"activation-speed = -1"}},
        BadCase{"move_interval_max",
                "",
                "",
                {"--move-interval-max", "11"},
                kExitInvalidParameter,
                {"move-interval-max = 11", "0 .. 10 s"}},
        BadCase{"nan_stiffness",
                "",
                "",
                {"--stiffness", "nan", "--damping", "1"},
                kExitInvalidParameter,
                {"stiffness = nan"}},
        BadCase{"negative_delay_buffer",
                "",
                "",
                {"--delay-buffer", "-2"},
                kExitInvalidParameter,
                {"delay-buffer = -2", "accepted range"}},
        BadCase{"unstable_gains",
                "",
                "",
                {"--stiffness", "1e6", "--damping", "0"},
                kExitUnstableGains,
                {"K = 1e+06", "B = 0", "alpha_max"}},
        BadCase{"only_stiffness", "", "", {"--stiffness", "100"}, kExitUsage, {"--damping"}},
        BadCase{"unknown_option", "", "", {"--stifness", "100"}, kExitUsage, {"--stifness"}},
        BadCase{"bad_criterion",
                "",
                "",
                {"--criterion", "CE3"},
                kExitUsage,
                {"--criterion: CE3 not in {amax,OV,CE0,CE1,CE2,CE0+OV,CE1+OV,CE2+OV}"}},
        BadCase{"bad_wall_criterion",
                "",
                "",
                {"--wall", "axis=0 criterion=CE2+0V"},
                kExitUsage,
                {"criterion = CE2+0V is invalid; accepted: amax, OV, CE0"}},
        BadCase{"bad_wall", "", "", {"--wall", "axis=1 position=0"}, kExitUsage, {"axis = 1"}},
        BadCase{"real_driver",
                "",
                "driver = \"falcon\"\nmass = 0.3\nmax_force = 9.0\n",
                {},
                kExitDeviceError,
                {"falcon", "--simulate"}},
        BadCase{"robust_with_overshoot_criterion",
                "",
                "",
                {"--robust", "--criterion", "CE2+OV"},
                kExitUsage,
                {"--robust", "CE2+OV", "CE0, CE1, CE2"}},
        BadCase{"robust_without_ranges",
                "",
                "mass = 0.3\nmax_force = 10.0\n",
                {"--robust"},
                kExitBadConfig,
                {"--robust", "mass_range"}},
        BadCase{"range_excludes_nominal",
                "",
                "mass = 0.3\nmax_force = 10.0\nmass_range = [0.4, 0.5]\n",
                {"--robust"},
                kExitInvalidParameter,
                {"mass_range", "min <= nominal value"}},
        BadCase{"range_wrong_length",
                "",
                "mass = 0.3\nmax_force = 10.0\nmass_range = [0.2, 0.3, 0.4]\n",
                {},
                kExitInvalidParameter,
                {"mass_range", "3 values", "[min, max]"}},
        BadCase{"bad_velocity_estimator",
                "",
                "",
                {"--velocity-estimator", "lowpass:20"},
                kExitInvalidParameter,
                {"--velocity-estimator", "lowpass:20", "window:<N>"}},
        BadCase{"lowpass_above_nyquist",
                "",
                "mass = 0.3\nmax_force = 10.0\nvelocity_estimator = \"lowpass:600Hz\"\n",
                {},
                kExitInvalidParameter,
                {"velocity_estimator = lowpass:600Hz", "500"}},
        BadCase{"passivity_control_with_a_budget",
                "",
                "mass = 0.3\nmax_force = 10.0\nposition_resolution = 1e-5\nforce_noise_budget = 0.1\n",
                {"--passivity-control", "--stiffness", "1000", "--damping", "1"},
                kExitUsage,
                {"--passivity-control", "force noise", "--force-noise-budget 0"}},
        BadCase{"negative_force_noise_budget",
                "",
                "",
                {"--force-noise-budget", "-1"},
                kExitInvalidParameter,
                {"--force-noise-budget = -1", "accepted range"}},
        BadCase{"budget_without_an_encoder_step",
                "",
                "",
                {"--force-noise-budget", "0.1"},
                kExitInvalidParameter,
                {"force_noise_budget = 0.1", "position_resolution > 0"}},
        BadCase{"device_fails_during_run",
                "",
                "mass = 0.3\nmax_force = 10.0\nfail_at_tick = 5\n",
                {"--stiffness", "1000", "--damping", "1"},
                kExitDeviceError,
                {"failed at tick 5", "disconnected"}}),
    [](const ::testing::TestParamInfo<BadCase>& info) { return std::string(info.param.name); });

// Removes this process's scratch files at the end.
class ScratchCleanup : public ::testing::Environment {
  public:
    void TearDown() override {
        std::error_code ec;
        std::filesystem::remove_all(test::scratch_dir(), ec);
    }
};
[[maybe_unused]] ::testing::Environment* const kScratchCleanup =
    ::testing::AddGlobalTestEnvironment(new ScratchCleanup);

}  // namespace
}  // namespace hapticd
