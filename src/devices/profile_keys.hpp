// Device-profile keys of the real-device drivers (Falcon, HID), registered with the profile reader in
// options.cpp. Documented in docs/devices.md.
#pragma once

#include <string>
#include <vector>

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
    // driver = "hid"
    long long usb_vid = -1;
    long long usb_pid = -1;
    long long input_report_id = 0x01;
    long long position_offset = 5;
    long long position_bytes = 2;
    bool position_signed = true;
    double position_scale = 1.0;        // m or rad per count
    double position_zero = 0.0;         // count at position 0
    long long set_effect_report_id = 0x01;
    long long constant_force_report_id = 0x05;
    long long effect_operation_report_id = 0x0A;
    long long block_free_report_id = 0x0B;
    long long device_control_report_id = 0x0C;
    long long create_effect_report_id = 0x11;
    long long block_load_report_id = 0x12;
    double force_scale = 1.0;           // magnitude counts per N (N m)
    long long force_max_counts = 10000;
};

void add_real_device_keys(CLI::App& app, RealDeviceKeys& keys);

// Range checks; throws StartupError(kExitInvalidParameter / kExitBadConfig) naming key, value and range.
void validate_real_device_keys(const std::string& where, const std::string& driver, const RealDeviceKeys& keys);

}  // namespace hapticd
