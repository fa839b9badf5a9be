// SPDX-License-Identifier: Apache-2.0
// The loop's velocity estimate (scene/velocity_filter.hpp) against the estimators' closed forms on inputs whose
// estimate is known exactly, and the scene's walls and client objects with it.
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <stdexcept>

#include "common/velocity_estimator_spec.hpp"
#include "loop/spsc_ring.hpp"
#include "scene/scene.hpp"
#include "scene/scene_objects.hpp"
#include "scene/velocity_filter.hpp"

namespace hapticd {
namespace velocity_filter_tests {  // named: unity builds

constexpr double kT = 1e-3;

VelocityEstimatorSpec spec_of(const char* text) {
    std::string error;
    const auto spec = parse_velocity_estimator(text, error);
    EXPECT_TRUE(spec.has_value()) << error;
    return spec.value_or(VelocityEstimatorSpec{});
}

TEST(VelocityEstimatorSpec, ParsesTheThreeFormsAndReadsItsOwnText) {
    for (const char* text : {"backward", "lowpass:50Hz", "lowpass:12.5Hz", "window:1", "window:50"}) {
        const VelocityEstimatorSpec spec = spec_of(text);
        std::string error;
        EXPECT_EQ(parse_velocity_estimator(to_string(spec), error), spec) << text;
    }
    EXPECT_EQ(spec_of("lowpass:12.5Hz").cutoff_hz, 12.5);
    EXPECT_EQ(spec_of("window:15").window, 15);
}

TEST(VelocityEstimatorSpec, RefusesOtherTextNamingTheKeyAndTheForms) {
    for (const char* text :
         {"", "Backward", "lowpass", "lowpass:", "lowpass:50", "lowpass:0Hz", "lowpass:-3Hz", "lowpass:nanHz",
          "lowpass:infHz", "lowpass:5Hzz", "window:0", "window:51", "window:1.5", "window:", "window:-2", "median:3"}) {
        std::string error;
        EXPECT_FALSE(parse_velocity_estimator(text, error).has_value()) << text;
        EXPECT_NE(error.find("velocity_estimator"), std::string::npos) << error;
        EXPECT_NE(error.find("window:<N>"), std::string::npos) << error;
    }
}

TEST(VelocityFilter, TheFirstUpdateIsZeroAndAStepIsSeenAsTheEstimatorsDifference) {
    // A position step of h at tick 1: backward sees h / T once; a window of N sees h / (N T) for N ticks.
    const double h = 2e-4;
    VelocityFilter backward(spec_of("backward"), kT);
    VelocityFilter window(spec_of("window:4"), kT);
    EXPECT_EQ(backward.update({0.3, 0.0, 0.0})[0], 0.0);
    EXPECT_EQ(window.update({0.3, 0.0, 0.0})[0], 0.0);
    for (int j = 1; j <= 6; ++j) {
        const double b = backward.update({0.3 + h, 0.0, 0.0})[0];
        const double w = window.update({0.3 + h, 0.0, 0.0})[0];
        // One rounding of (0.3 + h) - 0.3 and one of the scale: 4 eps relative.
        EXPECT_NEAR(b, j == 1 ? h / kT : 0.0, 4e-16 * 0.3 / kT) << j;
        EXPECT_NEAR(w, j <= 4 ? h / (4 * kT) : 0.0, 4e-16 * 0.3 / kT) << j;
    }
}

TEST(VelocityFilter, TheLowPassOfARampApproachesItsSlopeAsOneMinusLambdaToTheJ) {
    // x_j = s j T: the backward difference is s from tick 1 on, so v_j = s (1 - l^j) (a geometric sum).
    const double s = 0.05, f = 50.0;
    const double lambda = std::exp(-2.0 * std::numbers::pi * f * kT);
    VelocityFilter lowpass(spec_of("lowpass:50Hz"), kT);
    double worst = 0.0;
    for (int j = 0; j < 400; ++j) {
        const double v = lowpass.update({s * j * kT, -s * j * kT, 0.0})[0];
        worst = std::max(worst, std::abs(v - s * (1.0 - std::pow(lambda, j))));
    }
    // Each difference carries ~eps |x| / T of rounding (|x| <= 0.02 m); the filter sums them with weights
    // (1 - l) l^k, total 1: 1e-12 m/s leaves a margin of ~100 over 2 eps x 0.02 / T.
    EXPECT_LT(worst, 1e-12);
}

TEST(VelocityFilter, AWindowOfOneIsTheBackwardDifferenceBitForBit) {
    VelocityFilter one(spec_of("window:1"), kT);
    VelocityFilter backward(spec_of("backward"), kT);
    for (int j = 0; j < 50; ++j) {
        const AxisVector x{std::sin(0.1 * j), 1e-3 * j * j, std::cos(0.37 * j)};
        EXPECT_EQ(one.update(x), backward.update(x)) << j;
    }
}

TEST(VelocityFilter, ResetStartsFromRestAgain) {
    VelocityFilter lowpass(spec_of("lowpass:20Hz"), kT);
    lowpass.update({0.0, 0.0, 0.0});
    lowpass.update({1e-3, 0.0, 0.0});
    EXPECT_NE(lowpass.velocity()[0], 0.0);
    lowpass.reset();
    EXPECT_EQ(lowpass.update({5e-3, 0.0, 0.0})[0], 0.0);
    EXPECT_EQ(lowpass.update({5e-3, 0.0, 0.0})[0], 0.0);
}

TEST(VelocityFilter, RefusesAnInvalidPeriodCutoffOrWindowNamingIt) {
    VelocityEstimatorSpec bad_cutoff;
    bad_cutoff.kind = hapticopt::VelocityEstimatorKind::lowpass;
    bad_cutoff.cutoff_hz = -1.0;
    VelocityEstimatorSpec bad_window;
    bad_window.kind = hapticopt::VelocityEstimatorKind::window;
    bad_window.window = kMaxLoopVelocityWindow + 1;
    auto message = [](auto make) {
        try {
            make();
        } catch (const std::invalid_argument& e) {
            return std::string(e.what());
        }
        return std::string("no exception");
    };
    EXPECT_NE(message([] { VelocityFilter(VelocityEstimatorSpec{}, 0.0); }).find("period"), std::string::npos);
    EXPECT_NE(message([&] { VelocityFilter(bad_cutoff, kT); }).find("cutoff"), std::string::npos);
    EXPECT_NE(message([&] { VelocityFilter(bad_window, kT); }).find("window"), std::string::npos);
}

TEST(VelocityFilter, ConfigWallsDampTheirAxisEstimateAlongTheirNormal) {
    // Two bilateral walls on axis 1, facing each other: f = -d (K x + B d v_1) each, x = d (p - position).
    const VelocityEstimatorSpec spec = spec_of("window:3");
    std::vector<VirtualWall> walls;
    walls.emplace_back(WallGeometry{1, 0.01, 1.0, WallMode::Bilateral}, 1000.0, 5.0, kT);
    walls.emplace_back(WallGeometry{1, 0.02, -1.0, WallMode::Bilateral}, 700.0, 3.0, kT);
    Scene scene(std::move(walls), 3, 1e6, spec, kT);
    VelocityFilter reference(spec, kT);
    for (int j = 0; j < 20; ++j) {
        const AxisVector p{0.0, 0.015 + 1e-4 * std::sin(0.3 * j), 0.0};
        AxisVector force{};
        ASSERT_EQ(scene.evaluate(p, force), SceneFault::None);
        const double v = reference.update(p)[1];
        const double x1 = p[1] - 0.01, x2 = 0.02 - p[1];
        const double expected = -(1000.0 * x1 + 5.0 * v) + (700.0 * x2 + 3.0 * (-v));
        // A few roundings of terms up to ~10 N: 1e-13 N.
        EXPECT_NEAR(force[1], expected, 1e-13) << j;
        EXPECT_EQ(force[0], 0.0);
    }
}

TEST(VelocityFilter, ClientObjectsDampTheLoopsEstimate) {
    // A bilateral plane along x: f = n (K (offset - n.x) - B n.v) with v the configured estimate.
    SceneObjectsConfig config;
    config.ramp_time = 0.0;
    config.velocity = spec_of("lowpass:30Hz");
    CommitRing ring(4);
    SceneObjects objects(config, ring);
    ObjectCommit commit;
    commit.seq = 1;
    commit.count = 1;
    commit.updates[0].slot = 0;
    commit.updates[0].action = SlotUpdate::Action::Set;
    ObjectParams& plane = commit.updates[0].params;
    plane.id = 7;
    plane.kind = ObjectKind::Plane;
    plane.bilateral = true;
    plane.direction = {1.0, 0.0, 0.0};
    plane.offset = 0.0;
    plane.K = 800.0;
    plane.B = 4.0;
    ASSERT_TRUE(ring.try_push(commit));
    VelocityFilter reference(config.velocity, kT);
    for (int j = 0; j < 30; ++j) {
        objects.apply_commits();
        const AxisVector p{-1e-3 + 5e-5 * j, 0.0, 0.0};
        AxisVector force{};
        ASSERT_TRUE(objects.add_forces(p, force));
        const double v = reference.update(p)[0];
        EXPECT_NEAR(force[0], 800.0 * (-p[0]) - 4.0 * v, 1e-12) << j;
        EXPECT_EQ(objects.velocity()[0], v);
    }
}

}  // namespace velocity_filter_tests
}  // namespace hapticd
