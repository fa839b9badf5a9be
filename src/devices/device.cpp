// SPDX-License-Identifier: Apache-2.0
#include "devices/device.hpp"

namespace hapticd {

std::string_view to_string(DeviceStatus status) noexcept {
    switch (status) {
        case DeviceStatus::Ok:
            return "ok";
        case DeviceStatus::NotOpen:
            return "device not open";
        case DeviceStatus::NotHomed:
            return "device not homed";
        case DeviceStatus::Disconnected:
            return "device disconnected";
        case DeviceStatus::Timeout:
            return "device timeout";
        case DeviceStatus::HardwareFault:
            return "device hardware fault";
        case DeviceStatus::InvalidArgument:
            return "invalid force command";
        case DeviceStatus::Unsupported:
            return "not supported by the device";
    }
    return "unknown device status";
}

}  // namespace hapticd
