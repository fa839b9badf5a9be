// Builds the device named by a profile: driver "sim" -> SimDevice, "falcon" -> FalconDevice (libusb),
// "hid" -> HidFfbDevice (hidapi); with --simulate every profile runs on the simulated device. Drivers
// without an implementation ("lwr") are refused (kExitDeviceError) unless simulated.
#pragma once

#include <memory>

#include "devices/device.hpp"
#include "devices/sim_device.hpp"
#include "config/options.hpp"

namespace hapticd {

DeviceCapabilities capabilities_from_profile(const DeviceProfile& profile);

std::unique_ptr<Device> make_device(const DeviceProfile& profile, const Options& options, const SimScenario& scenario,
                                    double period);

}  // namespace hapticd
