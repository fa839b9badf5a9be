// SPDX-License-Identifier: Apache-2.0
// hapticd --retune as a process on the simulated Falcon in lockstep (docs/robust-stability.md, "Online re-tuning"):
// the bilateral wall in contact, the hand lets go and grips again at times at least 2 N_d apart; the wall's gains
// move to the released row after the release and back after the grip, switches 2 N_d apart, and the rendered loop
// is the switched loop: the trace's forces are the law with the active row's gains, and the trace's positions are an
// independent simulation's (the loop stepped here from the trace's state after the release, the forces in flight
// keeping their gains). The shipped profile for the energy; a copy without the encoder's rounding for the exact
// comparison (the rounding makes the position a function the simulation would have to reproduce to the count).
#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <deque>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "common/process.hpp"
#include "common/test_paths.hpp"
#include "common/trace_rows.hpp"
#include "daemon/exit_codes.hpp"
#include "daemon/recording_reader.hpp"

namespace hapticd {
namespace retune_process_test {  // named: the sanitizer trees' unity build joins this file with test_wall_retuner.cpp

using Row = test::TraceRow;
constexpr double kPeriod = 1e-3;
constexpr int kWindow = 15;     // the Falcon profile's window:15
constexpr int kDelayTicks = 6;  // its inherent_delay, 6 ms
constexpr double kReleasedMass = 0.22;

struct RetuneRun {
    test::Result result;
    std::vector<Row> rows;
    nlohmann::json summary;
};

RetuneRun falcon_run(const std::string& tag, const std::string& schedule, const std::string& duration,
                     const std::vector<std::string>& extra, const std::string& device = "falcon") {
    const std::string trace = (test::scratch_dir() / (tag + ".csv")).string();
    const std::string summary = (test::scratch_dir() / (tag + ".json")).string();
    std::vector<std::string> a{"--config",    "",
                               "--device",    device,
                               "--simulate",  "--lockstep",
                               "--bilateral", "--hand-schedule",
                               schedule,      "--duration",
                               duration,      "--trace",
                               trace,         "--summary-json",
                               summary};
    a.insert(a.end(), extra.begin(), extra.end());
    test::Process p(HAPTICD_BINARY, a, tag);
    const int code = p.wait(std::chrono::seconds(300));  // a hang guard, not a timing bound
    RetuneRun r{{code, p.out(), p.err()}, {}, {}};
    r.rows = test::read_trace(trace);
    if (std::ifstream(summary)) r.summary = nlohmann::json::parse(test::read_file(summary));
    return r;
}

// The shipped profile without the encoder's rounding (and so without the noise budget, which needs it).
std::string exact_falcon_profile() {
    return test::write_file("falcon_exact.toml",
                            "mass = 0.30\ninherent_delay = 0.006\nmass_range = [0.22, 0.30]\n"
                            "arm_stiffness_per_mass = 1000.0\narm_damping_per_mass = 20.0\nmax_force = 9.0\n"
                            "axes = 3\nvelocity_estimator = \"window:15\"\n"
                            "workspace_min = [-0.06, -0.06, -0.06]\nworkspace_max = [0.06, 0.06, 0.06]\n");
}

// The row active for the force of tick j: the switches' rows after their ticks.
int row_at(const nlohmann::json& switches, std::size_t j) {
    int row = 0;
    for (const auto& s : switches)
        if (j > s["tick"].get<std::size_t>()) row = s["row"].get<int>();
    return row;
}

double law(const nlohmann::json& rows, int row, const std::vector<Row>& t, std::size_t j) {
    const double K = rows[row][0]["K"].get<double>(), B = rows[row][0]["B"].get<double>();
    const double v = (t[j].position - t[j - kWindow].position) * ((1.0 / kPeriod) / kWindow);
    return -(K * t[j].position + B * v);  // direction +1 at 0: the force pushes back to x <= 0
}

// The independent loop from tick `a` on, a free mass (released, no hand) until tick `end`: the samples x_{a-15} ..
// x_a and the forces f_{a-6} .. f_{a-1} from the trace, the velocity at a from the trace's next position (exact for
// the ZOH: x_{a+1} = x_a + v_a T + f_{a-6} T^2 / 2m), then each tick the law with that tick's row, the force acting
// 6 ticks later for one period. Returns the positions x_a .. x_end.
std::vector<double> simulate_released(const std::vector<Row>& t, const nlohmann::json& summary, std::size_t a,
                                      std::size_t end) {
    const auto& rows = summary["retune"]["rows"];
    const auto& switches = summary["retune"]["switches"];
    std::deque<double> samples;  // newest first: x_j, x_{j-1}, ..., x_{j-15}
    for (std::size_t i = 0; i <= kWindow; ++i) samples.push_back(t[a - i].position);
    std::deque<double> forces;  // newest first: f_{j-1} .. f_{j-6}
    for (std::size_t i = 1; i <= kDelayTicks; ++i) forces.push_back(t[a - i].force);
    double x = t[a].position;
    double v = (t[a + 1].position - x) / kPeriod - forces.back() * kPeriod / (2.0 * kReleasedMass);
    std::vector<double> out{x};
    for (std::size_t j = a; j < end; ++j) {
        const int row = row_at(switches, j);
        const double K = rows[row][0]["K"].get<double>(), B = rows[row][0]["B"].get<double>();
        const double rate = (samples[0] - samples[kWindow]) / (kWindow * kPeriod);
        forces.push_front(-(K * samples[0] + B * rate));
        const double u = forces.back();  // f_{j-6}: acts during [j, j + 1)
        forces.pop_back();
        x += v * kPeriod + u * kPeriod * kPeriod / (2.0 * kReleasedMass);
        v += u * kPeriod / kReleasedMass;
        samples.push_front(x);
        samples.pop_back();
        out.push_back(x);
    }
    return out;
}

// The exact profile (no rounding): released at 1 s, gripped at 10 s (the gap 2 N_d is 8.4 s on this family).
TEST(RetuneProcess, TheWallReTunesAfterTheReleaseAndBackAfterTheGripAsTheSwitchedLoop) {
    const RetuneRun r = falcon_run("retune_exact", "release@1.0,grip@10.0", "11", {"--retune"}, exact_falcon_profile());
    ASSERT_EQ(r.result.code, 0) << r.result.err << r.result.out;
    ASSERT_TRUE(r.summary.contains("retune")) << r.summary.dump();
    const auto& rt = r.summary["retune"];
    const int dwell = rt["dwell_ticks"].get<int>();
    const std::size_t gap = rt["min_gap_ticks"].get<std::size_t>();
    EXPECT_EQ(gap, 2U * static_cast<std::size_t>(dwell));
    EXPECT_GT(dwell, 100);
    EXPECT_NE(r.result.out.find("dwell N_d = " + std::to_string(dwell) + " ticks"), std::string::npos) << r.result.out;
    // The released row: the optimum for 0.22 kg, softer than the held one.
    const auto& rows = rt["rows"];
    EXPECT_LT(rows[1][0]["K"].get<double>(), rows[0][0]["K"].get<double>());
    EXPECT_LT(rows[1][0]["B"].get<double>(), rows[0][0]["B"].get<double>());
    // Two switches: released within 100 ms of the release, held within 100 ms of the grip, 2 N_d apart.
    const auto& sw = rt["switches"];
    ASSERT_EQ(rt["switch_count"].get<int>(), 2) << rt.dump();
    ASSERT_EQ(sw.size(), 2U);
    const std::size_t s0 = sw[0]["tick"].get<std::size_t>(), s1 = sw[1]["tick"].get<std::size_t>();
    EXPECT_EQ(sw[0]["row"].get<int>(), 1);
    EXPECT_EQ(sw[1]["row"].get<int>(), 0);
    EXPECT_GE(s0, 1000U);
    EXPECT_LT(s0, 1100U);
    EXPECT_GE(s1, 10000U);
    EXPECT_LT(s1, 10100U);
    EXPECT_GE(s1 - s0, gap);
    std::printf("[ retune ] N_d %d ticks; switched to released after tick %zu, to held after tick %zu\n", dwell, s0,
                s1);
    ASSERT_EQ(r.rows.size(), 11000U);
    // The trace's force is the law with the active row's gains at every tick from the window's fill to the stop
    // window (relative 1e-12: the same operations in another order); the other row's law differs there.
    std::size_t other_row_differs = 0;
    for (std::size_t j = 100; j < 10900; ++j) {
        const int row = row_at(sw, j);
        const double f = law(rows, row, r.rows, j);
        ASSERT_NEAR(r.rows[j].force, f, 1e-12 * std::max(1.0, std::abs(f))) << "tick " << j << ", row " << row;
        if (std::abs(law(rows, 1 - row, r.rows, j) - f) > 1e-9) ++other_row_differs;
    }
    EXPECT_GT(other_row_differs, 1000U);
    // The independent simulation from 10 ticks after the release (a free 0.22 kg handle) through the switch to the
    // grip: the same positions to 1e-12 of the release's penetration (rounding of 9000 ticks of a stable loop).
    const std::size_t a = 1010, end = 9990;
    const std::vector<double> sim = simulate_released(r.rows, r.summary, a, end);
    const double scale = std::abs(r.rows[1000].position);
    double worst = 0.0;
    for (std::size_t j = a; j <= end; ++j) worst = std::max(worst, std::abs(sim[j - a] - r.rows[j].position));
    std::printf(
        "[ retune ] trace against the independent switched loop, ticks %zu .. %zu: %.3g m (x at release %.3g m)\n", a,
        end, worst, scale);
    EXPECT_GT(scale, 1e-4);
    EXPECT_LT(worst, 1e-9 * scale);
    // Energy decays after the release: the force over the last second before the grip is below 1e-6 of its value at
    // the release (the loop contracts by the certificate's rate, no rounding to keep a limit cycle).
    double at_release = 0.0, late = 0.0;
    for (std::size_t j = 995; j < 1005; ++j) at_release = std::max(at_release, std::abs(r.rows[j].force));
    for (std::size_t j = 9000; j < 10000; ++j) late = std::max(late, std::abs(r.rows[j].force));
    std::printf("[ retune ] |F| at the release %.4g N, over 9-10 s %.3g N\n", at_release, late);
    EXPECT_GT(at_release, 0.3);
    EXPECT_LT(late, 1e-6 * at_release);
}

// The shipped profile (the encoder's rounding, the noise budget): the same schedule with and without --retune. Both
// stay bounded and decay into the one-count limit cycle after the release; with --retune the walls switch twice
// and the start-up says how it was certified.
TEST(RetuneProcess, TheShippedFalconReTunesAndDecaysThroughReleaseAndGrip) {
    const RetuneRun r = falcon_run("retune_shipped", "release@1.0,grip@10.0", "11", {"--retune"});
    ASSERT_EQ(r.result.code, 0) << r.result.err << r.result.out;
    EXPECT_EQ(r.result.err.find("not stable"), std::string::npos) << r.result.err;
    EXPECT_NE(r.result.out.find("average dwell time"), std::string::npos) << r.result.out;
    EXPECT_NE(r.result.out.find("re-tuning: 2 switches"), std::string::npos) << r.result.out;
    const auto& sw = r.summary["retune"]["switches"];
    ASSERT_EQ(sw.size(), 2U) << r.summary.dump();
    EXPECT_GE(sw[1]["tick"].get<std::size_t>() - sw[0]["tick"].get<std::size_t>(),
              r.summary["retune"]["min_gap_ticks"].get<std::size_t>());
    ASSERT_EQ(r.rows.size(), 11000U);
    double at_release = 0.0, late = 0.0;
    for (std::size_t j = 995; j < 1005; ++j) at_release = std::max(at_release, std::abs(r.rows[j].force));
    for (std::size_t j = 1500; j < 10000; ++j) late = std::max(late, std::abs(r.rows[j].force));
    std::printf("[ retune ] shipped: |F| at the release %.4f N, over 1.5-10 s %.4f N\n", at_release, late);
    EXPECT_LT(late, at_release / 3.0);
    for (std::size_t j = 2000; j < 10000; ++j) ASSERT_LE(std::abs(r.rows[j].position), 9.7e-5) << j;
}

// The hand lets go and grips every 0.5 s for 20 s: the identifier follows it (each release and grip decided within
// 100 ms, tests/identification), the walls do not: their switches stay 2 N_d apart.
TEST(RetuneProcess, SwitchesStayTwoDwellsApartWhenTheHandFlipsFast) {
    std::string schedule;
    for (int i = 0; i < 19; ++i) {
        schedule += (schedule.empty() ? "" : ",") + std::string(i % 2 == 0 ? "release@" : "grip@") +
                    std::to_string(1.0 + 0.5 * i);
    }
    const RetuneRun r = falcon_run("retune_fast", schedule, "20", {"--retune"}, exact_falcon_profile());
    ASSERT_EQ(r.result.code, 0) << r.result.err << r.result.out;
    const auto& rt = r.summary["retune"];
    const std::size_t gap = rt["min_gap_ticks"].get<std::size_t>();
    const auto& sw = rt["switches"];
    ASSERT_EQ(r.summary["hand_events"].size(), 19U);
    ASSERT_GE(sw.size(), 2U) << rt.dump();
    EXPECT_LT(sw.size(), 5U);
    for (std::size_t i = 1; i < sw.size(); ++i) {
        EXPECT_GE(sw[i]["tick"].get<std::size_t>() - sw[i - 1]["tick"].get<std::size_t>(), gap) << rt.dump();
        EXPECT_NE(sw[i]["row"], sw[i - 1]["row"]);
    }
    EXPECT_EQ(rt["switch_count"].get<std::size_t>(), sw.size());
}

// The state stream: --record's tick chunks carry the active row (gain_row) from each switch's tick on, and the
// replay re-tunes as the run did (the identifier sees the recorded positions and the same forces): bit for bit.
TEST(RetuneProcess, TheRecordingCarriesTheRowAndTheReplayReTunesTheSame) {
    const std::string rec = (test::scratch_dir() / "retune.hrec").string();
    const RetuneRun r = falcon_run("retune_record", "release@1.0,grip@10.0", "11", {"--retune", "--record", rec},
                                   exact_falcon_profile());
    ASSERT_EQ(r.result.code, 0) << r.result.err;
    const auto& sw = r.summary["retune"]["switches"];
    ASSERT_EQ(sw.size(), 2U);
    const Recording recording = read_recording(rec);
    ASSERT_EQ(recording.ticks.size(), 11000U);
    for (std::size_t j = 0; j < recording.ticks.size(); ++j) {
        // The row recorded at tick j is the one after tick j's update: the switch's tick carries the new row.
        ASSERT_EQ(static_cast<int>(recording.ticks[j].gain_row), row_at(sw, j + 1)) << j;
    }
    const test::Result replay = test::run({"--replay", rec}, "retune_replay");
    EXPECT_EQ(replay.code, kExitOk) << replay.err;
    EXPECT_NE(replay.out.find("every force identical to the recording"), std::string::npos) << replay.out;
}

// Bad input: --retune on a profile without mass_range (exit 3, naming the key), with --serve (exit 2, naming it),
// and with explicit gains (exit 2).
TEST(RetuneProcess, RefusesWhereItCannotApply) {
    const std::string no_range = test::write_file(
        "falcon_no_range.toml",
        "mass = 0.30\ninherent_delay = 0.006\nmax_force = 9.0\naxes = 3\nvelocity_estimator = \"window:15\"\n");
    const test::Result a =
        test::run({"--config", "", "--device", no_range, "--simulate", "--lockstep", "--duration", "0.1", "--retune"},
                  "retune_no_range");
    EXPECT_EQ(a.code, kExitBadConfig) << a.err;
    EXPECT_NE(a.err.find("--retune"), std::string::npos) << a.err;
    EXPECT_NE(a.err.find("no mass_range"), std::string::npos) << a.err;
    const test::Result b =
        test::run({"--config", "", "--device", "falcon", "--simulate", "--lockstep", "--duration", "0.1", "--retune",
                   "--serve", "--serve-socket", (test::scratch_dir() / "retune.sock").string()},
                  "retune_serve");
    EXPECT_EQ(b.code, kExitUsage) << b.err;
    EXPECT_NE(b.err.find("--serve"), std::string::npos) << b.err;
    const test::Result c = test::run({"--config", "", "--device", "falcon", "--simulate", "--lockstep", "--duration",
                                      "0.1", "--retune", "--stiffness", "100", "--damping", "1"},
                                     "retune_gains");
    EXPECT_EQ(c.code, kExitUsage) << c.err;
    EXPECT_NE(c.err.find("--stiffness"), std::string::npos) << c.err;
    // The profile's key turns it on as the flag does (and so is refused there too).
    const std::string keyed = test::write_file(
        "falcon_retune_key.toml", "mass = 0.30\ninherent_delay = 0.006\nmax_force = 9.0\naxes = 3\nretune = true\n");
    const test::Result d =
        test::run({"--config", "", "--device", keyed, "--simulate", "--lockstep", "--duration", "0.1"}, "retune_key");
    EXPECT_EQ(d.code, kExitBadConfig) << d.err;
    EXPECT_NE(d.err.find("no mass_range"), std::string::npos) << d.err;
}

}  // namespace retune_process_test
}  // namespace hapticd
