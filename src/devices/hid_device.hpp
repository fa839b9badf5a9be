// A USB HID force-feedback device (HID PID, e.g. OpenFFBoard) as a hapticd Device, over hidapi:
// position from an axis of an input report, force through one constant-force effect whose magnitude is
// updated every tick. One axis (axis 0). Layout (ids, offsets, scaling) from the device profile.
#pragma once

#include <array>
#include <string>

#include "devices/device.hpp"
#include "devices/hid_ffb_protocol.hpp"

struct hid_device_;

namespace hapticd {

struct HidDeviceConfig {
    DeviceCapabilities capabilities;
    hid::Layout layout;
    int max_stale_reads = 100;  // consecutive ticks without an input report -> Timeout (0: never)
};

class HidFfbDevice final : public Device {
public:
    explicit HidFfbDevice(HidDeviceConfig config) : config_(std::move(config)) {}
    ~HidFfbDevice() override;

    DeviceStatus open() override;
    DeviceStatus home() override;  // HID wheels/joysticks need no homing
    void close() noexcept override;

    DeviceStatus read_position(AxisVector& position) noexcept override;
    DeviceStatus write_force(const AxisVector& force) noexcept override;

    [[nodiscard]] DeviceCounters counters() const noexcept override { return counters_; }
    [[nodiscard]] const DeviceCapabilities& capabilities() const noexcept override { return config_.capabilities; }
    [[nodiscard]] std::string_view name() const noexcept override { return "hid"; }
    [[nodiscard]] std::string last_error() const override { return *rt_error_ != '\0' ? rt_error_ : error_; }

private:
    DeviceStatus fail(DeviceStatus status, std::string message);
    bool write_report(const std::uint8_t* data, std::size_t size) noexcept;

    HidDeviceConfig config_;
    hid_device_* handle_ = nullptr;
    std::uint8_t block_ = 1;
    double position_ = 0.0;
    bool have_position_ = false;
    int consecutive_stale_ = 0;
    std::array<std::uint8_t, 64> report_{};
    DeviceCounters counters_;
    std::string error_;
    const char* rt_error_ = "";
};

}  // namespace hapticd
