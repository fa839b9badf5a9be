// SPDX-License-Identifier: Apache-2.0
// Device-profile keys registered with the profile reader in options.cpp, documented in docs/devices.md:
// the real-device drivers' keys (Falcon, HID), and the plant's mass keys (one mass, a mass per axis or a
// full mass matrix) with the stiffness limit.
#pragma once

#include <array>
#include <cstddef>
#include <optional>
#include <string>
#include <vector>

#include "config/key_locations.hpp"
#include "tuning/device_mass.hpp"

namespace CLI {
class App;
}

namespace hapticd {

struct RealDeviceKeys {
    // driver = "falcon"
    std::string firmware;          // Novint firmware image (user-supplied); --falcon-firmware overrides
    double homing_timeout = 60.0;  // s
    std::vector<double> origin;    // m, kinematic position of the workspace centre (default 0, 0, 0.125)
    long long device_index = 0;    // which of several identical devices (0: the first)
    // Per axis +1 or -1: forces are multiplied by it before they reach the device (the fix when
    // `hapticd check-device` measures sign -1). Empty: +1 on every axis.
    std::vector<double> force_sign;
    // driver = "hid" (report ids, offsets and the magnitude range come from the device's report
    // descriptor; only what no descriptor says is here)
    long long usb_vid = -1;
    long long usb_pid = -1;
    double position_scale = 1.0;  // m or rad per count
    double position_zero = 0.0;   // count at position 0
    double force_scale = 1.0;     // magnitude counts per N (N m)
};

void add_real_device_keys(CLI::App& app, RealDeviceKeys& keys);

// Range checks; throws StartupError(ErrorKind::InvalidParameter / ErrorKind::BadConfig) naming key, value and range,
// and where the profile wrote the key (`where`: from apply_config_file).
void validate_real_device_keys(const KeyLocations& where, const std::string& driver, const RealDeviceKeys& keys);

// The plant keys as read: `mass` (one value, or one per axis), `mass_matrix` (axes x axes values, row
// major) and `max_stiffness` (N/m). add_mass_keys registers them; `given` flags say which were written.
struct MassKeys {
    std::vector<double> mass;
    std::vector<double> mass_matrix;
    double max_stiffness = 0.0;
    bool mass_given = false, mass_matrix_given = false, max_stiffness_given = false;
};

void add_mass_keys(CLI::App& app, MassKeys& keys);
// Fills the `given` flags from the app the keys were registered with.
void read_mass_keys_given(const CLI::App& app, MassKeys& keys);

// The validated mass and limit of a profile. Throws StartupError naming the key, its value and the accepted
// range (ErrorKind::BadConfig: neither or both of mass and mass_matrix; ErrorKind::InvalidParameter: out of range):
// mass > 0 finite <= 1e6 (1 or `axes` values); mass_matrix `axes`^2 finite values, symmetric to 1e-9 of
// its largest entry, positive definite (Cholesky) with eigenvalues in (0, 1e6] and smallest / largest
// >= 1e-9; an anisotropic mass only with damping = stiffness = 0 (otherwise the plant along a direction
// is not one scalar loop); max_stiffness finite, > 0, <= 1e12 N/m.
struct ProfileMass {
    DeviceMass mass;
    std::optional<double> max_stiffness;  // N/m (N m/rad); none: only the stability region bounds K
};
ProfileMass validate_mass_keys(const KeyLocations& where, std::size_t axes, const MassKeys& keys, double damping,
                               double stiffness);

}  // namespace hapticd
