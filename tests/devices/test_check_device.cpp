// SPDX-License-Identifier: Apache-2.0
// `hapticd check-device` (measure_force_sign) on the simulated device, on a simulated device whose force
// acts against its position axis (a miswired device, ForceSignDevice with -1), and the first-run limit.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <memory>

#include "devices/check_device.hpp"
#include "devices/device_factory.hpp"
#include "devices/first_run.hpp"
#include "devices/force_sign_device.hpp"
#include "devices/sim_device.hpp"

namespace hapticd {
namespace {

std::unique_ptr<Device> sim(std::size_t axes, double mass, double damping, double noise = 0.0) {
    SimDeviceConfig c;
    c.capabilities.axes = axes;
    c.capabilities.max_force = 9.0;
    c.plant = PlantParameters{mass, damping, 0.0};
    c.period = 1e-3;
    c.position_noise = noise;
    c.scenario.kind = Scenario::Step;
    c.scenario.step_force = 0.0;
    return std::make_unique<SimDevice>(c);
}

ForceSignResult run_sign_check(Device& d) {
    EXPECT_EQ(d.open(), DeviceStatus::Ok);
    EXPECT_EQ(d.home(), DeviceStatus::Ok);
    ForceSignSettings s;
    s.lockstep = true;
    return measure_force_sign(d, s);
}

TEST(CheckDevice, SimulatedDeviceHasSignPlusOneOnEveryAxis) {
    auto d = sim(3, 0.3, 0.0, 2e-6);
    const ForceSignResult r = run_sign_check(*d);
    ASSERT_TRUE(r.ok) << r.message;
    ASSERT_EQ(r.axes.size(), 3U);
    for (const AxisSign& a : r.axes) {
        EXPECT_EQ(a.sign, 1);
        // Free mass 0.3 kg, 0.5 N for 50 ticks of 1 ms (zero-order hold, read one tick later): x = F t^2 / (2 m)
        // = 0.5 * 0.05^2 / 0.6 = 2.083 mm. Tolerance 5 %: 2 um noise and where in the tick the read falls.
        EXPECT_NEAR(a.displacement, 0.5 * 0.05 * 0.05 / (2 * 0.3), 0.05 * 2.083e-3);
    }
}

TEST(CheckDevice, FlippedDeviceIsReportedAsSignMinusOne) {
    ForceSignDevice flipped(sim(2, 0.3, 1.0), AxisVector{1.0, -1.0, 1.0});
    const ForceSignResult r = run_sign_check(flipped);
    ASSERT_TRUE(r.ok) << r.message;
    ASSERT_EQ(r.axes.size(), 2U);
    EXPECT_EQ(r.axes[0].sign, 1);
    EXPECT_EQ(r.axes[1].sign, -1);
    EXPECT_LT(r.axes[1].displacement, -r.axes[1].threshold);
    // The profile fix (force_sign = [1, -1]) applied on top gives +1 again.
    ForceSignDevice fixed(std::make_unique<ForceSignDevice>(sim(2, 0.3, 1.0), AxisVector{1.0, -1.0, 1.0}),
                          AxisVector{1.0, -1.0, 1.0});
    const ForceSignResult again = run_sign_check(fixed);
    ASSERT_TRUE(again.ok);
    EXPECT_EQ(again.axes[1].sign, 1);
}

TEST(CheckDevice, BlockedHandleIsInconclusive) {
    // 1e6 kg: 0.5 N moves it 1.25e-9 m, far below the 2e-5 m threshold.
    auto d = sim(1, 1e6, 0.0);
    const ForceSignResult r = run_sign_check(*d);
    ASSERT_TRUE(r.ok);
    EXPECT_EQ(r.axes[0].sign, 0);
}

TEST(CheckDevice, RunawayHandleStopsWithZeroForce) {
    // 1 g: 0.5 N moves it 0.5 * 500 * 0.05^2 = 0.6 m, beyond the 0.02 m limit.
    auto d = sim(1, 1e-3, 0.0);
    const ForceSignResult r = run_sign_check(*d);
    EXPECT_FALSE(r.ok);
    EXPECT_NE(r.message.find("moved more than"), std::string::npos) << r.message;
}

TEST(CheckDevice, FirstRunLimitUntilConfirmed) {
    const auto dir = std::filesystem::temp_directory_path() / "hapticd_test_state_check_device";
    std::filesystem::remove_all(dir);
    ASSERT_EQ(setenv("HAPTICD_STATE_DIR", dir.c_str(), 1), 0);
    DeviceCapabilities c;
    c.max_force = 9.0;
    EXPECT_TRUE(apply_first_run_limit(c, "falcon", true));
    EXPECT_DOUBLE_EQ(c.max_force, kFirstRunMaxForce);
    std::string error;
    ASSERT_TRUE(record_force_sign_confirmed("falcon", "axis 0 sign 1", error)) << error;
    EXPECT_TRUE(force_sign_confirmed("falcon"));
    DeviceCapabilities again;
    again.max_force = 9.0;
    EXPECT_FALSE(apply_first_run_limit(again, "falcon", true));
    EXPECT_DOUBLE_EQ(again.max_force, 9.0);
    EXPECT_FALSE(force_sign_confirmed("openffboard"));  // per profile
    unsetenv("HAPTICD_STATE_DIR");
    std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace hapticd
