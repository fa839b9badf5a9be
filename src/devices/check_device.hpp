// SPDX-License-Identifier: Apache-2.0
// The force-sign check of `hapticd check-device` (daemon/check_device_main.hpp): pushes the device gently along each
// axis and reports the measured force sign,
// i.e. whether a positive force command moves the handle towards positive positions. A wall rendered
// with the wrong sign pushes the hand INTO the wall and is unstable, so this is checked before the first
// real run (docs/devices.md, "First run").
//
// Method, per axis: from rest, the force profile +F for t, -F for 2 t, +F for t (zero net impulse: a free
// mass ends at rest where it started) with F = the push force, then zero force. The sign is that of the
// displacement at the end of the first +F phase (x(t) - x(0) = F t^2 / (2 m) for a free mass, so it has
// the sign of the force as the device executes it). It counts only when that displacement exceeds the
// threshold max(min_motion, 20 x the standard deviation of the position at rest); otherwise the axis is
// "inconclusive" (the handle was held or blocked). The run stops with zero force when the handle moves
// more than position_limit from where it started.
// Cost: (4 t + settle) per axis at the device's rate.
#pragma once

#include <cstddef>
#include <string>
#include <vector>

#include "devices/device.hpp"

namespace hapticd {

struct ForceSignSettings {
    double push_force = 0.5;       // N (N m)
    double push_time = 0.05;       // s, t above
    double rest_time = 0.1;        // s, rest before each axis (noise estimate) and after it
    double min_motion = 2e-5;      // m (rad)
    double position_limit = 0.02;  // m (rad) from the start position
    double period = 1e-3;          // s
    bool lockstep = false;         // ticks back to back (simulated device) instead of at the period
};

struct AxisSign {
    int sign = 0;             // +1, -1, or 0 = inconclusive
    double displacement = 0;  // x(t) - x(0) at the end of the first +F phase
    double threshold = 0;
};

struct ForceSignResult {
    bool ok = false;  // the procedure ran to the end (not: the signs are +1)
    std::vector<AxisSign> axes;
    DeviceStatus status = DeviceStatus::Ok;
    std::string message;  // what stopped it, when !ok
};

// The device must be open and homed. Zero force is written at the end and on every early stop.
ForceSignResult measure_force_sign(Device& device, const ForceSignSettings& settings);

}  // namespace hapticd
