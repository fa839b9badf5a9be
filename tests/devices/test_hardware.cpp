// SPDX-License-Identifier: Apache-2.0
// Hardware test: runs only when a supported device is plugged in and accessible; otherwise it is
// reported as SKIPPED with the reason (never as passed). Zero force only: safe without a human.
// A Falcon whose firmware is not running needs HAPTICD_FALCON_FIRMWARE=/path/to/firmware.bin.
#include <gtest/gtest.h>

#include <cstdlib>

#include "common/test_paths.hpp"
#include "devices/device_list.hpp"
#include "devices/falcon_device.hpp"
#include "devices/hid_device.hpp"
#include "devices/transport_libusb.hpp"
#include "config/options.hpp"

namespace hapticd {
namespace {

std::vector<ListedDevice> devices_of(const std::string& driver, std::string& why_skip) {
    Options o;
    o.config_path = std::string(HAPTICD_SOURCE_CONFIG_DIR) + "/hapticd.toml";
    std::vector<std::string> notes;
    const auto hid_profiles = discover_hid_profiles(o, notes);
    std::vector<ListedDevice> found;
    for (auto& d : enumerate_devices(hid_profiles, notes)) {
        if (d.driver != driver) continue;
        if (!d.accessible) {
            why_skip = d.driver + " " + d.usb_id + " at " + d.location + " is present but not accessible: " + d.problem;
            continue;
        }
        found.push_back(d);
    }
    if (found.empty() && why_skip.empty()) {
        why_skip = "no " + driver + " device present (" +
                   (driver == "falcon" ? std::string("USB 0403:cb48") : std::string("HID profiles in config/devices")) +
                   ")";
    }
    return found;
}

TEST(Hardware, FalconAnswersWithStatusPackets) {
    std::string why;
    if (devices_of("falcon", why).empty()) GTEST_SKIP() << why;
    FalconDeviceConfig cfg;
    cfg.capabilities.axes = 3;
    cfg.capabilities.max_force = 9.0;
    if (const char* fw = std::getenv("HAPTICD_FALCON_FIRMWARE")) cfg.firmware_path = fw;
    cfg.open_transport = [] { return LibusbFtdiTransport::open_falcon(0); };
    FalconDevice dev(cfg);
    ASSERT_EQ(dev.open(), DeviceStatus::Ok) << dev.last_error();
    for (int i = 0; i < 200; ++i) {
        AxisVector pos{};
        const DeviceStatus s = dev.read_position(pos);
        ASSERT_TRUE(s == DeviceStatus::Ok || s == DeviceStatus::NotHomed) << to_string(s) << ": " << dev.last_error();
        const DeviceStatus w = dev.write_force({});
        ASSERT_TRUE(w == DeviceStatus::Ok || w == DeviceStatus::NotHomed) << to_string(w) << ": " << dev.last_error();
    }
    EXPECT_GT(dev.counters().packets_ok, 100U);
    dev.close();
}

TEST(Hardware, HidDeviceReportsAPosition) {
    std::string why;
    if (devices_of("hid", why).empty()) GTEST_SKIP() << why;
    Options o;
    o.config_path = std::string(HAPTICD_SOURCE_CONFIG_DIR) + "/hapticd.toml";
    std::vector<std::string> notes;
    const auto profiles = discover_hid_profiles(o, notes);
    ASSERT_FALSE(profiles.empty());
    HidDeviceConfig cfg;
    cfg.capabilities.max_force = profiles.front().max_force;
    cfg.layout.vendor_id = static_cast<std::uint16_t>(profiles.front().real.usb_vid);
    cfg.layout.product_id = static_cast<std::uint16_t>(profiles.front().real.usb_pid);
    HidFfbDevice dev(cfg);
    ASSERT_EQ(dev.open(), DeviceStatus::Ok) << dev.last_error();
    ASSERT_EQ(dev.home(), DeviceStatus::Ok) << dev.last_error();
    AxisVector pos{};
    EXPECT_EQ(dev.read_position(pos), DeviceStatus::Ok) << dev.last_error();
    EXPECT_EQ(dev.write_force({}), DeviceStatus::Ok) << dev.last_error();
    dev.close();
}

}  // namespace
}  // namespace hapticd
