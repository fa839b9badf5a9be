// SPDX-License-Identifier: Apache-2.0
// A Device whose force commands are multiplied by a sign per axis before they reach the wrapped device:
// the fix for a device whose force acts against its position axis (measured by `hapticd check-device`,
// set with the profile key `force_sign`). Everything else is passed through. No allocation, noexcept on
// the per-tick calls, like the wrapped device.
#pragma once

#include <memory>

#include "devices/device.hpp"

namespace hapticd {

class ForceSignDevice final : public Device {
  public:
    ForceSignDevice(std::unique_ptr<Device> inner, const AxisVector& sign) : inner_(std::move(inner)), sign_(sign) {}

    DeviceStatus open() override { return inner_->open(); }
    DeviceStatus home() override { return inner_->home(); }
    void close() noexcept override { inner_->close(); }
    bool zero_force_from_signal_handler() noexcept override { return inner_->zero_force_from_signal_handler(); }
    DeviceStatus read_position(AxisVector& position) noexcept override { return inner_->read_position(position); }
    DeviceStatus write_force(const AxisVector& force) noexcept override {
        AxisVector f{};
        for (std::size_t a = 0; a < kMaxAxes; ++a) f[a] = sign_[a] * force[a];
        return inner_->write_force(f);
    }
    DeviceStatus read_external_force(AxisVector& force) noexcept override { return inner_->read_external_force(force); }
    [[nodiscard]] bool homed() const noexcept override { return inner_->homed(); }
    [[nodiscard]] DeviceCounters counters() const noexcept override { return inner_->counters(); }
    [[nodiscard]] const DeviceCapabilities& capabilities() const noexcept override { return inner_->capabilities(); }
    [[nodiscard]] std::string_view name() const noexcept override { return inner_->name(); }
    [[nodiscard]] std::string last_error() const override { return inner_->last_error(); }

    [[nodiscard]] const AxisVector& sign() const noexcept { return sign_; }

  private:
    std::unique_ptr<Device> inner_;
    AxisVector sign_;
};

}  // namespace hapticd
