// SPDX-License-Identifier: Apache-2.0
// The simulated device against closed-form solutions of the continuous plant.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "devices/sim_device.hpp"

namespace hapticd {
namespace {

SimDeviceConfig base(double mass, double damping, double stiffness, double delay = 0.0) {
    SimDeviceConfig c;
    c.capabilities.axes = 1;
    c.capabilities.max_force = 100.0;
    c.capabilities.inherent_delay = delay;
    c.plant = {mass, damping, stiffness};
    c.period = 1e-3;
    return c;
}

TEST(SimDevice, FreeMassStepIsExactParabola) {
    auto c = base(0.3, 0.0, 0.0);
    c.scenario.kind = Scenario::Step;
    c.scenario.step_force = 2.0;
    SimDevice dev(c);
    ASSERT_EQ(dev.open(), DeviceStatus::Ok);
    ASSERT_EQ(dev.home(), DeviceStatus::Ok);
    for (int j = 0; j < 200; ++j) {
        AxisVector p{};
        ASSERT_EQ(dev.read_position(p), DeviceStatus::Ok);
        const double t = j * 1e-3;
        EXPECT_NEAR(p[0], 2.0 * t * t / (2 * 0.3), 1e-13 * (1 + t * t / 0.6 * 2)) << j;
        ASSERT_EQ(dev.write_force(AxisVector{}), DeviceStatus::Ok);
    }
}

TEST(SimDevice, SpringStepIsExactCosine) {
    const double m = 0.065, k = 400.0;
    auto c = base(m, 0.0, k);
    c.scenario.surface = 0.1;  // spring rest at the surface
    SimDevice dev(c);
    ASSERT_EQ(dev.open(), DeviceStatus::Ok);
    const double w = std::sqrt(k / m);
    for (int j = 0; j < 500; ++j) {
        AxisVector p{};
        ASSERT_EQ(dev.read_position(p), DeviceStatus::Ok);
        const double t = j * 1e-3;
        EXPECT_NEAR(p[0] - 0.1, (1.0 / k) * (1.0 - std::cos(w * t)), 1e-14) << j;
        ASSERT_EQ(dev.write_force(AxisVector{}), DeviceStatus::Ok);
    }
}

// A force written from tick 0 on acts after the inherent delay, also a non-integer one
// (the period is then integrated in two exact sub-intervals).
TEST(SimDevice, InherentDelayIntegerAndFractional) {
    for (double delay_periods : {0.0, 1.0, 2.0, 0.25, 1.5, 2.75}) {
        auto c = base(0.22, 0.0, 0.0, delay_periods * 1e-3);
        c.scenario.kind = Scenario::Hold;
        c.scenario.hold_force = 0.0;
        c.scenario.hold_distance = 0.0;
        SimDevice dev(c);
        ASSERT_EQ(dev.open(), DeviceStatus::Ok);
        const double u = 1.5;
        for (int j = 0; j < 50; ++j) {
            AxisVector p{};
            ASSERT_EQ(dev.read_position(p), DeviceStatus::Ok);
            const double t = j * 1e-3;
            const double td = delay_periods * 1e-3;
            const double expected = t > td ? u * (t - td) * (t - td) / (2 * 0.22) : 0.0;
            EXPECT_NEAR(p[0], expected, 1e-15 + 1e-12 * expected) << "d=" << delay_periods << " j=" << j;
            ASSERT_EQ(dev.write_force({u, 0.0, 0.0}), DeviceStatus::Ok);
        }
    }
}

TEST(SimDevice, PushStartsOutsideMovingIn) {
    auto c = base(0.3, 0.0, 0.0);
    c.scenario.kind = Scenario::Push;
    c.scenario.direction = -1.0;
    c.scenario.surface = 0.01;
    c.scenario.push_distance = 0.002;
    c.scenario.push_speed = 0.1;
    SimDevice dev(c);
    ASSERT_EQ(dev.open(), DeviceStatus::Ok);
    AxisVector p{};
    ASSERT_EQ(dev.read_position(p), DeviceStatus::Ok);
    EXPECT_DOUBLE_EQ(p[0], 0.012);
    ASSERT_EQ(dev.write_force(AxisVector{}), DeviceStatus::Ok);
    ASSERT_EQ(dev.read_position(p), DeviceStatus::Ok);
    EXPECT_NEAR(p[0], 0.012 - 0.1e-3, 1e-15);
}

TEST(SimDevice, NoiseIsDeterministicAndQuantised) {
    auto c = base(0.3, 0.0, 0.0);
    c.position_noise = 1e-5;
    c.position_resolution = {1e-6, 1e-6, 1e-6};
    c.noise_seed = 42;
    SimDevice a(c);
    SimDevice b(c);
    ASSERT_EQ(a.open(), DeviceStatus::Ok);
    ASSERT_EQ(b.open(), DeviceStatus::Ok);
    bool any_nonzero = false;
    for (int j = 0; j < 100; ++j) {
        AxisVector pa{};
        AxisVector pb{};
        ASSERT_EQ(a.read_position(pa), DeviceStatus::Ok);
        ASSERT_EQ(b.read_position(pb), DeviceStatus::Ok);
        EXPECT_EQ(pa[0], pb[0]);
        EXPECT_NEAR(pa[0] / 1e-6, std::round(pa[0] / 1e-6), 1e-6);
        any_nonzero = any_nonzero || pa[0] != 0.0;
        ASSERT_EQ(a.write_force(AxisVector{}), DeviceStatus::Ok);
        ASSERT_EQ(b.write_force(AxisVector{}), DeviceStatus::Ok);
    }
    EXPECT_TRUE(any_nonzero);
}

TEST(SimDevice, ErrorsAreStatusValues) {
    auto c = base(0.3, 0.0, 0.0);
    c.fail_at_tick = 3;
    SimDevice dev(c);
    AxisVector p{};
    EXPECT_EQ(dev.read_position(p), DeviceStatus::NotOpen);
    ASSERT_EQ(dev.open(), DeviceStatus::Ok);
    EXPECT_EQ(dev.write_force(AxisVector{}), DeviceStatus::NotHomed);  // nothing read yet
    ASSERT_EQ(dev.read_position(p), DeviceStatus::Ok);
    EXPECT_EQ(dev.write_force({std::nan(""), 0, 0}), DeviceStatus::InvalidArgument);
    EXPECT_EQ(dev.write_force({101.0, 0, 0}), DeviceStatus::InvalidArgument);
    EXPECT_EQ(dev.write_force({100.0, 0, 0}), DeviceStatus::Ok);
    ASSERT_EQ(dev.read_position(p), DeviceStatus::Ok);
    ASSERT_EQ(dev.read_position(p), DeviceStatus::Ok);
    EXPECT_EQ(dev.read_position(p), DeviceStatus::Disconnected);
    EXPECT_NE(dev.last_error().find("disconnected"), std::string::npos);
    dev.close();
    EXPECT_EQ(dev.read_position(p), DeviceStatus::NotOpen);
}

}  // namespace
}  // namespace hapticd
