// Device-profile keys of the real-device drivers (Falcon, HID), registered with the profile reader in
// options.cpp. Documented in docs/devices.md.
#pragma once

#include <string>
#include <vector>

#include "config/key_locations.hpp"

namespace CLI {
class App;
}

namespace hapticd {

struct RealDeviceKeys {
    // driver = "falcon"
    std::string firmware;               // Novint firmware image (user-supplied); --falcon-firmware overrides
    double homing_timeout = 60.0;       // s
    std::vector<double> origin;         // m, kinematic position of the workspace centre (default 0, 0, 0.125)
    long long device_index = 0;         // which of several identical devices (0: the first)
    // Per axis +1 or -1: forces are multiplied by it before they reach the device (the fix when
    // `hapticd check-device` measures sign -1). Empty: +1 on every axis.
    std::vector<double> force_sign;
    // driver = "hid" (report ids, offsets and the magnitude range come from the device's report
    // descriptor; only what no descriptor says is here)
    long long usb_vid = -1;
    long long usb_pid = -1;
    double position_scale = 1.0;        // m or rad per count
    double position_zero = 0.0;         // count at position 0
    double force_scale = 1.0;           // magnitude counts per N (N m)
};

void add_real_device_keys(CLI::App& app, RealDeviceKeys& keys);

// Range checks; throws StartupError(kExitInvalidParameter / kExitBadConfig) naming key, value and range, and
// where the profile wrote the key (`where`: from apply_config_file).
void validate_real_device_keys(const KeyLocations& where, const std::string& driver, const RealDeviceKeys& keys);

}  // namespace hapticd
