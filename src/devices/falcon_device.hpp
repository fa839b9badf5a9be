// SPDX-License-Identifier: Apache-2.0
// The Novint Falcon as a hapticd Device: firmware upload and homing at start, then per tick one status
// packet in (encoders -> motor angles -> forward kinematics) and one command packet out (Cartesian
// force -> Jacobian-transpose torques -> clamped protocol values). The transport is injected, so the
// whole device runs against ScriptedTransport in tests and against libusb on hardware.
//
// Positions are in m in the kinematic frame of falcon_kinematics.hpp (z along the axis the grip moves in
// and out, x and y across it) shifted by `origin`, so that the middle of the workspace is 0. Forces in N.
#pragma once

#include <functional>
#include <memory>
#include <string>

#include "devices/device.hpp"
#include "devices/falcon_firmware.hpp"
#include "devices/falcon_homing.hpp"
#include "devices/falcon_kinematics.hpp"
#include "devices/falcon_protocol.hpp"
#include "devices/transport.hpp"

namespace hapticd {

struct OpenedTransport {
    std::unique_ptr<FtdiTransport> transport;  // null on failure
    TransportStatus status = TransportStatus::NotFound;
    std::string error;
};

struct FalconDeviceConfig {
    DeviceCapabilities capabilities;
    std::string firmware_path;  // "" : only works when the firmware is already running
    falcon::Geometry geometry = falcon::Geometry::published();
    falcon::Vec3 origin{0.0, 0.0, 0.125};  // m, subtracted from the kinematic position
    double homing_timeout = 60.0;          // s
    int homing_poll_ms = 1;                // sleep between homing polls (0 in tests)
    int io_timeout_ms = 1;                 // read timeout of the set-up exchanges (the loop never waits)
    // How long a fatal-signal handler waits for the Falcon to take the zero-torque command (the process ends
    // then either way): ~50 transfers of the 1 kHz stream.
    int signal_zero_timeout_ms = 50;
    // Forces start only after the grip has left the homing pose: libnifalcon's examples
    // (examples/falcon_test_cli/FalconCubeTest.cpp) wait until the kinematic z exceeds 0.170 m
    // ("Move the end effector all the way out") before rendering anything.
    double release_z = 0.170;          // m, kinematic frame (before `origin` is subtracted)
    int probe_tries = 50;              // packets sent to see whether the firmware runs
    int max_stale_reads = 100;         // consecutive ticks without a packet -> Timeout
    int max_kinematics_failures = 10;  // consecutive unsolvable positions -> HardwareFault
    falcon::FirmwareUploadConfig upload;
    std::function<OpenedTransport()> open_transport;
    std::function<void(const std::string&)> notify;  // user instructions (homing); may be empty
    std::function<bool()> cancel;                    // true: stop waiting for homing (SIGINT); may be empty
};

class FalconDevice final : public Device {
  public:
    explicit FalconDevice(FalconDeviceConfig config);
    ~FalconDevice() override;

    DeviceStatus open() override;
    DeviceStatus home() override;
    void close() noexcept override;
    // While streaming: a zero-torque command (built before the loop starts) handed to the transport as the last
    // command (FtdiTransport::post_final_from_signal_handler: the libusb transport's event thread sends it);
    // true once the Falcon has taken it, within FalconDeviceConfig::signal_zero_timeout_ms.
    bool zero_force_from_signal_handler() noexcept override;

    DeviceStatus read_position(AxisVector& position) noexcept override;
    DeviceStatus write_force(const AxisVector& force) noexcept override;

    [[nodiscard]] bool homed() const noexcept override { return gate_.force_allowed(); }
    [[nodiscard]] DeviceCounters counters() const noexcept override;
    [[nodiscard]] const DeviceCapabilities& capabilities() const noexcept override { return config_.capabilities; }
    [[nodiscard]] std::string_view name() const noexcept override { return "falcon"; }
    [[nodiscard]] std::string last_error() const override { return *rt_error_ != '\0' ? rt_error_ : error_; }

    [[nodiscard]] const falcon::Status& last_status() const noexcept { return status_; }
    [[nodiscard]] const falcon::Command& last_command() const noexcept { return command_; }
    // Commands that replaced one the Falcon had not taken yet (one command in flight; see transport.hpp).
    [[nodiscard]] std::uint64_t late_commands() const noexcept { return late_commands_; }

  private:
    // One exchange without the kinematics: sends `command_`, reads and parses what arrived.
    // Returns Ok / Disconnected / HardwareFault; `frames` = valid frames decoded.
    DeviceStatus exchange(std::size_t& frames) noexcept;
    DeviceStatus poll_input(std::size_t& frames) noexcept;
    DeviceStatus fail(DeviceStatus status, std::string message);
    DeviceStatus transport_failure(TransportStatus status) noexcept;
    bool probe_firmware();
    DeviceStatus wait_for_release();
    bool update_kinematics(int max_iterations) noexcept;

    FalconDeviceConfig config_;
    std::unique_ptr<FtdiTransport> transport_;
    falcon::FrameParser parser_;
    falcon::HomingGate gate_;
    falcon::Status status_;
    falcon::Command command_;
    falcon::Vec3 kinematic_position_{};
    std::array<std::uint8_t, 512> rx_{};
    std::uint64_t stale_reads_ = 0;
    std::uint64_t saturated_ = 0;
    std::uint64_t kinematics_failures_ = 0;
    std::uint64_t late_commands_ = 0;
    int consecutive_stale_ = 0;
    int consecutive_kinematics_failures_ = 0;
    bool open_ = false;
    bool streaming_ = false;
    falcon::Packet zero_packet_{};  // zero torque, LEDs off: the fatal-signal handler's command
    std::string error_;             // set outside the real-time path
    const char* rt_error_ = "";     // set in the real-time path (static text: no allocation)
};

}  // namespace hapticd
