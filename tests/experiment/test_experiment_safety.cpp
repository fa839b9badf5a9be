// SPDX-License-Identifier: Apache-2.0
// Abort paths of the experiments (limits, device fault) and the command end to end (exit codes, files).
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <optional>
#include <sstream>

#include "daemon/exit_codes.hpp"
#include "experiment_fixture.hpp"
#include "common/process.hpp"

namespace hapticd::experiment::test {
namespace {

// One trial at B = 200 N s/m and K = 1.5 x the boundary stiffness there (unstable: its oscillation grows
// until a limit stops it), instability detection off, on a device that records the last force written.
struct UnstableTrial {
    TrialRecord record;
    double force_cap = 0.0;   // the trial's
    double last_force = 0.0;  // the last force written to the device
};

UnstableTrial run_unstable_trial(double position_limit, std::optional<double> force_cap) {
    const Theory theory(kDefault.theory());
    auto sim = make_sim(kDefault);
    RecordingDevice dev(*sim);
    TrialRunner runner(dev, 1'000'000, true);
    TrialSettings t = make_setup(kDefault, theory, 2000).trial;
    t.K = 1.5 * theory.boundary_stiffness(200.0);
    t.B = 200.0;
    t.detect = false;
    t.position_limit = position_limit;
    if (force_cap) t.force_cap = *force_cap;
    UnstableTrial r;
    r.force_cap = t.force_cap;
    runner.run(t, r.record);
    r.last_force = dev.last_force[0];
    return r;
}

TEST(ExperimentSafety, ForceCapHitCountsAsUnstableAndLeavesZeroForce) {
    const UnstableTrial r = run_unstable_trial(/*position_limit=*/1.0, std::nullopt);  // the force grows until the cap
    EXPECT_EQ(r.record.outcome, TrialOutcome::ForceCap);
    EXPECT_TRUE(counts_as_unstable(r.record.outcome));
    EXPECT_LE(r.record.max_abs_force, r.force_cap);
    EXPECT_EQ(r.record.u[r.record.end_tick], 0.0);
    EXPECT_EQ(r.last_force, 0.0);
}

TEST(ExperimentSafety, PositionLimitHitCountsAsUnstableAndLeavesZeroForce) {
    const UnstableTrial r = run_unstable_trial(/*position_limit=*/2e-5, /*force_cap=*/1e3);  // grows until the limit
    EXPECT_EQ(r.record.outcome, TrialOutcome::PositionLimit);
    EXPECT_TRUE(counts_as_unstable(r.record.outcome));
    EXPECT_EQ(r.last_force, 0.0);
}

TEST(ExperimentSafety, DeviceFaultMidTrialStopsTheExperimentWithZeroForce) {
    const Theory theory(kDefault.theory());
    auto sim = make_sim(kDefault, /*fail_at_tick=*/3000);  // in the second trial (first: 2000 + settle 500)
    RecordingDevice dev(*sim);
    TrialRunner runner(dev, 1'000'000, true);
    ExperimentSetup setup = make_setup(kDefault, theory, 2000);
    setup.settle.home = 0.0;
    const BoundarySettings s = k_sweep(theory, {200.0}, 20.0, 8.0);
    const BoundaryResult r = run_boundary_quietly(runner, setup, s, theory);
    EXPECT_EQ(r.abort.outcome, TrialOutcome::DeviceFault);
    EXPECT_NE(r.abort.detail.find("device error"), std::string::npos) << r.abort.detail;
    ASSERT_EQ(r.trials.size(), 2U);
    EXPECT_EQ(r.trials.back().outcome, TrialOutcome::DeviceFault);
    EXPECT_EQ(dev.last_force[0], 0.0);
}

std::string out_dir(const std::string& tag) { return (hapticd::test::scratch_dir() / tag).string(); }

TEST(ExperimentProcess, BoundaryOnTheSimulatedDeviceEndToEnd) {
    const std::string dir = out_dir("boundary_e2e");
    const auto r = hapticd::test::run({"experiment", "boundary", "--device", "sim", "--b-values", "150", "350",
                                       "--k-step", "20000", "--k-resolution", "2000", "--out-dir", dir},
                                      "boundary_e2e");
    ASSERT_EQ(r.code, kExitOk) << r.err;
    for (const char* f : {"boundary.csv", "boundary_trials.csv", "boundary.svg"}) {
        EXPECT_TRUE(std::filesystem::exists(std::filesystem::path(dir) / f)) << f;
    }
    std::ifstream csv(std::filesystem::path(dir) / "boundary.csv");
    std::string line;
    int rows = -1;
    while (std::getline(csv, line)) ++rows;
    EXPECT_EQ(rows, 2);
    EXPECT_NE(r.out.find("B = 150 N s/m: K boundary measured"), std::string::npos) << r.out;
    EXPECT_NE(r.err.find("hapticd experiment boundary:"), std::string::npos) << "progress on stderr: " << r.err;
}

TEST(ExperimentProcess, OptimalOnTheSimulatedDeviceEndToEnd) {
    const std::string dir = out_dir("optimal_e2e");
    const auto r = hapticd::test::run(
        {"experiment", "optimal", "--k-range", "40000:120000:2", "--b-points", "5", "--out-dir", dir, "--quiet"},
        "optimal_e2e");
    ASSERT_EQ(r.code, kExitOk) << r.err;
    EXPECT_TRUE(r.err.empty()) << r.err;  // --quiet: no progress
    for (const char* f : {"optimal.csv", "optimal_trials.csv", "optimal.svg"}) {
        EXPECT_TRUE(std::filesystem::exists(std::filesystem::path(dir) / f)) << f;
    }
}

// A device error during the run is exit 6, as for the daemon's run (exit_codes.hpp).
TEST(ExperimentProcess, DeviceFaultMidRunExitsSixAndWritesThePartialResults) {
    const std::string profile = hapticd::test::write_file(
        "failing_sim.toml",
        "name = \"failing\"\ndriver = \"sim\"\nmass = 0.3\nmax_force = 10.0\nfail_at_tick = 5000\n");
    const std::string dir = out_dir("fault");
    const auto r = hapticd::test::run(
        {"experiment", "boundary", "--device", profile, "--b-values", "200", "--out-dir", dir, "--quiet"}, "fault");
    EXPECT_EQ(r.code, kExitDeviceError) << r.err;
    EXPECT_NE(r.err.find("device error"), std::string::npos) << r.err;
    EXPECT_TRUE(std::filesystem::exists(std::filesystem::path(dir) / "boundary_trials.csv"));
}

TEST(ExperimentProcess, BadInputsGiveTheirExitCodesAndNameTheParameter) {
    struct Case {
        std::vector<std::string> args;
        int code;
        std::string needle;
    };
    const std::vector<Case> cases = {
        {{"experiment"}, kExitUsage, "subcommand"},
        {{"experiment", "boundary", "--no-such-option"}, kExitUsage, "no-such-option"},
        {{"experiment", "boundary", "--b-range", "1:2"}, kExitUsage, "--b-range"},
        {{"experiment", "boundary", "--b-range", "1:2:3", "--b-values", "4"}, kExitUsage, "exclusive"},
        {{"experiment", "boundary", "--growth", "0.5"},
         kExitInvalidParameter,
         "--growth = 0.5 is invalid; accepted range: 1 < growth <= 100"},
        {{"experiment", "boundary", "--b-values", "-5"}, kExitInvalidParameter, "0 <= B"},
        {{"experiment", "boundary", "--k-step", "1000", "--k-resolution", "2000"},
         kExitInvalidParameter,
         "--k-resolution"},
        {{"experiment", "boundary", "--force-cap", "50"}, kExitInvalidParameter, "max_force = 10 N"},
        {{"experiment", "boundary", "--step-force", "3"}, kExitInvalidParameter, "--step-force"},
        {{"experiment", "boundary", "--rate", "nan"}, kExitInvalidParameter, "--rate"},
        {{"experiment", "optimal", "--k-values", "1e7"}, kExitInvalidParameter, "analysed K_max"},
        {{"experiment", "optimal", "--b-points", "2"}, kExitInvalidParameter, "--b-points"},
        {{"experiment", "optimal", "--device", "no_such_profile"}, kExitBadConfig, "no_such_profile"},
    };
    int i = 0;
    for (const auto& c : cases) {
        const auto r = hapticd::test::run(c.args, "bad" + std::to_string(i++));
        EXPECT_EQ(r.code, c.code) << c.args.back() << ": " << r.err;
        EXPECT_NE(r.err.find(c.needle), std::string::npos) << r.err;
    }
}

}  // namespace
}  // namespace hapticd::experiment::test
