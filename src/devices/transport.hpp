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
};

}  // namespace hapticd
