// SPDX-License-Identifier: Apache-2.0
// The two examples of docs/clients.md run for a bounded time against a real hapticd --serve (lockstep,
// simulated device; the simulated hand starts 1 cm before x = 0 and pushes towards +x with 2 N).
#include <gtest/gtest.h>

#include <cstdio>

#include "client_process.hpp"

namespace {

using clients_test::LockstepDaemon;
using clients_test::Result;

TEST(Examples, MovingWallRunsForItsDurationAndTheLoopAppliesEveryUpdate) {
    LockstepDaemon daemon("moving_wall");
    ASSERT_TRUE(daemon.ready()) << daemon.log();
    // The wall surface at x = -5 mm +- 2 mm (normal -x, offset 0.005): the hand is pressed against it.
    const Result r = clients_test::run(MOVING_WALL_BINARY,
                                       {"--socket", daemon.socket(), "--duration", "1", "--update-rate", "100", "--stiffness",
                                        "2000", "--damping", "10"},
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
    const Result r = clients_test::run(PUSH_BUTTON_BINARY, {"--socket", daemon.socket(), "--duration", "10", "--presses", "1"},
                                       "push_button");
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

}  // namespace
