// SPDX-License-Identifier: Apache-2.0
// Online identification of the moving mass and the grip / release decision (identification/online_mass.hpp) on the
// simulated Falcon (devices/sim_device.hpp: 0.30 kg held, 0.22 kg released, the encoder's 4.85e-5 m step, 6 ms
// delay, the hand pressing 1 N into the wall with its arm k_H 300 N/m, b_H 6 N s/m, released at 1 s and gripping
// again at 2 s), rendering the CE2 wall of the shipped profile (K 378.3 N/m, B 15.49 N s/m on the window-15 velocity)
// bilaterally: what the daemon would see. Measured: the estimate's error released and held, and the time to decide a
// release and a grip; printed for docs/robust-stability.md ("Online identification").
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <deque>
#include <stdexcept>
#include <vector>

#include "config/hand_schedule.hpp"
#include "devices/sim_device.hpp"
#include "common/counting_allocator.hpp"
#include "identification/online_mass.hpp"

namespace hapticd {
namespace {

struct FalconRun {
    std::vector<double> mass, excitation, true_mass;
    std::vector<bool> gripped;
};

FalconRun run_falcon(const OnlineMassSettings& settings, const char* schedule, double seconds, double wall_k,
                     double wall_b, Scenario scenario = Scenario::Step) {
    SimDeviceConfig c;
    c.capabilities.axes = 1;
    c.capabilities.max_force = 9.0;
    c.capabilities.inherent_delay = 0.006;
    c.plant = {0.30, 0.0, 0.0};
    c.period = 1e-3;
    c.position_resolution[0] = 4.85e-5;
    c.scenario.kind = scenario;
    c.scenario.step_force = 1.0;
    c.scenario.hand.stiffness = 300.0;
    c.scenario.hand.damping = 6.0;
    c.scenario.hand.release_mass = 0.08;
    c.scenario.schedule = parse_hand_schedule(schedule);
    SimDevice device(c);
    EXPECT_EQ(device.open(), DeviceStatus::Ok);
    EXPECT_EQ(device.home(), DeviceStatus::Ok);
    OnlineMassIdentifier id(settings);
    std::deque<double> samples(16, 0.0);
    FalconRun r;
    const int ticks = static_cast<int>(seconds / c.period);
    for (int j = 0; j < ticks; ++j) {
        AxisVector p{};
        EXPECT_EQ(device.read_position(p), DeviceStatus::Ok);
        samples.push_front(p[0]);
        samples.pop_back();
        const double velocity = (samples[0] - samples[15]) / (15 * c.period);
        AxisVector f{};
        f[0] = std::clamp(-(wall_k * p[0] + wall_b * velocity), -9.0, 9.0);  // the wall at 0, entered moving in +x
        EXPECT_EQ(device.write_force(f), DeviceStatus::Ok);
        id.update(p[0], f[0]);
        r.mass.push_back(id.mass());
        r.excitation.push_back(id.excitation());
        r.gripped.push_back(id.gripped());
        r.true_mass.push_back(device.moving_mass(0));
    }
    return r;
}

OnlineMassSettings falcon_settings() {
    OnlineMassSettings s;
    s.delay_ticks = 6;
    return s;
}

int first_tick(const std::vector<bool>& v, int from, bool value) {
    for (int j = from; j < static_cast<int>(v.size()); ++j) {
        if (v[static_cast<std::size_t>(j)] == value) return j;
    }
    return -1;
}

TEST(OnlineMass, TheFalconsReleaseAndGripAreDetected) {
    const FalconRun r = run_falcon(falcon_settings(), "release@1.0,grip@2.0", 3.0, 378.3, 15.49);
    const int release = first_tick(r.gripped, 1000, false);
    const int grip = first_tick(r.gripped, 2000, true);
    ASSERT_GE(release, 1000);
    ASSERT_GE(grip, 2000);
    // No false decision: held until the release, released from its detection to the grip.
    EXPECT_EQ(first_tick(r.gripped, 0, false), release);
    EXPECT_EQ(first_tick(r.gripped, release, true), grip);
    // The estimate while released: the regression's values where it decided (the release's transient) and the value it
    // holds at 2 s (the handle then rests in the wall's one-count limit cycle, below the excitation threshold).
    const double min_excitation = falcon_settings().min_excitation;
    double worst = 0;
    int n = 0;
    for (int j = release; j < 2000; ++j) {
        if (r.excitation[static_cast<std::size_t>(j)] < min_excitation) continue;
        worst = std::max(worst, std::abs(r.mass[static_cast<std::size_t>(j)] - 0.22));
        ++n;
    }
    const double held = r.mass[1999];
    std::printf(
        "release decided %d ms after it, grip %d ms after it; released estimate 0.22 kg %+.4f kg at 2 s, worst "
        "%.4f kg over the %d ticks it estimated\n",
        release - 1000, grip - 2000, held - 0.22, worst, n);
    double held_min = 1e9, held_max = 0;
    for (int j = grip; j < 3000; ++j) {
        if (r.excitation[static_cast<std::size_t>(j)] < min_excitation) continue;
        held_min = std::min(held_min, r.mass[static_cast<std::size_t>(j)]);
        held_max = std::max(held_max, r.mass[static_cast<std::size_t>(j)]);
    }
    std::printf(
        "held again (0.30 kg with the arm k_H 300 N/m, b_H 6 N s/m): the regression reads %.4f .. %.4f kg (biased "
        "by the arm)\n",
        held_min, held_max);
    ASSERT_GT(n, 0);
    // Within half the set's 10 % mass margin: a re-tuned wall for this estimate stays inside the certified set.
    EXPECT_LT(std::abs(held - 0.22), 0.05 * 0.22);
    // The decision needs 2h + confirm_release = 40 ticks of released data after the last held sample, and a grip
    // confirm_grip = 3 ticks of a residual beyond twice the bound after the kernel reaches the grip.
    EXPECT_LE(release - 1000, 2 * 10 + 20 + 20);
    EXPECT_LE(grip - 2000, 2 * 10 + 3 + 10);
}

// What it cannot see: a hand that holds the handle at rest off the wall with no force (the Rest intent, no wall)
// leaves nothing to tell it from a released handle: the decision reads "released" although the hand holds it.
TEST(OnlineMass, AHeldHandleAtRestWithoutForceReadsAsReleased) {
    const FalconRun r = run_falcon(falcon_settings(), "", 1.0, 0.0, 0.0, Scenario::Rest);
    const int release = first_tick(r.gripped, 0, false);
    std::printf("held at rest without force: decided released at tick %d (true mass %.2f kg)\n", release,
                r.true_mass.back());
    EXPECT_GE(release, 0);
    EXPECT_EQ(r.true_mass.back(), 0.30);
}

// The update is for the tick: no allocation over 5000 updates (the counting operator new of
// tests/common/counting_allocator.cpp).
TEST(OnlineMass, TheUpdateAllocatesNothing) {
    OnlineMassIdentifier id(falcon_settings());
    test::start_counting();
    for (int j = 0; j < 5000; ++j) id.update(1e-3 * std::sin(0.05 * j), std::cos(0.05 * j));
    const test::AllocationCounts counts = test::stop_counting();
    EXPECT_EQ(counts.allocations, 0U);
    EXPECT_GT(id.excitation(), 0.0);
}

TEST(OnlineMass, BadSettingsAreRefusedByName) {
    OnlineMassSettings s;
    s.period = 0;
    EXPECT_THROW(OnlineMassIdentifier{s}, std::invalid_argument);
    s = {};
    s.half_width = 0;
    EXPECT_THROW(OnlineMassIdentifier{s}, std::invalid_argument);
    s = {};
    s.mass_tolerance = 0.6;
    try {
        OnlineMassIdentifier id(s);
        ADD_FAILURE() << "accepted mass_tolerance = 0.6";
    } catch (const std::invalid_argument& e) {
        EXPECT_NE(std::string(e.what()).find("mass_tolerance"), std::string::npos) << e.what();
    }
    s = {};
    OnlineMassIdentifier id(s);
    id.update(std::nan(""), 1.0);  // ignored
    EXPECT_EQ(id.mass(), 0.0);
}

}  // namespace
}  // namespace hapticd
