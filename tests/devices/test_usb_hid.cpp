// SPDX-License-Identifier: Apache-2.0
// The HID driver through the REAL hidapi (hidraw backend) on an emulated OpenFFBoard-like device under
// umockdev (emulated_hid_device.hpp): enumeration, the report descriptor ioctls, the start-up and effect
// reports as the firmware receives them, input reports only on change or every ~100 ms, the magnitude
// range, unplug and silence, the fatal-signal handler's zero, and `hapticd --list-devices` (a child process
// sees the same emulated device). Label `usb`. The binary re-executes itself with libumockdev-preload.so.0
// preloaded when it is not.
#include <gtest/gtest.h>

#include <unistd.h>

#include <chrono>
#include <csignal>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>
#include <thread>
#include <vector>

#include "common/test_paths.hpp"
#include "daemon/fatal_signal.hpp"
#include "devices/hid_device.hpp"
#include "emulated_hid_device.hpp"

namespace {

// Before main(): run again with the umockdev preload library (and ASan told that it is not first).
struct UmockdevPreload {
    UmockdevPreload() {
        const char* preload = std::getenv("LD_PRELOAD");
        if (preload != nullptr && std::string(preload).find("libumockdev-preload") != std::string::npos) return;
        if (std::getenv("HAPTICD_NO_UMOCKDEV_REEXEC") != nullptr) return;
        std::string value = "libumockdev-preload.so.0";
        if (preload != nullptr && *preload != '\0') value += std::string(":") + preload;
        setenv("LD_PRELOAD", value.c_str(), 1);
        std::string asan = std::getenv("ASAN_OPTIONS") != nullptr ? std::getenv("ASAN_OPTIONS") : "";
        setenv("ASAN_OPTIONS", (asan + (asan.empty() ? "" : ":") + "verify_asan_link_order=0:detect_leaks=0").c_str(),
               1);                                     // glib/umockdev keep allocations for the process lifetime
        setenv("HAPTICD_NO_UMOCKDEV_REEXEC", "1", 1);  // never loop
        std::vector<char> cmdline(65536);
        FILE* f = std::fopen("/proc/self/cmdline", "rb");
        if (f == nullptr) return;
        const std::size_t n = std::fread(cmdline.data(), 1, cmdline.size() - 1, f);
        std::fclose(f);
        std::vector<char*> argv;
        for (std::size_t i = 0; i < n; i += std::strlen(&cmdline[i]) + 1) argv.push_back(&cmdline[i]);
        argv.push_back(nullptr);
        execv("/proc/self/exe", argv.data());
    }
} const g_reexec;

using namespace hapticd;
using Clock = std::chrono::steady_clock;

HidDeviceConfig hid_usb_config() {
    HidDeviceConfig c;
    c.capabilities.axes = 1;
    c.capabilities.max_force = 20.0;
    c.capabilities.rotary = true;
    c.layout.vendor_id = 0x1209;
    c.layout.product_id = 0xFFB0;
    c.layout.position_scale = 0.001;
    c.layout.force_scale = 2000.0;  // counts per N m
    c.max_stale_reads = 500;        // 0.5 s at 1 kHz, as the factory sets
    return c;
}

class UsbHid : public ::testing::Test {
  protected:
    void SetUp() override {
        if (!emulated.ok()) GTEST_SKIP() << "umockdev emulation unavailable: " << emulated.error();
    }
    test::EmulatedHidDevice emulated;
};

TEST_F(UsbHid, StartUpReportsAreWhatThePidFirmwareNeeds) {
    HidFfbDevice dev(hid_usb_config());
    ASSERT_EQ(dev.open(), DeviceStatus::Ok) << dev.last_error();
    EXPECT_EQ(dev.path(), "/dev/hidraw0");
    const auto out = emulated.output_reports();
    ASSERT_GE(out.size(), 7U);
    // Reset (Device Control 4), Stop All (3), Device Gain 255, Enable Actuators (1) -- hid-pidff.c order.
    EXPECT_EQ(out[0], (std::vector<std::uint8_t>{0x0C, 4}));
    EXPECT_EQ(out[1], (std::vector<std::uint8_t>{0x0C, 3}));
    EXPECT_EQ(out[2], (std::vector<std::uint8_t>{0x0D, 0xFF}));
    EXPECT_EQ(out[3], (std::vector<std::uint8_t>{0x0C, 1}));
    // Set Effect: 22 bytes, block 1 (from the Block Load answer), constant force, Direction Enable and X
    // enabled (byte 13 = 0x05), direction 9000 = 90 deg of 0..35999.
    ASSERT_EQ(out[4].size(), 22U);
    EXPECT_EQ(out[4][0], 0x01);
    EXPECT_EQ(out[4][1], 1);
    EXPECT_EQ(out[4][2], 1);
    EXPECT_EQ(out[4][13], 0x05);
    EXPECT_EQ(out[4][14] | (out[4][15] << 8), 9000);
    EXPECT_EQ(out[5], (std::vector<std::uint8_t>{0x05, 1, 0, 0}));  // magnitude 0
    EXPECT_EQ(out[6], (std::vector<std::uint8_t>{0x0A, 1, 1, 1}));  // Start, loop count 1
    const auto features = emulated.feature_reports();
    ASSERT_EQ(features.size(), 1U);
    EXPECT_EQ(features[0], (std::vector<std::uint8_t>{0x11, 1, 0, 0}));  // Create New Effect: constant force
    dev.close();
    const auto after = emulated.output_reports();
    // Close: magnitude 0, Stop, Block Free, Stop All.
    ASSERT_GE(after.size(), out.size() + 4);
    EXPECT_EQ(after[after.size() - 4], (std::vector<std::uint8_t>{0x05, 1, 0, 0}));
    EXPECT_EQ(after[after.size() - 3], (std::vector<std::uint8_t>{0x0A, 1, 3, 1}));
    EXPECT_EQ(after[after.size() - 2], (std::vector<std::uint8_t>{0x0B, 1}));
    EXPECT_EQ(after[after.size() - 1], (std::vector<std::uint8_t>{0x0C, 3}));
}

TEST_F(UsbHid, PositionFromReportsSentOnChangeOrEvery100ms) {
    HidFfbDevice dev(hid_usb_config());
    ASSERT_EQ(dev.open(), DeviceStatus::Ok) << dev.last_error();
    emulated.set_position(-1234);
    ASSERT_EQ(dev.home(), DeviceStatus::Ok) << dev.last_error();
    AxisVector p{};
    // 350 ticks of 1 ms with the wheel at rest: the device sends every ~100 ms only; no timeout.
    const auto start = Clock::now();
    const int before = emulated.input_reports_sent();
    for (int i = 0; i < 350; ++i) {
        std::this_thread::sleep_until(start + std::chrono::milliseconds(i + 1));
        ASSERT_EQ(dev.read_position(p), DeviceStatus::Ok) << "tick " << i << ": " << dev.last_error();
        EXPECT_DOUBLE_EQ(p[0], -1.234);
    }
    const int resting = emulated.input_reports_sent() - before;
    EXPECT_GE(resting, 2);  // ~3 keep-alive reports in 350 ms (timing on a loaded machine: at least 2)
    EXPECT_LE(resting, 5);
    EXPECT_GT(dev.counters().stale_reads, 300U);
    emulated.set_position(500);  // a change is reported at once
    for (int i = 0; i < 20 && p[0] != 0.5; ++i) {
        std::this_thread::sleep_for(std::chrono::milliseconds(1));
        ASSERT_EQ(dev.read_position(p), DeviceStatus::Ok);
    }
    EXPECT_DOUBLE_EQ(p[0], 0.5);
}

TEST_F(UsbHid, ForceReportsUseTheDescriptorRange) {
    HidFfbDevice dev(hid_usb_config());
    ASSERT_EQ(dev.open(), DeviceStatus::Ok) << dev.last_error();
    ASSERT_EQ(dev.write_force({2.5, 0, 0}), DeviceStatus::Ok);  // 2.5 N m * 2000 = 5000 = 0x1388
    EXPECT_EQ(emulated.output_reports().back(), (std::vector<std::uint8_t>{0x05, 1, 0x88, 0x13}));
    ASSERT_EQ(dev.write_force({-19.0, 0, 0}), DeviceStatus::Ok);  // -38000 -> clamped to -32767 = 0x8001
    EXPECT_EQ(emulated.output_reports().back(), (std::vector<std::uint8_t>{0x05, 1, 0x01, 0x80}));
    EXPECT_EQ(dev.counters().saturated_commands, 1U);
    EXPECT_EQ(dev.write_force({NAN, 0, 0}), DeviceStatus::InvalidArgument);
    EXPECT_EQ(emulated.output_reports().back(), (std::vector<std::uint8_t>{0x05, 1, 0, 0}));
}

// The fatal-signal path (daemon/fatal_signal.hpp): write(2) of pre-built reports on the driver's own hidraw
// descriptor. Called directly: magnitude 0, Stop, Stop All reach the device after a non-zero magnitude.
TEST_F(UsbHid, TheSignalSafeZeroWritesMagnitudeZeroStopAndStopAll) {
    HidFfbDevice dev(hid_usb_config());
    ASSERT_EQ(dev.open(), DeviceStatus::Ok) << dev.last_error();
    ASSERT_EQ(dev.write_force({2.5, 0, 0}), DeviceStatus::Ok);
    const std::size_t before = emulated.output_reports().size();
    EXPECT_TRUE(dev.zero_force_from_signal_handler());
    const auto out = emulated.output_reports();
    ASSERT_EQ(out.size(), before + 3);
    EXPECT_EQ(out[before], (std::vector<std::uint8_t>{0x05, 1, 0, 0}));      // magnitude 0
    EXPECT_EQ(out[before + 1], (std::vector<std::uint8_t>{0x0A, 1, 3, 1}));  // Effect Operation: Stop
    EXPECT_EQ(out[before + 2], (std::vector<std::uint8_t>{0x0C, 3}));        // Device Control: Stop All Effects
    dev.close();
    EXPECT_FALSE(dev.zero_force_from_signal_handler());  // closed: nothing to write to
}

// And from a real fatal signal with the daemon's handlers installed (a death test in a re-executed child, which
// builds its own emulated device): the handler reports the zero as written.
TEST_F(UsbHid, AFatalSignalZeroesTheDevice) {
    GTEST_FLAG_SET(death_test_style, "threadsafe");
    HidFfbDevice dev(hid_usb_config());
    ASSERT_EQ(dev.open(), DeviceStatus::Ok) << dev.last_error();
    ASSERT_EQ(dev.write_force({2.5, 0, 0}), DeviceStatus::Ok);
    EXPECT_EXIT(
        {
            install_fatal_signal_handlers(&dev, nullptr);
            std::raise(SIGSEGV);
        },
        ::testing::KilledBySignal(SIGSEGV), "hapticd: fatal: signal 11; zero force written to the device");
    dev.close();
}

TEST_F(UsbHid, UnplugIsADisconnectAndSilenceATimeout) {
    HidFfbDevice dev(hid_usb_config());
    ASSERT_EQ(dev.open(), DeviceStatus::Ok) << dev.last_error();
    ASSERT_EQ(dev.home(), DeviceStatus::Ok) << dev.last_error();
    AxisVector p{};
    emulated.set_silent(true);
    DeviceStatus s = DeviceStatus::Ok;
    int ticks = 0;
    for (; ticks < 1000 && s == DeviceStatus::Ok; ++ticks) s = dev.read_position(p);
    EXPECT_EQ(s, DeviceStatus::Timeout);
    EXPECT_EQ(ticks, 501);  // max_stale_reads = 500 ticks without a report, then Timeout
    emulated.set_silent(false);
    emulated.set_unplugged(true);
    EXPECT_EQ(dev.read_position(p), DeviceStatus::Disconnected);
    EXPECT_EQ(dev.write_force({0, 0, 0}), DeviceStatus::Disconnected);
    dev.close();  // no hang, no crash
}

TEST_F(UsbHid, ListDevicesFindsTheEmulatedDevice) {
    // A child process inherits the preload and the testbed (UMOCKDEV_DIR) and talks to this handler.
    const std::string cmd = std::string(HAPTICD_BINARY) + " --list-devices 2>&1";
    FILE* pipe = popen(cmd.c_str(), "r");
    ASSERT_NE(pipe, nullptr);
    std::string out;
    char buf[512];
    while (std::fgets(buf, sizeof buf, pipe) != nullptr) out += buf;
    const int rc = pclose(pipe);
    EXPECT_EQ(rc, 0) << out;
    EXPECT_NE(out.find("1209:ffb0"), std::string::npos) << out;
    EXPECT_NE(out.find("hidraw0"), std::string::npos) << out;
}

}  // namespace
