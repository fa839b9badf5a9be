// SPDX-License-Identifier: Apache-2.0
// The wall law, the delay ring and the scene (saturation, finiteness, fault latch).
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>

#include "scene/delay_ring.hpp"
#include "scene/force_limiter.hpp"
#include "scene/scene.hpp"
#include "scene/wall.hpp"

namespace hapticd {
namespace wall_scene {  // named: the sanitizer stage builds the tests as one unity file with test_scene_objects.cpp

constexpr double kT = 1e-3;

TEST(Wall, BilateralIsTheAnalysedLaw) {
    VirtualWall wall({0, 0.0, 1.0, WallMode::Bilateral}, 2000.0, 5.0, kT);
    const double xs[] = {0.0, 0.001, 0.0015, 0.0012, -0.0005};
    double prev = 0.0;
    for (double x : xs) {
        const double expected = 2000.0 * x + 5.0 * (x - prev) / kT;
        EXPECT_DOUBLE_EQ(wall.normal_force(x), expected);
        prev = x;
    }
}

TEST(Wall, FirstSampleHasNoVelocityEstimate) {
    VirtualWall wall({0, 0.0, 1.0, WallMode::Bilateral}, 1000.0, 10.0, kT);
    EXPECT_DOUBLE_EQ(wall.normal_force(0.002), 2.0);  // x_{-1} = x_0
}

TEST(Wall, UnilateralOnlyPushesOutAndOnlyInContact) {
    VirtualWall wall({0, 0.0, 1.0, WallMode::Unilateral}, 1000.0, 10.0, kT);
    EXPECT_EQ(wall.normal_force(-0.001), 0.0);                              // outside
    EXPECT_DOUBLE_EQ(wall.normal_force(0.0005), 0.5 + 10.0 * 0.0015 / kT);  // entering: the law
    EXPECT_EQ(wall.normal_force(0.0001), 0.0);                              // leaving fast: law < 0 -> 0 (no pulling)
    EXPECT_EQ(wall.normal_force(-0.002), 0.0);
}

TEST(Wall, DirectionAndPositionDefinePenetration) {
    VirtualWall wall({1, 0.01, -1.0, WallMode::Bilateral}, 1000.0, 0.0, kT);
    AxisVector p{0.0, 0.008, 0.0};  // 2 mm below a wall solid below 0.01
    EXPECT_NEAR(wall.penetration(p), 0.002, 1e-15);
    EXPECT_NEAR(wall.device_force(p), 2.0, 1e-12);  // pushes in +axis, out of the wall
}

TEST(Wall, RejectsInvalidGains) {
    EXPECT_THROW(VirtualWall({0, 0.0, 1.0, WallMode::Bilateral}, -1.0, 0.0, kT), std::invalid_argument);
    EXPECT_THROW(VirtualWall({0, 0.0, 1.0, WallMode::Bilateral}, std::nan(""), 0.0, kT), std::invalid_argument);
    EXPECT_THROW(VirtualWall({0, 0.0, 1.0, WallMode::Bilateral}, 1.0, 0.0, 0.0), std::invalid_argument);
    EXPECT_THROW(VirtualWall({0, 0.0, 0.5, WallMode::Bilateral}, 1.0, 0.0, kT), std::invalid_argument);
}

// The config walls' contact flags (Scene::contact_mask): bit i while the handle is behind wall i's surface
// (penetration > 0), whatever its mode and whether its law pushes; zero after a fault.
TEST(Scene, ContactFlagsAreThePenetrationSignsOfTheWalls) {
    std::vector<VirtualWall> walls;
    walls.emplace_back(WallGeometry{0, 0.01, 1.0, WallMode::Unilateral}, 1000.0, 10.0, kT);  // solid for x0 > 0.01
    walls.emplace_back(WallGeometry{1, 0.0, -1.0, WallMode::Bilateral}, 1000.0, 10.0, kT);   // solid for x1 < 0
    Scene scene(std::move(walls), 2, 100.0);
    AxisVector f{};
    ASSERT_EQ(scene.evaluate({0.0, 0.001, 0.0}, f), SceneFault::None);
    EXPECT_EQ(scene.contact_mask(), 0U);
    ASSERT_EQ(scene.evaluate({0.02, 0.001, 0.0}, f), SceneFault::None);
    EXPECT_EQ(scene.contact_mask(), 1U);
    ASSERT_EQ(scene.evaluate({0.02, -0.001, 0.0}, f), SceneFault::None);
    EXPECT_EQ(scene.contact_mask(), 3U);
    ASSERT_EQ(scene.evaluate({0.0, -0.001, 0.0}, f), SceneFault::None);
    EXPECT_EQ(scene.contact_mask(), 2U);
    ASSERT_EQ(scene.evaluate({std::numeric_limits<double>::quiet_NaN(), -0.001, 0.0}, f),
              SceneFault::NonFinitePosition);
    EXPECT_EQ(scene.contact_mask(), 0U);
}

TEST(DelayRing, DelaysByExactlyNSamples) {
    for (std::size_t n : {0U, 1U, 4U}) {
        DelayRing<double> ring(n);
        for (int j = 0; j < 20; ++j) {
            const double out = ring.push_pop(static_cast<double>(j + 1));
            const double expected = j < static_cast<int>(n) ? 0.0 : static_cast<double>(j + 1 - static_cast<int>(n));
            EXPECT_EQ(out, expected) << "n=" << n << " j=" << j;
        }
    }
}

TEST(WallSpec, ParsesAndRejectsWithNamedKeys) {
    std::string err;
    auto s = parse_wall_spec("axis=1 position=-0.5 direction=-1 mode=bilateral criterion=CE1", err);
    ASSERT_TRUE(s) << err;
    EXPECT_EQ(s->axis, 1U);
    EXPECT_EQ(s->position, -0.5);
    EXPECT_EQ(s->direction, -1.0);
    EXPECT_EQ(*s->mode, WallMode::Bilateral);
    EXPECT_EQ(*s->criterion, hapticopt::Criterion::CE1);
    EXPECT_EQ(to_string(*s), "axis=1 position=-0.5 direction=-1 mode=bilateral criterion=CE1");
    // The criterion is parsed here (exact, case-sensitive): another name is refused with the accepted ones.
    auto ov = parse_wall_spec("axis=0 criterion=CE2+OV", err);
    ASSERT_TRUE(ov) << err;
    EXPECT_EQ(*ov->criterion, hapticopt::Criterion::CE2_OV);
    EXPECT_FALSE(parse_wall_spec("axis=0 criterion=ce2", err));
    EXPECT_EQ(err,
              "wall 'axis=0 criterion=ce2': criterion = ce2 is invalid; accepted: amax, OV, CE0, CE1, CE2, "
              "CE0+OV, CE1+OV, CE2+OV");
    EXPECT_FALSE(parse_wall_spec("axis=3", err));
    EXPECT_NE(err.find("axis = 3"), std::string::npos) << err;
    EXPECT_FALSE(parse_wall_spec("position=nan", err));
    EXPECT_NE(err.find("position"), std::string::npos) << err;
    EXPECT_FALSE(parse_wall_spec("stiff=3", err));
    EXPECT_NE(err.find("unknown key 'stiff'"), std::string::npos) << err;
    EXPECT_FALSE(parse_wall_spec("", err));
}

// Property: whatever the position sequence, the scene's force is finite, and within the saturation once through
// the force limiter (the daemon's last stage, the only one that saturates); a non-finite position (or a force that
// would overflow) gives zero force and latches the fault.
TEST(SceneProperty, ForceAlwaysFiniteAndSaturatedByTheLimiter) {
    const double fmax = 7.5;
    std::mt19937_64 rng(12345);
    std::uniform_real_distribution<double> small(-0.05, 0.05);
    std::uniform_real_distribution<double> exponent(-300.0, 300.0);
    const double specials[] = {
        0.0,   -0.0, 1e308, -1e308, std::numeric_limits<double>::max(), std::numeric_limits<double>::denorm_min(),
        1e-320};
    for (int trial = 0; trial < 200; ++trial) {
        std::vector<VirtualWall> walls;
        walls.emplace_back(WallGeometry{0, 0.0, 1.0, trial % 2 ? WallMode::Bilateral : WallMode::Unilateral}, 3e4, 30.0,
                           kT);
        walls.emplace_back(WallGeometry{0, 0.01, -1.0, WallMode::Unilateral}, 1e5, 100.0, kT);
        walls.emplace_back(WallGeometry{2, 0.0, 1.0, WallMode::Bilateral}, 1e9, 1e6, kT);
        Scene scene(std::move(walls), 3, fmax);
        ForceLimiter limiter(fmax, default_max_force_rate(fmax, kT), kT, 3);
        for (int j = 0; j < 500; ++j) {
            AxisVector p{};
            for (auto& v : p) {
                switch (rng() % 4) {
                    case 0:
                        v = small(rng);
                        break;
                    case 1:
                        v = std::copysign(std::pow(10.0, exponent(rng)), small(rng));
                        break;
                    case 2:
                        v = specials[rng() % std::size(specials)];
                        break;
                    default:
                        v = (j % 2 ? 1.0 : -1.0) * 0.02;
                        break;  // adversarial alternation
                }
            }
            AxisVector f{1.0, 1.0, 1.0};
            const SceneFault fault = scene.evaluate(p, f);
            for (double v : f) ASSERT_TRUE(std::isfinite(v));
            for (double v : limiter.step(f, LawChange{})) ASSERT_LE(std::abs(v), fmax);
            if (fault != SceneFault::None) {
                for (double v : f) ASSERT_EQ(v, 0.0);
            }
        }
    }
}

TEST(SceneProperty, NonFinitePositionZeroForceAndLatchedFault) {
    for (double bad :
         {std::nan(""), std::numeric_limits<double>::infinity(), -std::numeric_limits<double>::infinity()}) {
        std::vector<VirtualWall> walls;
        walls.emplace_back(WallGeometry{0, 0.0, 1.0, WallMode::Bilateral}, 1000.0, 1.0, kT);
        Scene scene(std::move(walls), 2, 10.0);
        AxisVector f{};
        EXPECT_EQ(scene.evaluate({0.001, 0.0, 0.0}, f), SceneFault::None);
        EXPECT_GT(std::abs(f[0]), 0.0);
        EXPECT_EQ(scene.evaluate({0.001, bad, 0.0}, f), SceneFault::NonFinitePosition);  // any active axis
        EXPECT_EQ(f, AxisVector{});
        EXPECT_EQ(scene.evaluate({0.001, 0.0, 0.0}, f), SceneFault::NonFinitePosition);  // latched
        EXPECT_EQ(f, AxisVector{});
        scene.reset();
        EXPECT_EQ(scene.evaluate({0.001, 0.0, 0.0}, f), SceneFault::None);
    }
}

TEST(SceneProperty, OverflowingForceIsAFault) {
    std::vector<VirtualWall> walls;
    walls.emplace_back(WallGeometry{0, 0.0, 1.0, WallMode::Bilateral}, 1e12, 1e12, kT);
    Scene scene(std::move(walls), 1, 10.0);
    AxisVector f{};
    EXPECT_EQ(scene.evaluate({1e300, 0.0, 0.0}, f), SceneFault::NonFiniteForce);
    EXPECT_EQ(f, AxisVector{});
}

// The scene gives the walls' sum as the law asks; the force limiter saturates it (and counts).
TEST(SceneProperty, TheSceneDoesNotSaturateTheForceLimiterDoes) {
    std::vector<VirtualWall> walls;
    walls.emplace_back(WallGeometry{0, 0.0, 1.0, WallMode::Bilateral}, 1e4, 0.0, kT);
    Scene scene(std::move(walls), 1, 5.0);
    ForceLimiter limiter(scene.max_force(), 4999.0, kT, 1);
    AxisVector f{};
    scene.evaluate({0.01, 0.0, 0.0}, f);  // 100 N asked
    EXPECT_EQ(f[0], -100.0);
    // The wall appears (a whole change): saturated to 5 N, then one step of 4.999 N from zero; the offset left,
    // 1 mN, decays at the next tick.
    EXPECT_DOUBLE_EQ(limiter.step(f, LawChange::whole_change())[0], -4.999);
    EXPECT_EQ(limiter.step(f, LawChange{})[0], -5.0);
    EXPECT_EQ(limiter.stats().saturated_ticks, 2U);
    EXPECT_EQ(limiter.stats().rate_limited_ticks, 1U);
}

TEST(Scene, RejectsWallOnMissingAxis) {
    std::vector<VirtualWall> walls;
    walls.emplace_back(WallGeometry{2, 0.0, 1.0, WallMode::Bilateral}, 1.0, 0.0, kT);
    EXPECT_THROW(Scene(std::move(walls), 1, 5.0), std::invalid_argument);
}

}  // namespace wall_scene
}  // namespace hapticd
