// SPDX-License-Identifier: Apache-2.0
// hapticd's command line for real devices: --list-devices, a missing device, profile keys.
#include <gtest/gtest.h>

#include "common/process.hpp"

namespace hapticd::test {
namespace {

TEST(DeviceCli, ListDevicesExitsZeroAndNamesWhatItLooksFor) {
    const Result r = run({"--list-devices", "--config", ""}, "list_devices");
    EXPECT_EQ(r.code, 0) << r.err;
    // Either devices are listed or it says none was found, naming the Falcon and the HID profiles.
    if (r.out.find("no supported device found") != std::string::npos) {
        EXPECT_NE(r.out.find("0403:cb48"), std::string::npos) << r.out;
        EXPECT_NE(r.out.find("openffboard (HID 1209:ffb0"), std::string::npos) << r.out;
    } else {
        EXPECT_NE(r.out.find("supported device(s)"), std::string::npos) << r.out;
    }
}

TEST(DeviceCli, MissingFalconIsADeviceErrorNamingWhatWasLookedFor) {
    const Result probe = run({"--list-devices", "--config", ""}, "list_probe");
    if (probe.out.find("falcon  0403:cb48") != std::string::npos) GTEST_SKIP() << "a Falcon is plugged in";
    const Result r = run({"--config", "", "--device", "falcon", "--duration", "0.01", "--quiet"}, "falcon_missing");
    EXPECT_EQ(r.code, 6) << r.err;
    EXPECT_NE(r.err.find("no Novint Falcon found"), std::string::npos) << r.err;
    EXPECT_NE(r.err.find("0403:cb48"), std::string::npos) << r.err;
}

TEST(DeviceCli, MissingHidDeviceIsADeviceError) {
    const Result probe = run({"--list-devices", "--config", ""}, "list_probe_hid");
    if (probe.out.find("hid  1209:ffb0") != std::string::npos) GTEST_SKIP() << "an OpenFFBoard is plugged in";
    const Result r = run({"--config", "", "--device", "openffboard", "--duration", "0.01", "--quiet"}, "hid_missing");
    EXPECT_EQ(r.code, 6) << r.err;
    EXPECT_NE(r.err.find("1209:ffb0"), std::string::npos) << r.err;
}

TEST(DeviceCli, FalconFirmwareOptionIsAccepted) {
    const Result r =
        run({"--config", "", "--device", "falcon", "--falcon-firmware", "/nonexistent/fw.bin", "--dry-run", "--quiet"},
            "falcon_fw_option");
    EXPECT_EQ(r.code, 0) << r.err;
}

TEST(DeviceCli, HidProfileWithoutIdsIsABadConfig) {
    const std::string path = write_file("hid_no_ids.toml", "driver = \"hid\"\nmass = 0.01\nmax_force = 1.0\n");
    const Result r = run({"--config", "", "--device", path, "--dry-run"}, "hid_no_ids");
    EXPECT_EQ(r.code, 3) << r.err;
    EXPECT_NE(r.err.find("usb_vid"), std::string::npos) << r.err;
}

TEST(DeviceCli, OutOfRangeProfileKeyIsAnInvalidParameter) {
    const std::string path = write_file(
        "falcon_bad_origin.toml", "driver = \"falcon\"\nmass = 0.3\nmax_force = 9.0\naxes = 3\norigin = [0.0, 0.0]\n");
    const Result r = run({"--config", "", "--device", path, "--dry-run"}, "falcon_bad_origin");
    EXPECT_EQ(r.code, 4) << r.err;
    EXPECT_NE(r.err.find("origin"), std::string::npos) << r.err;
}

}  // namespace
}  // namespace hapticd::test
