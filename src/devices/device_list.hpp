// SPDX-License-Identifier: Apache-2.0
// `hapticd --list-devices`: the USB (libusb) and HID (hidapi) devices hapticd can drive.
#pragma once

#include <ostream>
#include <string>
#include <vector>

#include "config/options.hpp"

namespace hapticd {

struct ListedDevice {
    std::string driver;    // "falcon" | "hid"
    std::string profiles;  // profile names that drive it
    std::string usb_id;    // "0403:cb48"
    std::string location;  // "bus 1 device 5" / hidraw path
    bool accessible = false;
    std::string problem;  // why not accessible (with a hint)
};

// The HID profiles found next to the config file in use and in the built-in config dir.
std::vector<DeviceProfile> discover_hid_profiles(const Options& options, std::vector<std::string>& warnings);

std::vector<ListedDevice> enumerate_devices(const std::vector<DeviceProfile>& hid_profiles,
                                            std::vector<std::string>& notes);

// Prints the list (or that none was found) and returns 0 (success: the daemon exits with it).
int list_devices(std::ostream& out, const Options& options);

}  // namespace hapticd
