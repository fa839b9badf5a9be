// SPDX-License-Identifier: Apache-2.0
// Byte transport to an FTDI-based device (the Novint Falcon's FT232R), separated from the protocol so
// that the protocol, firmware upload and homing logic can run against a scripted in-memory transport
// in tests and against libusb on hardware (transport_libusb.hpp).
//
// All calls are noexcept and report errors as values. read() returns payload bytes only: the two
// modem-status bytes that the FTDI chip puts at the start of every USB packet are removed by the
// implementation (ftdi_protocol.hpp, strip_ftdi_status()).
#pragma once

#include <cstddef>
#include <cstdint>
#include <span>
#include <string>

namespace hapticd {

enum class TransportStatus : std::uint8_t {
    Ok,
    Timeout,       // nothing (or not everything) transferred within the timeout
    Disconnected,  // the device is gone (unplugged)
    AccessDenied,  // permission problem (udev rule missing)
    NotFound,      // no such device
    Error,         // any other transfer error
};

struct TransportResult {
    TransportStatus status = TransportStatus::Ok;
    std::size_t bytes = 0;  // bytes written / payload bytes read
};

class FtdiTransport {
  public:
    FtdiTransport() = default;
    FtdiTransport(const FtdiTransport&) = delete;
    FtdiTransport& operator=(const FtdiTransport&) = delete;
    virtual ~FtdiTransport() = default;

    // A vendor OUT control request without data stage (bmRequestType 0x40), as all FTDI SIO requests.
    virtual TransportStatus control(std::uint8_t request, std::uint16_t value, std::uint16_t index) noexcept = 0;
    virtual TransportResult write(std::span<const std::uint8_t> data, int timeout_ms) noexcept = 0;
    // Reads at most buffer.size() payload bytes; may return fewer (also 0 with status Ok).
    virtual TransportResult read(std::span<std::uint8_t> buffer, int timeout_ms) noexcept = 0;
    // Text of the last failure (not for the real-time path).
    [[nodiscard]] virtual std::string last_error() const = 0;

    // Streaming, for the real-time path: nothing here may block. libnifalcon keeps one command in
    // flight and polls asynchronous transfers (FalconCommLibUSB.cpp write()/issueRead()/poll(),
    // FalconFirmwareNovintSDK.cpp runIOLoop()); the libusb transport does the same with an event
    // thread. The defaults suit a transport whose calls return at once (the scripted one): post() is
    // write() and poll() is read(), both with timeout 0.
    //
    // start_streaming(): from now on IN data is collected in the background. stop_streaming(): waits
    // (bounded) for the transfers in flight, after which the blocking calls above may be used again.
    virtual TransportStatus start_streaming() noexcept { return TransportStatus::Ok; }
    virtual void stop_streaming() noexcept {}
    // Queues one packet; it is sent now, or as soon as the packet in flight completes. A packet still
    // queued is replaced by the newer one (`replaced` = true: the device had not taken the previous
    // command yet). Errors of earlier transfers (unplug, stall) are returned here and by poll().
    virtual TransportStatus post(std::span<const std::uint8_t> data, bool& replaced) noexcept {
        replaced = false;
        return write(data, 0).status;
    }
    // The payload bytes that arrived since the last call (at most buffer.size()); never waits.
    virtual TransportResult poll(std::span<std::uint8_t> buffer) noexcept { return read(buffer, 0); }
    // From a fatal-signal handler while streaming (Device::zero_force_from_signal_handler): `packet` (16 bytes)
    // becomes the last command, post() is ignored from then on, and the call waits at most timeout_ms for the
    // device to have taken it. Only async-signal-safe work in the calling thread. True when the transfer of
    // `packet` completed; the default: the transport cannot.
    virtual bool post_final_from_signal_handler(std::span<const std::uint8_t> /*packet*/, int /*timeout_ms*/) noexcept {
        return false;
    }
};

}  // namespace hapticd
