// FalconDevice against the scripted Falcon: firmware detection/upload, the homing gate, positions,
// torques and their clamping, malformed packets, disconnects.
#include <gtest/gtest.h>

#include <cmath>
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
    EXPECT_EQ(fake.commands.back().leds, falcon::kLedRed);
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
    ASSERT_EQ(dev->write_force({}), DeviceStatus::Ok);  // the first status packet
    const RunResult r = daemon.run();
    EXPECT_EQ(r.fault, Fault::Device);
    EXPECT_EQ(r.device_status, DeviceStatus::Disconnected);
    EXPECT_LT(r.fault_tick, 25U);
    bool rendered = false;
    for (const auto& c : fake.commands) rendered = rendered || c.torque[0] != 0;
    EXPECT_TRUE(rendered);
    dev->close();
}

}  // namespace
}  // namespace hapticd
