// SPDX-License-Identifier: Apache-2.0
// Device interface of hapticd: what the real-time loop needs from a haptic device.
//
// Conventions
//  * Positions are read per axis in the device frame (m, or rad for rotary devices); forces are written
//    per axis in the same frame (N, or N m). Unused axes (index >= capabilities().axes) are ignored.
//  * Errors are return values (DeviceStatus), never exceptions. read_position() and write_force() are
//    called from the real-time thread: implementations must not allocate, lock or block beyond the
//    device transfer itself.
//  * open(), home() and close() run outside the real-time loop and may allocate.
//  * close() must leave the device with zero force, whatever state it is in.
//  * zero_force_from_signal_handler() is called from a fatal-signal handler (daemon/fatal_signal.hpp):
//    only async-signal-safe work; false when the driver cannot command zero force that way.
//  * After a non-Ok status, last_error() describes it (read it outside the loop).
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>

#include "common/axis_vector.hpp"

namespace hapticd {

enum class DeviceStatus : std::uint8_t {
    Ok,
    NotOpen,          // called before open() or after close()
    NotHomed,         // the device needs home() first
    Disconnected,     // transport lost (USB unplugged, ...)
    Timeout,          // transfer did not complete in time
    HardwareFault,    // the device reports a fault (amplifier, encoder, e-stop)
    InvalidArgument,  // non-finite or out-of-range force handed to write_force()
    Unsupported,      // the device cannot do this (e.g. measure the external force)
};

std::string_view to_string(DeviceStatus status) noexcept;

struct DeviceCapabilities {
    std::size_t axes = 1;
    double max_force = 0.0;      // saturation per axis, N (N m)
    AxisVector workspace_min{};  // per axis, m (rad)
    AxisVector workspace_max{};
    double inherent_delay = 0.0;  // estimate of the device's own loop delay, s
    bool rotary = false;          // units are rad / N m / kg m^2 instead of m / N / kg
    bool measures_external_force = false;
};

// Transport-level statistics of real devices (all zero for the simulated device).
struct DeviceCounters {
    std::uint64_t packets_ok = 0;           // valid status packets / input reports received
    std::uint64_t packets_malformed = 0;    // framing or range errors: dropped, never turned into force
    std::uint64_t packets_short = 0;        // truncated packets: dropped
    std::uint64_t garbage_bytes = 0;        // bytes skipped while resynchronising on frame boundaries
    std::uint64_t stale_reads = 0;          // ticks without a new packet (the last position was reused)
    std::uint64_t saturated_commands = 0;   // force commands clamped to the device's or the protocol's range
    std::uint64_t kinematics_failures = 0;  // positions the kinematics could not solve (last one kept)
};

class Device {
  public:
    Device() = default;
    Device(const Device&) = delete;
    Device& operator=(const Device&) = delete;
    virtual ~Device() = default;

    virtual DeviceStatus open() = 0;
    virtual DeviceStatus home() = 0;
    virtual void close() noexcept = 0;
    // Zero force without locks, allocation or library calls that are not async-signal-safe; true when it was
    // written (and, where the driver can tell, taken by the device). The default: the driver cannot.
    virtual bool zero_force_from_signal_handler() noexcept { return false; }

    virtual DeviceStatus read_position(AxisVector& position) noexcept = 0;
    virtual DeviceStatus write_force(const AxisVector& force) noexcept = 0;
    // The force the user (or the simulated scenario) applies, when the device can know it.
    virtual DeviceStatus read_external_force(AxisVector& /*force*/) noexcept { return DeviceStatus::Unsupported; }

    // Homing status: false while the device must not render force because it is not calibrated.
    [[nodiscard]] virtual bool homed() const noexcept { return true; }
    [[nodiscard]] virtual DeviceCounters counters() const noexcept { return {}; }

    [[nodiscard]] virtual const DeviceCapabilities& capabilities() const noexcept = 0;
    [[nodiscard]] virtual std::string_view name() const noexcept = 0;
    [[nodiscard]] virtual std::string last_error() const = 0;
};

}  // namespace hapticd
