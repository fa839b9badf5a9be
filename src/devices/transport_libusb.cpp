#include "devices/transport_libusb.hpp"

#include <libusb.h>

#include <algorithm>
#include <cstring>

#include "devices/ftdi_protocol.hpp"

namespace hapticd {

namespace {

TransportStatus map_error(int code) noexcept {
    switch (code) {
        case LIBUSB_SUCCESS: return TransportStatus::Ok;
        case LIBUSB_ERROR_TIMEOUT: return TransportStatus::Timeout;
        case LIBUSB_ERROR_NO_DEVICE: return TransportStatus::Disconnected;
        case LIBUSB_ERROR_ACCESS: return TransportStatus::AccessDenied;
        case LIBUSB_ERROR_NOT_FOUND: return TransportStatus::NotFound;
        default: return TransportStatus::Error;
    }
}

}  // namespace

OpenedTransport LibusbFtdiTransport::open_falcon(int index) {
    OpenedTransport out;
    libusb_context* ctx = nullptr;
    if (const int rc = libusb_init(&ctx); rc != 0) {
        out.status = TransportStatus::Error;
        out.error = std::string("libusb_init failed: ") + libusb_error_name(rc);
        return out;
    }
    libusb_device** list = nullptr;
    const ssize_t n = libusb_get_device_list(ctx, &list);
    libusb_device* found = nullptr;
    int seen = 0;
    for (ssize_t i = 0; i < n; ++i) {
        libusb_device_descriptor desc{};
        if (libusb_get_device_descriptor(list[i], &desc) != 0) continue;
        if (desc.idVendor == ftdi::kFalconVendorId && desc.idProduct == ftdi::kFalconProductId && seen++ == index) {
            found = libusb_ref_device(list[i]);
        }
    }
    if (list != nullptr) libusb_free_device_list(list, 1);
    if (found == nullptr) {
        libusb_exit(ctx);
        out.status = TransportStatus::NotFound;
        out.error = "no Novint Falcon found (driver \"falcon\", looked for USB 0403:cb48" +
                    (index > 0 ? ", device #" + std::to_string(index) : std::string()) +
                    "); is it plugged in and powered? `hapticd --list-devices` shows what hapticd sees; "
                    "--simulate runs the profile on the simulated device";
        return out;
    }
    libusb_device_handle* handle = nullptr;
    const int rc = libusb_open(found, &handle);
    libusb_unref_device(found);
    if (rc != 0) {
        libusb_exit(ctx);
        out.status = map_error(rc);
        out.error = std::string("cannot open the Novint Falcon (USB 0403:cb48): ") + libusb_error_name(rc);
        if (rc == LIBUSB_ERROR_ACCESS) out.error += "; permission denied: " + std::string(kUdevHint);
        return out;
    }
    libusb_set_auto_detach_kernel_driver(handle, 1);
    if (const int claim = libusb_claim_interface(handle, 0); claim != 0) {
        libusb_close(handle);
        libusb_exit(ctx);
        out.status = map_error(claim);
        out.error = std::string("cannot claim the Novint Falcon's USB interface: ") + libusb_error_name(claim) +
                    (claim == LIBUSB_ERROR_BUSY ? " (another program, e.g. a second hapticd, is using it)" : "");
        return out;
    }
    out.transport.reset(new LibusbFtdiTransport(ctx, handle));
    out.status = TransportStatus::Ok;
    return out;
}

LibusbFtdiTransport::~LibusbFtdiTransport() {
    if (handle_ != nullptr) {
        libusb_release_interface(handle_, 0);
        libusb_close(handle_);
    }
    if (context_ != nullptr) libusb_exit(context_);
}

TransportStatus LibusbFtdiTransport::map(int code) noexcept {
    last_error_code_ = code;
    return map_error(code);
}

TransportStatus LibusbFtdiTransport::control(std::uint8_t request, std::uint16_t value, std::uint16_t index) noexcept {
    constexpr auto kVendorOut = static_cast<std::uint8_t>(static_cast<unsigned>(LIBUSB_REQUEST_TYPE_VENDOR) |
                                                          static_cast<unsigned>(LIBUSB_RECIPIENT_DEVICE) |
                                                          static_cast<unsigned>(LIBUSB_ENDPOINT_OUT));  // 0x40
    const int rc = libusb_control_transfer(handle_, kVendorOut, request, value, index, nullptr, 0, 1000);
    if (request == ftdi::kRequestReset && (value == ftdi::kPurgeRx || value == ftdi::kResetSio)) pending_size_ = 0;
    return map(rc < 0 ? rc : 0);
}

TransportResult LibusbFtdiTransport::write(std::span<const std::uint8_t> data, int timeout_ms) noexcept {
    int transferred = 0;
    // libusb's buffer argument is not const, but an OUT transfer does not modify it.
    const int rc = libusb_bulk_transfer(handle_, ftdi::kEndpointOut, const_cast<std::uint8_t*>(data.data()),
                                        static_cast<int>(data.size()), &transferred, static_cast<unsigned>(std::max(1, timeout_ms)));
    const TransportStatus s = map(rc);
    return {s == TransportStatus::Timeout && transferred > 0 ? TransportStatus::Ok : s,
            static_cast<std::size_t>(transferred)};
}

TransportResult LibusbFtdiTransport::read(std::span<std::uint8_t> buffer, int timeout_ms) noexcept {
    if (pending_size_ == 0) {
        int transferred = 0;
        const int rc = libusb_bulk_transfer(handle_, ftdi::kEndpointIn, raw_.data(), static_cast<int>(raw_.size()),
                                            &transferred, static_cast<unsigned>(std::max(1, timeout_ms)));
        const TransportStatus s = map(rc);
        if (s != TransportStatus::Ok && !(s == TransportStatus::Timeout && transferred > 0)) {
            return {s == TransportStatus::Timeout ? TransportStatus::Ok : s, 0};  // no data yet is not an error
        }
        pending_size_ = ftdi::strip_ftdi_status(raw_.data(), static_cast<std::size_t>(transferred), pending_.data());
    }
    const std::size_t n = std::min(buffer.size(), pending_size_);
    std::memcpy(buffer.data(), pending_.data(), n);
    std::memmove(pending_.data(), pending_.data() + n, pending_size_ - n);
    pending_size_ -= n;
    return {TransportStatus::Ok, n};
}

std::string LibusbFtdiTransport::last_error() const {
    return last_error_code_ == 0 ? std::string("no error") : std::string(libusb_error_name(last_error_code_));
}

}  // namespace hapticd
