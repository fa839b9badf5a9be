// SPDX-License-Identifier: Apache-2.0
// WallRetuner (src/daemon/wall_retuner.hpp), --retune's part of the tick: the dwell rule holds however fast the
// identifier's decision flips, the scene's gains are the active row's, and a tick allocates nothing.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <stdexcept>
#include <random>
#include <vector>

#include "common/counting_allocator.hpp"
#include "daemon/wall_retuner.hpp"
#include "scene/scene.hpp"

namespace hapticd {
namespace {

constexpr double kPeriod = 1e-3;

Scene two_walls() {
    std::vector<VirtualWall> walls;
    walls.emplace_back(WallGeometry{0, 0.0, 1.0, WallMode::Bilateral}, 400.0, 15.0, kPeriod);
    walls.emplace_back(WallGeometry{1, 0.01, -1.0, WallMode::Unilateral}, 400.0, 15.0, kPeriod);
    return Scene(std::move(walls), 3, 9.0);
}

WallRetuner retuner(std::uint64_t min_gap) {
    OnlineMassSettings s;
    s.delay_ticks = 6;
    return WallRetuner(s, 0, min_gap, GainRow{{400.0, 400.0}, {15.0, 15.0}}, GainRow{{290.0, 280.0}, {11.0, 10.0}});
}

// The decision flips every tick, then at random intervals of 1 .. 300 ticks, for 200000 ticks: the switches are
// never closer than min_gap (the first is free), each goes to the row the decision names at its tick, there is one
// within min_gap + 1 ticks of every disagreement, and the scene's gains are the active row's at every tick.
TEST(WallRetuner, NeverSwitchesCloserThanTheGapHoweverFastTheDecisionFlips) {
    constexpr std::uint64_t kGap = 1000;
    Scene scene = two_walls();
    WallRetuner r = retuner(kGap);
    std::mt19937 rng(7);
    std::uniform_int_distribution<int> run(1, 300);
    bool gripped = true;
    int left = 1;
    std::uint64_t flips = 0, disagreeing_since = 0;
    bool disagreeing = false;
    std::vector<std::uint64_t> ticks;
    for (std::uint64_t tick = 0; tick < 200000; ++tick) {
        if (--left == 0) {
            gripped = !gripped;
            ++flips;
            left = tick < 20000 ? 1 : run(rng);
        }
        const bool switched = r.decide(tick, gripped, scene);
        if (switched) {
            ticks.push_back(tick);
            EXPECT_EQ(r.row(), gripped ? WallRetuner::kHeld : WallRetuner::kReleased) << tick;
        }
        const bool agrees = r.row() == (gripped ? WallRetuner::kHeld : WallRetuner::kReleased);
        if (!agrees && !disagreeing) disagreeing_since = tick;
        disagreeing = !agrees;
        if (disagreeing) {
            ASSERT_LE(tick - disagreeing_since, kGap) << "a disagreement outlasted the gap at tick " << tick;
        }
        const GainRow& g = r.gains(r.row());
        for (std::size_t i = 0; i < 2; ++i) {
            ASSERT_EQ(scene.walls()[i].stiffness(), g.stiffness[i]) << tick;
            ASSERT_EQ(scene.walls()[i].damping(), g.damping[i]) << tick;
        }
    }
    ASSERT_GE(ticks.size(), 100U);
    EXPECT_GT(flips, 10 * ticks.size());
    EXPECT_EQ(r.switch_count(), ticks.size());
    ASSERT_EQ(r.stored_switches(), ticks.size());
    for (std::size_t i = 0; i < ticks.size(); ++i) {
        EXPECT_EQ(r.switches()[i].tick, ticks[i]);
        if (i > 0) {
            ASSERT_GE(ticks[i] - ticks[i - 1], kGap) << i;
        }
    }
}

// update() runs the identifier and the rule in the tick: no allocation over 10000 ticks of a moving handle.
TEST(WallRetuner, ATickAllocatesNothing) {
    Scene scene = two_walls();
    WallRetuner r = retuner(50);
    AxisVector position{}, force{};
    test::start_counting();
    for (std::uint64_t tick = 0; tick < 10000; ++tick) {
        position[0] = 1e-3 * std::sin(0.01 * static_cast<double>(tick));
        force[0] = tick % 3000 < 1500 ? -0.4 * position[0] * 1e3 : 0.0;
        scene.evaluate(position, force);
        r.update(tick, position, force, scene);
    }
    const test::AllocationCounts c = test::stop_counting();
    EXPECT_EQ(c.allocations, 0U);
    EXPECT_EQ(c.releases, 0U);
    EXPECT_GE(r.switch_count(), 1U);  // the identifier decided released in the force-free halves
}

TEST(WallRetuner, RefusesRowsOfDifferentSizesAndAZeroGap) {
    OnlineMassSettings s;
    EXPECT_THROW(WallRetuner(s, 0, 0, GainRow{{1.0}, {1.0}}, GainRow{{1.0}, {1.0}}), std::invalid_argument);
    EXPECT_THROW(WallRetuner(s, 0, 10, GainRow{{1.0}, {1.0}}, GainRow{{1.0, 2.0}, {1.0, 2.0}}), std::invalid_argument);
    EXPECT_THROW(WallRetuner(s, 3, 10, GainRow{{1.0}, {1.0}}, GainRow{{1.0}, {1.0}}), std::invalid_argument);
}

}  // namespace
}  // namespace hapticd
