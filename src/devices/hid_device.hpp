// SPDX-License-Identifier: Apache-2.0
// A USB HID force-feedback device (HID PID, e.g. OpenFFBoard) as a hapticd Device, over hidapi (hidraw):
// position from the X axis of an input report, force through one constant-force effect whose magnitude
// is updated every tick. One axis (axis 0). Report ids, offsets and ranges come from the device's
// report descriptor (read from the hidraw node, HIDIOCGRDESC; hid_ffb_protocol.hpp); scaling from the
// device profile.
#pragma once

#include <array>
#include <memory>
#include <string>

#include "devices/device.hpp"
#include "devices/hid_ffb_protocol.hpp"

struct hid_device_;

namespace hapticd {

struct HidDeviceConfig {
    DeviceCapabilities capabilities;
    hid::Layout layout;
    // Consecutive ticks without an input report -> Timeout (0: never). The device reports only on change
    // or every ~100 ms (OpenFFBoard FFBWheel/FFBHIDMain send_report(): on change, or after 100 calls at
    // 1 kHz), so a resting wheel is silent for 100 ms: the factory sets 0.5 s worth of ticks.
    int max_stale_reads = 500;
    int device_index = 0;  // which of several devices with the same VID:PID
};

class HidFfbDevice final : public Device {
  public:
    explicit HidFfbDevice(HidDeviceConfig config);
    ~HidFfbDevice() override;

    DeviceStatus open() override;
    DeviceStatus home() override;  // HID wheels/joysticks need no homing: waits for a first input report
    void close() noexcept override;
    // write(2) (async-signal-safe) of reports built at open() on a second descriptor of the hidraw node, opened
    // at open(): magnitude 0, Effect Operation Stop, Device Control Stop All Effects. The kernel serialises
    // them with the loop's writes; a magnitude written after them does not restart the stopped effect. True
    // when the three were written whole.
    bool zero_force_from_signal_handler() noexcept override;

    DeviceStatus read_position(AxisVector& position) noexcept override;
    DeviceStatus write_force(const AxisVector& force) noexcept override;

    [[nodiscard]] DeviceCounters counters() const noexcept override { return counters_; }
    [[nodiscard]] const DeviceCapabilities& capabilities() const noexcept override { return config_.capabilities; }
    [[nodiscard]] std::string_view name() const noexcept override { return "hid"; }
    [[nodiscard]] std::string last_error() const override { return *rt_error_ != '\0' ? rt_error_ : error_; }

    // The layout read from the device (valid after open()).
    [[nodiscard]] const hid::PidLayout& pid_layout() const noexcept { return *pid_; }
    [[nodiscard]] const std::string& path() const noexcept { return path_; }

  private:
    DeviceStatus fail(DeviceStatus status, std::string message);
    bool write_report(const hid::Report& report) noexcept;

    HidDeviceConfig config_;
    std::unique_ptr<hid::PidLayout> pid_;
    std::string path_;
    hid_device_* handle_ = nullptr;
    int signal_fd_ = -1;                           // the hidraw node, write-only, for the fatal-signal handler
    std::array<hid::Report, 3> signal_reports_{};  // what the handler writes (zero_force_from_signal_handler)
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
