// SPDX-License-Identifier: Apache-2.0
// Builds the device named by a profile: driver "sim" -> SimDevice, "falcon" -> FalconDevice (libusb),
// "hid" -> HidFfbDevice (hidapi); with --simulate every profile runs on the simulated device. Drivers
// without an implementation ("lwr") are refused (ErrorKind::Device) unless simulated. Real devices get
// the first-run force limit until their force sign is confirmed (first_run.hpp), and the profile's
// `force_sign` (force_sign_device.hpp).
#pragma once

#include <memory>
#include <string>

#include "devices/device.hpp"
#include "devices/sim_device.hpp"
#include "config/options.hpp"

namespace hapticd {

DeviceCapabilities capabilities_from_profile(const DeviceProfile& profile);

// Caps capabilities.max_force at kFirstRunMaxForce (with a warning unless quiet) when the force sign of
// `profile_name` has not been confirmed by `hapticd check-device`; true if it capped.
bool apply_first_run_limit(DeviceCapabilities& capabilities, const std::string& profile_name, bool quiet);

// The simulated hand's intent from --scenario ("auto": rest with --serve, else the paper's step).
Scenario scenario_kind(const Options& options);

// The simulated hand's impedance from --hand-*: a negative damping or stiffness is the default,
// kHandDampingPerMass / kHandStiffnessPerMass times the profile's mass (docs/simulated-hand.md); the hand's part
// of the profile's mass (release_mass): --hand-release-mass, else the profile's mass minus the lightest of its
// mass_range (0 without a range).
SimHand simulated_hand(const Options& options, const DeviceProfile& profile);

std::unique_ptr<Device> make_device(const DeviceProfile& profile, const Options& options, const SimScenario& scenario,
                                    double period);

}  // namespace hapticd
