// SPDX-License-Identifier: Apache-2.0
#include "devices/falcon_device.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <thread>

#include "devices/ftdi_protocol.hpp"

namespace hapticd {

namespace {

DeviceStatus to_device_status(TransportStatus s) noexcept {
    switch (s) {
        case TransportStatus::Ok:
            return DeviceStatus::Ok;
        case TransportStatus::Timeout:
            return DeviceStatus::Timeout;
        case TransportStatus::Disconnected:
        case TransportStatus::NotFound:
            return DeviceStatus::Disconnected;
        case TransportStatus::AccessDenied:
        case TransportStatus::Error:
            return DeviceStatus::HardwareFault;
    }
    return DeviceStatus::HardwareFault;
}

}  // namespace

FalconDevice::FalconDevice(FalconDeviceConfig config) : config_(std::move(config)) {
    const double polls = config_.homing_timeout * 1000.0 / std::max(1, config_.homing_poll_ms);
    gate_ = falcon::HomingGate(static_cast<std::uint64_t>(std::max(1.0, polls)));
}

FalconDevice::~FalconDevice() { close(); }

DeviceStatus FalconDevice::fail(DeviceStatus status, std::string message) {
    error_ = std::move(message);
    rt_error_ = "";
    return status;
}

DeviceStatus FalconDevice::transport_failure(TransportStatus status) noexcept {
    rt_error_ = status == TransportStatus::Disconnected ? "Falcon disconnected (USB transfer: no device)"
                                                        : "Falcon USB transfer failed";
    return to_device_status(status);
}

DeviceStatus FalconDevice::poll_input(std::size_t& frames) noexcept {
    frames = 0;
    // Drain what arrived; a few reads at most. While streaming, poll() never waits; during the set-up
    // (homing) the first read may wait up to io_timeout_ms.
    for (int i = 0; i < 4; ++i) {
        const TransportResult r =
            streaming_ ? transport_->poll(rx_) : transport_->read(rx_, i == 0 ? config_.io_timeout_ms : 0);
        if (r.status != TransportStatus::Ok && r.status != TransportStatus::Timeout) return transport_failure(r.status);
        if (r.bytes == 0) break;
        frames += parser_.feed(rx_.data(), r.bytes, status_);
        if (r.bytes < rx_.size()) break;
    }
    return DeviceStatus::Ok;
}

DeviceStatus FalconDevice::exchange(std::size_t& frames) noexcept {
    const falcon::Packet packet = falcon::encode_command(command_);
    const TransportResult w = transport_->write(packet, 100);
    if (w.status != TransportStatus::Ok) return transport_failure(w.status);
    return poll_input(frames);
}

bool FalconDevice::probe_firmware() {
    if (falcon::set_normal_mode(*transport_) != TransportStatus::Ok) return false;
    parser_.reset();
    command_ = falcon::Command{};
    command_.homing_mode = true;  // zero torque; keep (or start) homing
    for (int i = 0; i < config_.probe_tries; ++i) {
        std::size_t frames = 0;
        if (exchange(frames) != DeviceStatus::Ok) return false;
        if (frames > 0) return true;
    }
    return false;
}

DeviceStatus FalconDevice::open() {
    close();
    error_.clear();
    rt_error_ = "";
    if (!config_.open_transport) return fail(DeviceStatus::Unsupported, "no transport configured for the Falcon");
    OpenedTransport opened = config_.open_transport();
    if (!opened.transport) {
        return fail(
            opened.status == TransportStatus::AccessDenied ? DeviceStatus::HardwareFault : DeviceStatus::Disconnected,
            opened.error);
    }
    transport_ = std::move(opened.transport);
    if (!probe_firmware()) {
        if (config_.firmware_path.empty()) {
            transport_.reset();
            return fail(DeviceStatus::HardwareFault,
                        "the Falcon's firmware is not running and no firmware file was given: set `firmware = "
                        "\"/path/to/falcon_firmware.bin\"` in the device profile or pass --falcon-firmware FILE "
                        "(hapticd does not ship Novint's firmware; see docs/devices.md)");
        }
        std::string read_error;
        const std::vector<std::uint8_t> image = falcon::read_firmware_file(config_.firmware_path, read_error);
        if (image.empty()) {
            transport_.reset();
            return fail(DeviceStatus::HardwareFault, read_error);
        }
        if (config_.notify) {
            config_.notify("Falcon firmware not running: uploading '" + config_.firmware_path + "' (" +
                           std::to_string(image.size()) + " bytes)");
        }
        const falcon::ReopenTransport reopen = [this](std::string& error) -> FtdiTransport* {
            transport_.reset();
            OpenedTransport again = config_.open_transport();
            error = again.error;
            transport_ = std::move(again.transport);
            return transport_.get();
        };
        const falcon::FirmwareUploadResult up = falcon::upload_firmware(*transport_, image, config_.upload, reopen);
        if (!transport_) return fail(DeviceStatus::Disconnected, up.message);
        if (!up.ok) {
            const DeviceStatus s = up.transport == TransportStatus::Disconnected ? DeviceStatus::Disconnected
                                                                                 : DeviceStatus::HardwareFault;
            transport_.reset();
            return fail(s, up.message + " (firmware file '" + config_.firmware_path + "')");
        }
        if (config_.notify) config_.notify(up.message);
        if (!probe_firmware()) {
            transport_.reset();
            return fail(DeviceStatus::HardwareFault,
                        "the firmware from '" + config_.firmware_path +
                            "' was uploaded but the Falcon does not answer with status packets (wrong firmware file?)");
        }
    }
    open_ = true;
    gate_.reset();
    return DeviceStatus::Ok;
}

DeviceStatus FalconDevice::home() {
    if (!open_) return fail(DeviceStatus::NotOpen, "home() before open()");
    if (streaming_) {
        transport_->stop_streaming();
        streaming_ = false;
    }
    gate_.reset();
    bool told = false;
    while (true) {
        command_ = falcon::Command{};
        command_.homing_mode = true;
        command_.leds = gate_.leds();
        std::size_t frames = 0;
        if (const DeviceStatus s = exchange(frames); s != DeviceStatus::Ok) {
            return fail(s, std::string("homing: ") + rt_error_);
        }
        const falcon::HomingState state = gate_.update(frames > 0, status_.homed_mask);
        if (state == falcon::HomingState::Homed) break;
        if (config_.cancel && config_.cancel()) {
            return fail(DeviceStatus::NotHomed, "homing interrupted by a stop request (" + gate_.describe() + ")");
        }
        if (state == falcon::HomingState::TimedOut) {
            return fail(DeviceStatus::NotHomed, std::string(falcon::kHomingInstructions) + "; gave up after " +
                                                    std::to_string(config_.homing_timeout) + " s (" + gate_.describe() +
                                                    ")");
        }
        if (!told && config_.notify) {
            config_.notify(falcon::kHomingInstructions);
            told = true;
        }
        if (config_.homing_poll_ms > 0) std::this_thread::sleep_for(std::chrono::milliseconds(config_.homing_poll_ms));
    }
    // Homed: green LED, and a first position so that the kinematics' Newton iteration starts close.
    command_ = falcon::Command{};
    command_.homing_mode = true;
    command_.leds = gate_.leds();
    kinematic_position_ = config_.origin;
    falcon::Vec3 theta{};
    for (std::size_t i = 0; i < 3; ++i) theta[i] = falcon::encoder_to_angle(status_.encoder[i], config_.geometry);
    const falcon::ForwardResult fk = falcon::forward_kinematics(theta, config_.geometry, kinematic_position_, 100);
    if (!fk.converged) {
        return fail(DeviceStatus::HardwareFault,
                    "homing: the encoder counts do not correspond to a reachable position");
    }
    if (config_.notify) config_.notify("Falcon homed (LED green)");
    if (const DeviceStatus s = wait_for_release(); s != DeviceStatus::Ok) return s;
    if (const TransportStatus t = transport_->start_streaming(); t != TransportStatus::Ok) {
        return fail(to_device_status(t),
                    "cannot start the Falcon's asynchronous transfers: " + transport_->last_error());
    }
    zero_packet_ = falcon::encode_command(falcon::Command{});
    streaming_ = true;
    return DeviceStatus::Ok;
}

bool FalconDevice::zero_force_from_signal_handler() noexcept {
    return streaming_ && transport_ &&
           transport_->post_final_from_signal_handler(zero_packet_, config_.signal_zero_timeout_ms);
}

bool FalconDevice::update_kinematics(int max_iterations) noexcept {
    falcon::Vec3 theta{};
    for (std::size_t i = 0; i < 3; ++i) theta[i] = falcon::encoder_to_angle(status_.encoder[i], config_.geometry);
    falcon::Vec3 p = kinematic_position_;
    const falcon::ForwardResult fk = falcon::forward_kinematics(theta, config_.geometry, p, max_iterations, 1e-10);
    if (fk.converged) kinematic_position_ = p;
    return fk.converged;
}

// After homing the grip sits pushed in; libnifalcon's examples render nothing until it has been pulled
// out past z = 0.170 m (FalconCubeTest.cpp). Zero torque, homing bit and green LED meanwhile.
DeviceStatus FalconDevice::wait_for_release() {
    if (kinematic_position_[2] > config_.release_z) return DeviceStatus::Ok;
    if (config_.notify) {
        config_.notify("Falcon: pull the grip out towards you (past z = " + std::to_string(config_.release_z) +
                       " m); forces start after that");
    }
    const double polls = config_.homing_timeout * 1000.0 / std::max(1, config_.homing_poll_ms);
    for (double i = 0; i < std::max(1.0, polls); ++i) {
        std::size_t frames = 0;
        if (const DeviceStatus s = exchange(frames); s != DeviceStatus::Ok) {
            return fail(s, std::string("waiting for the grip to be pulled out: ") + rt_error_);
        }
        if (frames > 0) {
            if ((status_.homed_mask & falcon::kAllAxesHomed) != falcon::kAllAxesHomed) {
                return fail(DeviceStatus::NotHomed,
                            "the Falcon lost its homing while waiting for the grip to be pulled out");
            }
            if (update_kinematics(100) && kinematic_position_[2] > config_.release_z) return DeviceStatus::Ok;
        }
        if (config_.cancel && config_.cancel()) {
            return fail(DeviceStatus::NotHomed,
                        "interrupted by a stop request while waiting for the grip to be pulled out");
        }
        if (config_.homing_poll_ms > 0) std::this_thread::sleep_for(std::chrono::milliseconds(config_.homing_poll_ms));
    }
    return fail(DeviceStatus::NotHomed, "the grip was not pulled out past z = " + std::to_string(config_.release_z) +
                                            " m within " + std::to_string(config_.homing_timeout) +
                                            " s after homing (no force is rendered before that)");
}

void FalconDevice::close() noexcept {
    if (transport_ && streaming_) transport_->stop_streaming();  // then the blocking writes below
    streaming_ = false;
    if (transport_) {
        // Zero torque, LEDs off, a few times in case one packet is lost.
        command_ = falcon::Command{};
        const falcon::Packet packet = falcon::encode_command(command_);
        for (int i = 0; i < 3; ++i) {
            if (transport_->write(packet, 100).status != TransportStatus::Ok) break;
        }
    }
    transport_.reset();
    open_ = false;
}

DeviceStatus FalconDevice::read_position(AxisVector& position) noexcept {
    if (!open_ || !transport_) return DeviceStatus::NotOpen;
    std::size_t frames = 0;
    if (const DeviceStatus s = poll_input(frames); s != DeviceStatus::Ok) return s;
    if (frames == 0) {
        ++stale_reads_;
        if (++consecutive_stale_ > config_.max_stale_reads) {
            rt_error_ = "no status packet from the Falcon for too many ticks";
            return DeviceStatus::Timeout;
        }
    } else {
        consecutive_stale_ = 0;
        gate_.update(true, status_.homed_mask);
        if (!gate_.force_allowed()) {
            rt_error_ = "the Falcon lost its homing (re-home: pull the grip out, push it in)";
            return DeviceStatus::NotHomed;
        }
        if (update_kinematics(8)) {
            consecutive_kinematics_failures_ = 0;
        } else {
            ++kinematics_failures_;
            if (++consecutive_kinematics_failures_ > config_.max_kinematics_failures) {
                rt_error_ = "the Falcon's encoder counts do not correspond to a reachable position";
                return DeviceStatus::HardwareFault;
            }
        }
    }
    for (std::size_t i = 0; i < 3; ++i) position[i] = kinematic_position_[i] - config_.origin[i];
    return DeviceStatus::Ok;
}

DeviceStatus FalconDevice::write_force(const AxisVector& force) noexcept {
    if (!open_ || !transport_) return DeviceStatus::NotOpen;
    command_.homing_mode = true;  // must stay set for the Falcon to stay homed (libnifalcon FalconFirmware.h)
    command_.leds = gate_.leds();
    command_.torque = {0, 0, 0};
    DeviceStatus result = DeviceStatus::Ok;
    bool finite = true;
    for (double f : force) finite = finite && std::isfinite(f);
    if (!finite) {
        rt_error_ = "non-finite force command";
        result = DeviceStatus::InvalidArgument;
    } else if (!gate_.force_allowed()) {
        rt_error_ = "force requested while the Falcon is not homed";
        result = DeviceStatus::NotHomed;
    } else {
        const double limit = config_.capabilities.max_force;
        falcon::Vec3 F{};
        bool saturated = false;
        for (std::size_t i = 0; i < 3; ++i) {
            F[i] = std::clamp(force[i], -limit, limit);
            saturated = saturated || F[i] != force[i];
        }
        falcon::Vec3 tau{};
        if (!falcon::force_to_torque(kinematic_position_, F, config_.geometry, tau)) {
            ++kinematics_failures_;  // singular pose: zero torque this tick
        } else {
            double largest = 0.0;
            for (double t : tau) largest = std::max(largest, std::abs(t * config_.geometry.torque_to_command));
            // Scale all three together so the force keeps its direction when one motor saturates.
            const double scale = largest > falcon::kMaxTorqueCommand ? falcon::kMaxTorqueCommand / largest : 1.0;
            saturated = saturated || scale < 1.0;
            for (std::size_t i = 0; i < 3; ++i) {
                command_.torque[i] =
                    static_cast<std::int16_t>(std::lround(tau[i] * config_.geometry.torque_to_command * scale));
            }
        }
        if (saturated) ++saturated_;
    }
    // Never waits: queued for the event thread (one command in flight); a command the Falcon had not
    // taken yet is replaced by this newer one and counted as late.
    bool replaced = false;
    const TransportStatus w =
        streaming_ ? transport_->post(falcon::encode_command(command_), replaced)
                   : transport_->write(falcon::encode_command(command_), config_.io_timeout_ms + 1).status;
    if (replaced) ++late_commands_;
    if (w != TransportStatus::Ok) return transport_failure(w);
    return result;
}

DeviceCounters FalconDevice::counters() const noexcept {
    DeviceCounters c;
    const falcon::FrameCounters& f = parser_.counters();
    c.packets_ok = f.frames;
    c.packets_malformed = f.malformed;
    c.packets_short = f.short_frames;
    c.garbage_bytes = f.garbage_bytes;
    c.stale_reads = stale_reads_;
    c.saturated_commands = saturated_;
    c.kinematics_failures = kinematics_failures_;
    return c;
}

}  // namespace hapticd
