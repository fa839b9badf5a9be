// FtdiTransport over libusb-1.0 (synchronous transfers) for the Novint Falcon's FT232R.
// Note for the real-time path: hapticd itself does not allocate here (fixed buffers), but libusb's
// synchronous API allocates a transfer per call internally; see docs/devices.md.
#pragma once

#include <array>
#include <cstdint>
#include <string>

#include "devices/falcon_device.hpp"
#include "devices/transport.hpp"

struct libusb_context;
struct libusb_device_handle;

namespace hapticd {

inline constexpr const char* kUdevHint =
    "install the udev rule: sudo cp config/udev/70-hapticd.rules /etc/udev/rules.d/ && "
    "sudo udevadm control --reload && sudo udevadm trigger, add yourself to the plugdev group "
    "(sudo usermod -aG plugdev $USER, then log in again) and replug the device";

class LibusbFtdiTransport final : public FtdiTransport {
public:
    // Opens the `index`-th device with the Falcon's VID:PID and claims interface 0.
    static OpenedTransport open_falcon(int index = 0);
    ~LibusbFtdiTransport() override;

    TransportStatus control(std::uint8_t request, std::uint16_t value, std::uint16_t index) noexcept override;
    TransportResult write(std::span<const std::uint8_t> data, int timeout_ms) noexcept override;
    TransportResult read(std::span<std::uint8_t> buffer, int timeout_ms) noexcept override;
    [[nodiscard]] std::string last_error() const override;

private:
    LibusbFtdiTransport(libusb_context* context, libusb_device_handle* handle) noexcept
        : context_(context), handle_(handle) {}
    TransportStatus map(int libusb_error) noexcept;

    libusb_context* context_ = nullptr;
    libusb_device_handle* handle_ = nullptr;
    std::array<std::uint8_t, 512> raw_{};      // one bulk-IN transfer (8 full-speed packets)
    std::array<std::uint8_t, 512> pending_{};  // payload not yet handed out
    std::size_t pending_size_ = 0;
    int last_error_code_ = 0;
};

}  // namespace hapticd
