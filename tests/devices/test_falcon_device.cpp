// SPDX-License-Identifier: Apache-2.0
// FalconDevice against the scripted Falcon: firmware detection/upload, the homing gate, positions,
// torques and their clamping, malformed packets, disconnects.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>

#include "daemon/daemon.hpp"
#include "devices/falcon_device.hpp"
#include "fake_falcon.hpp"
#include "scene/scene.hpp"
#include "scene/wall.hpp"

namespace hapticd {
namespace {

using test::FakeFalcon;

class FalconDeviceTest : public ::testing::Test {
  protected:
    FalconDeviceConfig config() {
        FalconDeviceConfig c;
        c.capabilities.axes = 3;
        c.capabilities.max_force = 9.0;
        c.homing_poll_ms = 0;
        c.homing_timeout = 0.2;  // 200 polls at the 1 ms nominal poll period
        c.open_transport = [this] { return fake.open(); };
        c.notify = [this](const std::string& m) { notices.push_back(m); };
        return c;
    }
    FakeFalcon fake;
    std::vector<std::string> notices;
};

TEST_F(FalconDeviceTest, RunningFirmwareIsDetectedAndHomingGatesForce) {
    fake.firmware_running = true;
    fake.packets_until_homed = 20;
    FalconDevice dev(config());
    ASSERT_EQ(dev.open(), DeviceStatus::Ok) << dev.last_error();
    EXPECT_FALSE(dev.homed());
    // Before homing: no force, whatever is asked.
    AxisVector pos{};
    EXPECT_EQ(dev.write_force({1.0, 2.0, 3.0}), DeviceStatus::NotHomed);
    EXPECT_EQ(fake.commands.back().torque, (std::array<std::int16_t, 3>{0, 0, 0}));

    ASSERT_EQ(dev.home(), DeviceStatus::Ok) << dev.last_error();
    EXPECT_TRUE(dev.homed());
    ASSERT_FALSE(notices.empty());
    EXPECT_NE(notices.front().find("pull the grip all the way out"), std::string::npos);
    // Every homing packet had the homing bit and the red LED; afterwards the LED is green.
    for (const auto& c : fake.commands) EXPECT_TRUE(c.homing_mode);
    // Red while homing (after the firmware probe's LED-less packets), green once homed.
    const auto first_lit =
        std::find_if(fake.commands.begin(), fake.commands.end(), [](const auto& c) { return c.leds != 0; });
    ASSERT_NE(first_lit, fake.commands.end());
    EXPECT_EQ(first_lit->leds, falcon::kLedRed);
    EXPECT_EQ(fake.commands.back().leds, falcon::kLedGreen);
    // Then the grip had to be pulled out before forces (libnifalcon FalconCubeTest.cpp: z > 0.170 m).
    bool asked_to_pull_out = false;
    for (const auto& n : notices)
        asked_to_pull_out = asked_to_pull_out || n.find("pull the grip out towards you") != std::string::npos;
    EXPECT_TRUE(asked_to_pull_out);
    for (const auto& c : fake.commands) EXPECT_EQ(c.torque, (std::array<std::int16_t, 3>{0, 0, 0}));
    EXPECT_EQ(dev.write_force({0.0, 0.0, 0.0}), DeviceStatus::Ok);
    EXPECT_EQ(fake.commands.back().leds, falcon::kLedGreen);
    EXPECT_TRUE(fake.commands.back().homing_mode);
    EXPECT_EQ(dev.read_position(pos), DeviceStatus::Ok);
}

TEST_F(FalconDeviceTest, MissingFirmwareFileIsAClearError) {
    FalconDevice dev(config());
    EXPECT_EQ(dev.open(), DeviceStatus::HardwareFault);
    EXPECT_NE(dev.last_error().find("--falcon-firmware"), std::string::npos) << dev.last_error();
}

TEST_F(FalconDeviceTest, FirmwareIsUploadedFromTheGivenFile) {
    const auto path = std::filesystem::temp_directory_path() / "hapticd_test_falcon_fw.bin";
    {
        std::ofstream out(path, std::ios::binary);
        for (int i = 0; i < 500; ++i) out.put(static_cast<char>(i * 7));
    }
    fake.firmware_size = 500;
    fake.packets_until_homed = 0;
    FalconDeviceConfig c = config();
    c.firmware_path = path.string();
    FalconDevice dev(c);
    ASSERT_EQ(dev.open(), DeviceStatus::Ok) << dev.last_error();
    EXPECT_EQ(fake.upload_attempts, 1);
    ASSERT_GE(notices.size(), 2U);
    EXPECT_NE(notices[0].find("uploading"), std::string::npos);
    EXPECT_TRUE(fake.firmware_running);
    EXPECT_EQ(dev.home(), DeviceStatus::Ok) << dev.last_error();
    std::filesystem::remove(path);
}

TEST_F(FalconDeviceTest, HomingTimesOutWithInstructions) {
    fake.firmware_running = true;
    fake.packets_until_homed = -1;
    fake.status.homed_mask = 0b101;  // motor 2 never homes
    FalconDevice dev(config());
    ASSERT_EQ(dev.open(), DeviceStatus::Ok);
    EXPECT_EQ(dev.home(), DeviceStatus::NotHomed);
    EXPECT_NE(dev.last_error().find("pull the grip"), std::string::npos);
    EXPECT_NE(dev.last_error().find("motor(s) 2 not homed"), std::string::npos) << dev.last_error();
    EXPECT_EQ(dev.write_force({0.0, 0.0, 1.0}), DeviceStatus::NotHomed);
    EXPECT_EQ(fake.commands.back().torque, (std::array<std::int16_t, 3>{0, 0, 0}));
}

// After homing the grip sits at the homing pose (pushed in); no force until it has been pulled out.
TEST_F(FalconDeviceTest, ForcesOnlyAfterTheGripLeftTheHomingPose) {
    fake.firmware_running = true;
    fake.packets_until_pulled_out = 40;
    FalconDevice dev(config());
    ASSERT_EQ(dev.open(), DeviceStatus::Ok);
    ASSERT_EQ(dev.home(), DeviceStatus::Ok) << dev.last_error();
    // 40 packets after the homed flags the encoders moved to z = 0.175 m: home() waited for them, with
    // zero torque throughout.
    ASSERT_GE(fake.commands.size(), 40U);
    for (const auto& c : fake.commands) EXPECT_EQ(c.torque, (std::array<std::int16_t, 3>{0, 0, 0}));
    AxisVector pos{};
    ASSERT_EQ(dev.write_force({}), DeviceStatus::Ok);
    ASSERT_EQ(dev.read_position(pos), DeviceStatus::Ok);
    EXPECT_NEAR(pos[2], 0.175 - 0.125, 1e-4);  // 1e-4 m: encoder quantisation (~4e-5 m per count here)
}

TEST_F(FalconDeviceTest, GripNeverPulledOutMeansNoForceAndAClearError) {
    fake.firmware_running = true;
    fake.packets_until_pulled_out = -1;
    FalconDevice dev(config());
    ASSERT_EQ(dev.open(), DeviceStatus::Ok);
    EXPECT_EQ(dev.home(), DeviceStatus::NotHomed);
    EXPECT_NE(dev.last_error().find("not pulled out"), std::string::npos) << dev.last_error();
    for (const auto& c : fake.commands) EXPECT_EQ(c.torque, (std::array<std::int16_t, 3>{0, 0, 0}));
}

// libnifalcon (FalconCLIBase.cpp) tries the firmware upload 10 times; hapticd reopens the device between
// attempts. Here the first 4 attempts get a corrupted echo.
TEST_F(FalconDeviceTest, FirmwareUploadIsRetriedWithAReopen) {
    const auto path = std::filesystem::temp_directory_path() / "hapticd_test_falcon_fw_retry.bin";
    {
        std::ofstream out(path, std::ios::binary);
        for (int i = 0; i < 200; ++i) out.put(static_cast<char>(i * 3));
    }
    fake.firmware_size = 200;
    fake.corrupt_echo_attempts = 4;
    FalconDeviceConfig c = config();
    c.firmware_path = path.string();
    FalconDevice dev(c);
    ASSERT_EQ(dev.open(), DeviceStatus::Ok) << dev.last_error();
    EXPECT_EQ(fake.upload_attempts, 5);
    EXPECT_EQ(fake.opens, 5);  // the first open, then one reopen before each of attempts 2..5
    std::filesystem::remove(path);
}

TEST_F(FalconDeviceTest, HomingCanBeInterrupted) {
    fake.firmware_running = true;
    fake.packets_until_homed = -1;
    int polls = 0;
    FalconDeviceConfig c = config();
    c.homing_timeout = 1000.0;
    c.cancel = [&polls] { return ++polls > 10; };
    FalconDevice dev(c);
    ASSERT_EQ(dev.open(), DeviceStatus::Ok);
    EXPECT_EQ(dev.home(), DeviceStatus::NotHomed);
    EXPECT_NE(dev.last_error().find("interrupted"), std::string::npos) << dev.last_error();
}

class HomedFalcon : public FalconDeviceTest {
  protected:
    void SetUp() override {
        fake.firmware_running = true;
        dev = std::make_unique<FalconDevice>(config());
        ASSERT_EQ(dev->open(), DeviceStatus::Ok);
        ASSERT_EQ(dev->home(), DeviceStatus::Ok);
    }
    std::unique_ptr<FalconDevice> dev;
};

TEST_F(HomedFalcon, PositionComesFromTheKinematics) {
    fake.status.encoder = {0, 0, 0};
    AxisVector pos{};
    ASSERT_EQ(dev->write_force({}), DeviceStatus::Ok);  // the Falcon answers every command packet
    ASSERT_EQ(dev->read_position(pos), DeviceStatus::Ok);
    // Equal motor angles (35 deg): on the z axis, 0.1346 m from the base (see the kinematics tests),
    // minus the default origin z = 0.125 m. Tolerance 1e-4 m: the hand-computed 0.1346 is rounded.
    EXPECT_NEAR(pos[0], 0.0, 1e-9);
    EXPECT_NEAR(pos[1], 0.0, 1e-9);
    EXPECT_NEAR(pos[2], 0.1346 - 0.125, 1e-4);
}

TEST_F(HomedFalcon, ForceAlongZGivesEqualTorquesAndIsClamped) {
    AxisVector pos{};
    ASSERT_EQ(dev->write_force({}), DeviceStatus::Ok);
    ASSERT_EQ(dev->read_position(pos), DeviceStatus::Ok);
    ASSERT_EQ(dev->write_force({0.0, 0.0, 2.0}), DeviceStatus::Ok);
    const auto t = fake.commands.back().torque;
    EXPECT_NE(t[0], 0);
    EXPECT_NEAR(t[0], t[1], 1);  // 3-fold symmetry on the axis (1 count: rounding)
    EXPECT_NEAR(t[0], t[2], 1);
    // Far beyond max_force: clamped to 9 N first, then to the protocol range, direction kept.
    ASSERT_EQ(dev->write_force({0.0, 0.0, 1e6}), DeviceStatus::Ok);
    const auto big = fake.commands.back().torque;
    for (auto v : big) EXPECT_LE(std::abs(v), falcon::kMaxTorqueCommand);
    EXPECT_NEAR(big[0], big[1], 1);
    EXPECT_EQ((big[0] > 0), (t[0] > 0));
    EXPECT_GE(dev->counters().saturated_commands, 1U);
    // Non-finite: refused, zero torque sent.
    EXPECT_EQ(dev->write_force({NAN, 0.0, 0.0}), DeviceStatus::InvalidArgument);
    EXPECT_EQ(fake.commands.back().torque, (std::array<std::int16_t, 3>{0, 0, 0}));
}

// What the Falcon can really give: with the protocol's +-4096 torque commands (libnifalcon
// FalconKinematic.h "Force values are capped at 4096"), a force along one axis at the workspace centre
// is limited below the profile's max_force of 9 N on some axes; the driver then scales the whole force
// down (direction kept). Checked the second way: the force delivered by the commanded torques,
// F = A^T tau with A = d theta / d p from central differences of the inverse kinematics (h = 1e-6 m,
// error O(h^2) ~ 1e-10), must point along the requested axis and equal the scaled magnitude.
// Tolerance 0.02 N: torque commands are rounded to whole counts (0.5 / 10000 N m per motor) times
// |A| < 40 rad/m, i.e. < 0.002 N per motor.
TEST_F(HomedFalcon, TorqueLimitGivesLessThanMaxForceAtTheCentreAndKeepsTheDirection) {
    const falcon::Geometry g = falcon::Geometry::published();
    const falcon::Vec3 centre{0.0, 0.0, 0.125};
    fake.status.encoder = FakeFalcon::encoders_at(centre);
    AxisVector pos{};
    for (int i = 0; i < 3; ++i) {  // a few packets for the Newton iteration to settle on the new pose
        ASSERT_EQ(dev->write_force({}), DeviceStatus::Ok);
        ASSERT_EQ(dev->read_position(pos), DeviceStatus::Ok);
    }
    falcon::Vec3 p{pos[0] + 0.0, pos[1] + 0.0, pos[2] + 0.125};
    falcon::Mat3 A{};
    const double h = 1e-6;
    for (std::size_t k = 0; k < 3; ++k) {
        falcon::Vec3 plus = p, minus = p, tp{}, tm{};
        plus[k] += h;
        minus[k] -= h;
        ASSERT_TRUE(falcon::inverse_kinematics(plus, g, tp));
        ASSERT_TRUE(falcon::inverse_kinematics(minus, g, tm));
        for (std::size_t i = 0; i < 3; ++i) A[i][k] = (tp[i] - tm[i]) / (2 * h);
    }
    const char* names = "xyz";
    for (std::size_t axis = 0; axis < 3; ++axis) {
        AxisVector f{};
        f[axis] = 100.0;  // far beyond max_force = 9 N
        ASSERT_EQ(dev->write_force(f), DeviceStatus::Ok);
        const auto cmd = fake.commands.back().torque;
        falcon::Vec3 tau{};
        for (std::size_t i = 0; i < 3; ++i) tau[i] = cmd[i] / g.torque_to_command;
        falcon::Vec3 delivered{};
        for (std::size_t k = 0; k < 3; ++k) delivered[k] = A[0][k] * tau[0] + A[1][k] * tau[1] + A[2][k] * tau[2];
        int largest = 0;
        for (auto c : cmd) largest = std::max(largest, std::abs(static_cast<int>(c)));
        const double along = delivered[axis];
        std::printf("MEASURED falcon max force along %c at the centre: %.2f N (largest motor command %d of 4096)\n",
                    names[axis], along, largest);
        EXPECT_GT(along, 0.0);
        EXPECT_LE(along, 9.0 + 0.02);
        if (along < 9.0 - 0.02) {
            EXPECT_GE(largest, falcon::kMaxTorqueCommand - 1);  // limited by the motors
        }
        for (std::size_t k = 0; k < 3; ++k) {
            if (k != axis) {
                EXPECT_NEAR(delivered[k], 0.0, 0.02) << "axis " << axis << " component " << k;
            }
        }
    }
}

TEST_F(HomedFalcon, MalformedPacketsAreCountedAndNeverUsed) {
    fake.status.encoder = {0, 0, 0};
    AxisVector good{};
    ASSERT_EQ(dev->write_force({}), DeviceStatus::Ok);
    ASSERT_EQ(dev->read_position(good), DeviceStatus::Ok);
    // Before every status packet: garbage and a frame whose end marker is wrong and whose encoder
    // values would be an extreme pose if they were used.
    fake.after_status = [](ScriptedTransport& tr, const falcon::Packet&) {
        falcon::Status evil;
        evil.encoder = {-20000, 20000, -20000};
        evil.homed_mask = 7;
        falcon::Packet bad = falcon::encode_status(evil);
        bad[15] = 'Z';
        const std::uint8_t junk[3] = {0x00, 0xFF, 0x13};
        tr.push_rx(junk);
        tr.push_rx(bad);
    };
    for (int i = 0; i < 5; ++i) {
        AxisVector pos{};
        ASSERT_EQ(dev->write_force({}), DeviceStatus::Ok);
        ASSERT_EQ(dev->read_position(pos), DeviceStatus::Ok);
        for (std::size_t a = 0; a < 3; ++a) EXPECT_NEAR(pos[a], good[a], 1e-12);
    }
    const DeviceCounters c = dev->counters();
    EXPECT_GE(c.packets_malformed, 4U);
    EXPECT_GE(c.garbage_bytes, 12U);
}

TEST_F(HomedFalcon, UnplugGivesDisconnectedWithoutCrash) {
    AxisVector pos{};
    fake.transport->disconnected = true;
    EXPECT_EQ(dev->read_position(pos), DeviceStatus::Disconnected);
    EXPECT_EQ(dev->write_force({}), DeviceStatus::Disconnected);  // the zero-force attempt fails cleanly
    EXPECT_NE(dev->last_error().find("disconnected"), std::string::npos);
    dev->close();
    EXPECT_EQ(dev->read_position(pos), DeviceStatus::NotOpen);
}

TEST_F(HomedFalcon, SilenceBecomesATimeout) {
    AxisVector pos{};
    fake.firmware_running = false;  // stops answering
    DeviceStatus s = DeviceStatus::Ok;
    int ticks = 0;
    while (s == DeviceStatus::Ok && ticks < 1000) {
        s = dev->read_position(pos);
        ++ticks;
    }
    EXPECT_EQ(s, DeviceStatus::Timeout);
    EXPECT_EQ(ticks, 101);  // max_stale_reads = 100 stale ticks are tolerated
}

TEST_F(HomedFalcon, LostHomingStopsForce) {
    AxisVector pos{};
    fake.packets_until_homed = -1;
    fake.status.homed_mask = 0;
    ASSERT_EQ(dev->write_force({}), DeviceStatus::Ok);
    EXPECT_EQ(dev->read_position(pos), DeviceStatus::NotHomed);
    EXPECT_EQ(dev->write_force({0.0, 0.0, 3.0}), DeviceStatus::NotHomed);
    EXPECT_EQ(fake.commands.back().torque, (std::array<std::int16_t, 3>{0, 0, 0}));
}

// The real-time loop with the Falcon: a 1-DoF wall along z renders force (non-zero torques), then the
// Falcon is unplugged: the loop stops with a device fault (Disconnected) instead of crashing.
TEST_F(HomedFalcon, LoopRendersTheWallThenStopsCleanlyOnUnplug) {
    int packets = 0;
    fake.after_status = [&packets](ScriptedTransport& tr, const falcon::Packet&) {
        if (++packets == 20) tr.disconnected = true;
    };
    std::vector<VirtualWall> walls;
    // Handle at z = +9.6 mm (encoders 0, see above): 9.6 mm inside a wall at 0 entered in +z.
    walls.emplace_back(WallGeometry{2, 0.0, 1.0, WallMode::Bilateral}, 500.0, 1.0, 1e-3);
    Scene scene(std::move(walls), 3, 5.0);
    DaemonConfig cfg;
    cfg.loop = {1'000'000, true};
    cfg.max_ticks = 1000;
    cfg.watchdog_enabled = false;
    cfg.trace_axis = 2;
    Daemon daemon(*dev, scene, nullptr, cfg);
    fake.status.encoder = {0, 0, 0};
    ASSERT_EQ(dev->write_force({}), DeviceStatus::Ok);  // the first status packet
    const RunResult r = daemon.run();
    EXPECT_EQ(r.fault, StateFault::Device);
    EXPECT_EQ(r.device_status, DeviceStatus::Disconnected);
    EXPECT_LT(r.fault_tick, 25U);
    bool rendered = false;
    for (const auto& c : fake.commands) rendered = rendered || c.torque[0] != 0;
    EXPECT_TRUE(rendered);
    dev->close();
}

}  // namespace
}  // namespace hapticd
