// SPDX-License-Identifier: Apache-2.0
#include "devices/transport_libusb.hpp"

#include <libusb.h>
#include <poll.h>
#include <sys/eventfd.h>
#include <time.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstring>

#include "devices/ftdi_protocol.hpp"

namespace hapticd {

namespace {

TransportStatus map_error(int code) noexcept {
    switch (code) {
        case LIBUSB_SUCCESS:
            return TransportStatus::Ok;
        case LIBUSB_ERROR_TIMEOUT:
            return TransportStatus::Timeout;
        case LIBUSB_ERROR_NO_DEVICE:
            return TransportStatus::Disconnected;
        case LIBUSB_ERROR_ACCESS:
            return TransportStatus::AccessDenied;
        case LIBUSB_ERROR_NOT_FOUND:
            return TransportStatus::NotFound;
        default:
            return TransportStatus::Error;
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
    stop_streaming();
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
                                        static_cast<int>(data.size()), &transferred,
                                        static_cast<unsigned>(std::max(1, timeout_ms)));
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

// ---- Streaming ---------------------------------------------------------------------------------

TransportStatus LibusbFtdiTransport::start_streaming() noexcept {
    if (streaming_) return TransportStatus::Ok;
    wake_fd_ = eventfd(0, EFD_NONBLOCK | EFD_CLOEXEC);
    in_transfer_ = libusb_alloc_transfer(0);
    out_transfer_ = libusb_alloc_transfer(0);
    if (wake_fd_ < 0 || in_transfer_ == nullptr || out_transfer_ == nullptr) {
        stop_streaming();
        last_error_code_ = LIBUSB_ERROR_NO_MEM;
        return TransportStatus::Error;
    }
    stop_.store(false);
    stream_status_.store(0);
    ring_head_.store(0);
    ring_tail_.store(0);
    pending_size_ = 0;
    posted_seq_ = mailbox_seq_.load();
    sent_seq_.store(posted_seq_);
    // Timeout 0 = none: the FTDI chip completes the IN transfer every latency period on its own.
    libusb_fill_bulk_transfer(in_transfer_, handle_, ftdi::kEndpointIn, in_buffer_.data(),
                              static_cast<int>(in_buffer_.size()), &LibusbFtdiTransport::on_in_done, this, 0);
    in_active_.store(true);
    if (const int rc = libusb_submit_transfer(in_transfer_); rc != 0) {
        in_active_.store(false);
        stop_streaming();
        return map(rc);
    }
    streaming_ = true;
    final_.store(false);
    try {
        event_thread_ = std::thread([this] { event_loop(); });
        stream_running_.store(true, std::memory_order_release);
    } catch (...) {
        libusb_cancel_transfer(in_transfer_);
        timeval tv{0, 100000};
        while (in_active_.load()) libusb_handle_events_timeout_completed(context_, &tv, nullptr);
        streaming_ = false;
        stop_streaming();
        return TransportStatus::Error;
    }
    return TransportStatus::Ok;
}

void LibusbFtdiTransport::stop_streaming() noexcept {
    stream_running_.store(false, std::memory_order_release);
    if (streaming_) {
        stop_.store(true);
        const std::uint64_t one = 1;
        [[maybe_unused]] const ssize_t w = ::write(wake_fd_, &one, sizeof one);
        if (event_thread_.joinable()) event_thread_.join();
        streaming_ = false;
    }
    if (in_transfer_ != nullptr && !in_active_.load()) {
        libusb_free_transfer(in_transfer_);
        in_transfer_ = nullptr;
    }
    if (out_transfer_ != nullptr && !out_active_.load()) {
        libusb_free_transfer(out_transfer_);
        out_transfer_ = nullptr;
    }
    if (wake_fd_ >= 0) {
        ::close(wake_fd_);
        wake_fd_ = -1;
    }
}

void LibusbFtdiTransport::event_loop() noexcept {
    std::array<pollfd, 16> fds{};
    // On stop: cancel, then wait at most 500 ms for the cancellations; a transfer libusb never gives back
    // (a device gone without notice) is left allocated rather than the close hanging.
    std::chrono::steady_clock::time_point give_up{};
    bool cancelled = false;
    while (true) {
        const bool stopping = stop_.load(std::memory_order_acquire);
        if (stopping && !cancelled) {
            if (in_active_.load()) libusb_cancel_transfer(in_transfer_);
            if (out_active_.load()) libusb_cancel_transfer(out_transfer_);
            cancelled = true;
            give_up = std::chrono::steady_clock::now() + std::chrono::milliseconds(500);
        }
        if (stopping && !in_active_.load() && !out_active_.load()) break;
        if (stopping && std::chrono::steady_clock::now() > give_up) break;
        // Wait for a libusb fd (transfer completion) or the wake-up eventfd (a new command, a stop).
        std::size_t n = 0;
        fds[n++] = {wake_fd_, POLLIN, 0};
        if (const libusb_pollfd** list = libusb_get_pollfds(context_); list != nullptr) {
            for (const libusb_pollfd** p = list; *p != nullptr && n < fds.size(); ++p) {
                fds[n++] = {(*p)->fd, (*p)->events, 0};
            }
            libusb_free_pollfds(list);
        }
        ::poll(fds.data(), n, stopping ? 5 : 50);
        if ((fds[0].revents & POLLIN) != 0) {
            std::uint64_t count = 0;
            [[maybe_unused]] const ssize_t r = ::read(wake_fd_, &count, sizeof count);
        }
        timeval zero{0, 0};
        libusb_handle_events_timeout_completed(context_, &zero, nullptr);
        if (!stopping) submit_out_if_due();
    }
}

void LibusbFtdiTransport::fail_stream(TransportStatus status) noexcept {
    int expected = 0;
    stream_status_.compare_exchange_strong(expected, static_cast<int>(status));
}

void LibusbFtdiTransport::submit_out_if_due() noexcept {
    if (out_active_.load() || stream_status_.load() != 0) return;
    // Read the newest command from the seqlock mailbox (retry while the real-time thread writes it).
    std::uint32_t before = 0;
    std::array<std::uint64_t, 2> words{};
    do {
        before = mailbox_seq_.load(std::memory_order_acquire);
        if ((before & 1U) != 0) continue;
        words[0] = mailbox_[0].load(std::memory_order_relaxed);
        words[1] = mailbox_[1].load(std::memory_order_relaxed);
        std::atomic_thread_fence(std::memory_order_acquire);
    } while ((before & 1U) != 0 || mailbox_seq_.load(std::memory_order_relaxed) != before);
    if (before == sent_seq_.load(std::memory_order_relaxed)) return;  // nothing new
    std::memcpy(out_buffer_.data(), words.data(), kPacketBytes);
    libusb_fill_bulk_transfer(out_transfer_, handle_, ftdi::kEndpointOut, out_buffer_.data(),
                              static_cast<int>(kPacketBytes), &LibusbFtdiTransport::on_out_done, this, 100);
    out_active_.store(true);
    if (const int rc = libusb_submit_transfer(out_transfer_); rc != 0) {
        out_active_.store(false);
        fail_stream(map_error(rc));
        return;
    }
    in_flight_seq_ = before;
    sent_seq_.store(before, std::memory_order_release);
}

bool LibusbFtdiTransport::ring_push(const std::uint8_t* data, std::size_t n) noexcept {
    const std::size_t head = ring_head_.load(std::memory_order_relaxed);
    const std::size_t tail = ring_tail_.load(std::memory_order_acquire);
    if (kRingSize - (head - tail) < n) return false;
    for (std::size_t i = 0; i < n; ++i) ring_[(head + i) & (kRingSize - 1)] = data[i];
    ring_head_.store(head + n, std::memory_order_release);
    return true;
}

void LibusbFtdiTransport::on_in_done(libusb_transfer* transfer) {
    auto* self = static_cast<LibusbFtdiTransport*>(transfer->user_data);
    switch (transfer->status) {
        case LIBUSB_TRANSFER_COMPLETED: {
            std::array<std::uint8_t, 512> payload{};
            const std::size_t n = ftdi::strip_ftdi_status(
                transfer->buffer, static_cast<std::size_t>(transfer->actual_length), payload.data());
            if (n > 0 && !self->ring_push(payload.data(), n))
                self->ring_overflows_.fetch_add(1, std::memory_order_relaxed);
            if (!self->stop_.load() && libusb_submit_transfer(transfer) == 0) return;  // keep one IN in flight
            if (!self->stop_.load()) self->fail_stream(TransportStatus::Disconnected);
            break;
        }
        case LIBUSB_TRANSFER_CANCELLED:
            break;
        case LIBUSB_TRANSFER_NO_DEVICE:
            self->fail_stream(TransportStatus::Disconnected);
            break;
        case LIBUSB_TRANSFER_TIMED_OUT:
            if (!self->stop_.load() && libusb_submit_transfer(transfer) == 0) return;
            self->fail_stream(TransportStatus::Error);
            break;
        default:
            self->fail_stream(TransportStatus::Error);
            break;  // STALL, ERROR, OVERFLOW
    }
    self->in_active_.store(false);
}

void LibusbFtdiTransport::on_out_done(libusb_transfer* transfer) {
    auto* self = static_cast<LibusbFtdiTransport*>(transfer->user_data);
    switch (transfer->status) {
        case LIBUSB_TRANSFER_COMPLETED:
            self->done_seq_.store(self->in_flight_seq_, std::memory_order_release);
            break;
        case LIBUSB_TRANSFER_CANCELLED:
            break;
        case LIBUSB_TRANSFER_NO_DEVICE:
            self->fail_stream(TransportStatus::Disconnected);
            break;
        case LIBUSB_TRANSFER_TIMED_OUT:
            self->fail_stream(TransportStatus::Timeout);
            break;
        default:
            self->fail_stream(TransportStatus::Error);
            break;
    }
    self->out_active_.store(false);
    if (!self->stop_.load()) self->submit_out_if_due();  // a newer command may be waiting
}

TransportStatus LibusbFtdiTransport::post(std::span<const std::uint8_t> data, bool& replaced) noexcept {
    replaced = false;
    if (final_.load(std::memory_order_acquire)) return TransportStatus::Ok;  // the process is dying: zero stays
    if (!streaming_) return write(data, 1).status;
    if (const int s = stream_status_.load(std::memory_order_acquire); s != 0) return static_cast<TransportStatus>(s);
    if (data.size() != kPacketBytes) return TransportStatus::Error;
    // The previous command was not submitted yet: it is overwritten (counted by the caller as late).
    replaced = sent_seq_.load(std::memory_order_acquire) != posted_seq_;
    std::array<std::uint64_t, 2> words{};
    std::memcpy(words.data(), data.data(), kPacketBytes);
    const std::uint32_t seq = posted_seq_;
    mailbox_seq_.store(seq + 1, std::memory_order_relaxed);  // odd: writing
    std::atomic_thread_fence(std::memory_order_release);
    mailbox_[0].store(words[0], std::memory_order_relaxed);
    mailbox_[1].store(words[1], std::memory_order_relaxed);
    mailbox_seq_.store(seq + 2, std::memory_order_release);
    posted_seq_ = seq + 2;
    const std::uint64_t one = 1;
    [[maybe_unused]] const ssize_t w = ::write(wake_fd_, &one, sizeof one);  // eventfd: never blocks (EFD_NONBLOCK)
    return TransportStatus::Ok;
}

TransportResult LibusbFtdiTransport::poll(std::span<std::uint8_t> buffer) noexcept {
    if (!streaming_) return read(buffer, 1);
    const std::size_t tail = ring_tail_.load(std::memory_order_relaxed);
    const std::size_t head = ring_head_.load(std::memory_order_acquire);
    const std::size_t n = std::min(buffer.size(), head - tail);
    for (std::size_t i = 0; i < n; ++i) buffer[i] = ring_[(tail + i) & (kRingSize - 1)];
    ring_tail_.store(tail + n, std::memory_order_release);
    if (n == 0) {
        if (const int s = stream_status_.load(std::memory_order_acquire); s != 0) {
            return {static_cast<TransportStatus>(s), 0};
        }
    }
    return {TransportStatus::Ok, n};
}

std::string LibusbFtdiTransport::last_error() const {
    return last_error_code_ == 0 ? std::string("no error") : std::string(libusb_error_name(last_error_code_));
}

namespace {

std::int64_t signal_safe_now_ns() noexcept {
    timespec ts{};
    ::clock_gettime(CLOCK_MONOTONIC, &ts);  // async-signal-safe (POSIX)
    return static_cast<std::int64_t>(ts.tv_sec) * 1000000000 + ts.tv_nsec;
}

void signal_safe_sleep_us(long us) noexcept {
    timespec ts{0, us * 1000};
    ::nanosleep(&ts, nullptr);  // async-signal-safe (POSIX)
}

}  // namespace

// The mailbox gets a second writer here, the handler: post() returns at once once final_ is set, so at most one
// post() that passed that test before can still write, on another thread (within nanoseconds), or on this
// thread, interrupted by the signal (it never finishes). The handler waits up to 1 ms for an odd sequence to
// become even, then writes its packet with a sequence above any post()'s, and writes it again if a post()
// overwrote it meanwhile. Then the event thread submits it as any command; the handler waits for its transfer
// to complete (done_seq_), the stream to fail, or timeout_ms.
bool LibusbFtdiTransport::post_final_from_signal_handler(std::span<const std::uint8_t> packet,
                                                         int timeout_ms) noexcept {
    if (!stream_running_.load(std::memory_order_acquire) || packet.size() != kPacketBytes) return false;
    final_.store(true, std::memory_order_seq_cst);
    const std::int64_t until = signal_safe_now_ns() + static_cast<std::int64_t>(timeout_ms) * 1000000;
    const std::int64_t settle = signal_safe_now_ns() + 1000000;
    while ((mailbox_seq_.load(std::memory_order_acquire) & 1U) != 0U && signal_safe_now_ns() < settle) {
    }
    std::array<std::uint64_t, 2> words{};
    std::memcpy(words.data(), packet.data(), kPacketBytes);
    std::uint32_t mine = 0;
    bool written = false;
    while (signal_safe_now_ns() < until) {
        const std::uint32_t now = mailbox_seq_.load(std::memory_order_acquire);
        if (!written || now != mine) {  // not written yet, or overwritten by a post() that was under way
            const std::uint32_t odd = (now | 1U) + 2U;
            mailbox_seq_.store(odd, std::memory_order_relaxed);
            std::atomic_thread_fence(std::memory_order_release);
            mailbox_[0].store(words[0], std::memory_order_relaxed);
            mailbox_[1].store(words[1], std::memory_order_relaxed);
            mine = odd + 1U;
            written = true;
            mailbox_seq_.store(mine, std::memory_order_release);
            const std::uint64_t one = 1;
            [[maybe_unused]] const ssize_t w = ::write(wake_fd_, &one, sizeof one);  // async-signal-safe
        }
        if (done_seq_.load(std::memory_order_acquire) == mine) return true;
        if (stream_status_.load(std::memory_order_acquire) != 0) return false;
        signal_safe_sleep_us(100);
    }
    return false;
}

}  // namespace hapticd
