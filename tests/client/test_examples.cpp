// SPDX-License-Identifier: Apache-2.0
// The two examples of docs/clients.md run for a bounded time against a real hapticd --serve (lockstep,
// simulated device; the simulated hand holds the handle at x = -5 mm and pushes towards +x with 2 N), and the
// moving wall against the README's real-time daemon.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <filesystem>

#include <unistd.h>

#include "client_process.hpp"
#include "common/test_paths.hpp"

namespace {

using clients_test::LockstepDaemon;
using clients_test::Result;

TEST(Examples, MovingWallRunsForItsDurationAndTheLoopAppliesEveryUpdate) {
    LockstepDaemon daemon("moving_wall");
    ASSERT_TRUE(daemon.ready()) << daemon.log();
    // The wall surface at x = -5 mm +- 2 mm (normal -x, offset 0.005): the hand is pressed against it.
    const Result r = clients_test::run(MOVING_WALL_BINARY,
                                       {"--socket", daemon.socket(), "--duration", "1", "--update-rate", "100",
                                        "--stiffness", "2000", "--damping", "10"},
                                       "moving_wall");
    ASSERT_EQ(r.code, 0) << r.out << r.err;
    unsigned long long updates = 0, contact = 0, samples = 0;
    double fmin = 0, fmax = 0;
    const auto at = r.out.find("moving_wall: ", r.out.find('\n'));
    ASSERT_NE(at, std::string::npos) << r.out;
    ASSERT_EQ(std::sscanf(r.out.c_str() + at,
                          "moving_wall: %llu updates sent, last applied yes; in contact in %llu of %llu samples; "
                          "force along the normal %lf .. %lf N",
                          &updates, &contact, &samples, &fmin, &fmax),
              5)
        << r.out;
    // 1 s at 100 Hz: about 100 updates (at least 20 on a loaded machine: sleep_until may oversleep).
    EXPECT_GE(updates, 20U);
    EXPECT_GT(contact, 0U) << "the hand is in contact with the moving wall";
    EXPECT_GT(fmax, 0.0) << "the wall pushes along its normal";
    EXPECT_EQ(daemon.stop(), 0) << daemon.log();
}

TEST(Examples, PushButtonPrintsPressedWhenTheHandPushesPastTheClick) {
    LockstepDaemon daemon("push_button");
    ASSERT_TRUE(daemon.ready()) << daemon.log();
    // K = 1000 N/m against the hand's 2 N less its spring (k_H = 200 N/m, held at the surface): 1000 d = 2 - 200 d,
    // 1.67 mm deep at rest, past the 1.5 mm click; --presses 1 ends it.
    const Result r = clients_test::run(
        PUSH_BUTTON_BINARY, {"--socket", daemon.socket(), "--duration", "10", "--presses", "1"}, "push_button");
    ASSERT_EQ(r.code, 0) << r.out << r.err;
    EXPECT_NE(r.out.find("ready"), std::string::npos) << r.out;
    double depth = 0, force = 0;
    const auto at = r.out.find("pressed (1): ");
    ASSERT_NE(at, std::string::npos) << r.out;
    ASSERT_EQ(std::sscanf(r.out.c_str() + at, "pressed (1): depth %lf mm, force %lf N", &depth, &force), 2) << r.out;
    EXPECT_GT(depth, 1.5) << "pressed only past the click depth";
    EXPECT_NE(r.out.find("push_button: 1 press(es)"), std::string::npos) << r.out;
    EXPECT_EQ(daemon.stop(), 0) << daemon.log();
}

// The 200 Hz moving wall against the README's daemon in real time (hapticd --serve --no-walls: the default
// profile, the hand at rest in the centre; the loop at SCHED_FIFO 80 as deployed, the example's poses at 70 when the
// test runs as root): the CE2 plane (normal -x, offset 5 mm +- 2 mm at 1 Hz) appears
// 5 mm around the handle, pushes it out at the activation speed (0.5 s), then moves with the poses. From the
// daemon's trace, over the tracking phase (from 0.7 s after the first force to 1.9 s), leaving out 20 ticks
// after any tick woken more than a period late (the loop then applies poses that piled up): contact releases
// and the roughness (RMS of f_j - 2 f_{j-1} + f_{j-2}). The bounds that hold for poses on time (no release,
// roughness <= 0.47 N) are asserted deterministically by
// SceneMotion.TheMovingWallTracksWithoutChatterInClosedLoopWithTheHand; here the example's poses carry the
// shared machine's timing (a pose more than one interval late is beyond the hold's extrapolation: it can open the
// contact and step the force, which the trace cannot tell from chatter), so no absolute bound holds on a loaded
// machine and the real processes are compared with moves applied at once in the same run
// (--move-interval-max 0 --activation-speed 0), under the same load: at least ten times fewer releases and
// roughness below a third of the baseline's (whose 5 ms steps of K v_max n T = 4.7 N give ~2.7 N).
struct WallRun {
    std::size_t releases = 0, counted = 0;
    double roughness = 0.0;
};

WallRun moving_wall_against_readme_daemon(const std::string& tag, const std::vector<std::string>& extra) {
    const std::string socket = (clients_test::scratch_dir() / (tag + ".sock")).string();
    const std::string shm = "/hapticd-clients-" + std::to_string(::getpid()) + "-" + tag;
    const std::string trace = (clients_test::scratch_dir() / (tag + ".csv")).string();
    std::vector<std::string> args{
        "--config", "", "--serve", "--no-walls", "--serve-socket", socket, "--serve-shm", shm, "--rt-priority", "80",
        "--mlock", "false", "--duration", "4", "--trace", trace, "--trace-axis", "0", "--quiet",
        // the example gives up on session_limit; a loop delayed by a loaded machine must not end it
        "--session-max-in-flight", "64"};
    args.insert(args.end(), extra.begin(), extra.end());
    clients_test::Process daemon(HAPTICD_BINARY, args, tag + "_daemon");
    EXPECT_TRUE(hapticd::test::wait_for_socket(socket, std::chrono::seconds(10))) << daemon.err();
    // The example's poses at SCHED_FIFO 70 (below the daemon's loop at 80) where the test may ask for it (root, as
    // CI): what it judges is the rendering of poses sent on time, which a loaded machine otherwise delays.
    const bool realtime = ::geteuid() == 0 && std::filesystem::exists("/usr/bin/chrt");
    const Result r =
        realtime ? clients_test::run("/usr/bin/chrt",
                                     {"-f", "70", MOVING_WALL_BINARY, "--socket", socket, "--duration", "2.5"}, tag)
                 : clients_test::run(MOVING_WALL_BINARY, {"--socket", socket, "--duration", "2.5"}, tag);
    EXPECT_EQ(r.code, 0) << r.out << r.err;
    EXPECT_EQ(daemon.wait(), 0) << daemon.err();
    std::ifstream in(trace);
    std::string line;
    std::getline(in, line);
    std::vector<double> f, late;
    while (std::getline(in, line)) {
        double tick = 0, t = 0, x = 0, force = 0, ext = 0, wake = 0;
        if (std::sscanf(line.c_str(), "%lf,%lf,%lf,%lf,%lf,%lf", &tick, &t, &x, &force, &ext, &wake) == 6) {
            f.push_back(-force);
            late.push_back(wake);
        }
    }
    WallRun run;
    std::size_t first = 0;
    while (first < f.size() && f[first] == 0.0) ++first;
    if (first + 1900 >= f.size()) return run;
    std::size_t skip_until = 0;
    double sum2 = 0.0;
    for (std::size_t j = first; j < first + 1900; ++j) {
        if (late[j] > 1000.0) skip_until = j + 20;
        if (j < first + 700 || j <= skip_until) continue;
        run.releases += f[j] == 0.0 && f[j - 1] > 0.0 ? 1U : 0U;
        const double d2 = f[j] - 2.0 * f[j - 1] + f[j - 2];
        sum2 += d2 * d2;
        ++run.counted;
    }
    run.roughness = run.counted > 0 ? std::sqrt(sum2 / static_cast<double>(run.counted)) : 0.0;
    std::printf("[ moving wall, real time%s ] %zu ticks judged: %zu releases, roughness %.4f N\n",
                extra.empty() ? "" : ", moves at once", run.counted, run.releases, run.roughness);
    return run;
}

TEST(Examples, MovingWallRendersWithoutChatterAgainstTheReadmeDaemon) {
    const WallRun held = moving_wall_against_readme_daemon("moving_held", {});
    // The baseline renders the moves' steps as they come: its force-rate limit at 9.99 N per tick (the largest
    // accepted, below max_force), so that the default limit (2.5 N per tick) does not smooth the 4.7 N steps.
    const WallRun at_once = moving_wall_against_readme_daemon(
        "moving_at_once", {"--move-interval-max", "0", "--activation-speed", "0", "--max-force-rate", "9990"});
    ASSERT_GT(held.counted, 600U) << "too many late ticks to judge";
    ASSERT_GT(at_once.counted, 600U) << "too many late ticks to judge";
    EXPECT_LE(10 * held.releases, at_once.releases);
    EXPECT_LE(3.0 * held.roughness, at_once.roughness);
}

}  // namespace
