// SPDX-License-Identifier: Apache-2.0
// FtdiTransport over libusb-1.0 for the Novint Falcon's FT232R: synchronous transfers for the set-up
// (firmware upload, homing) and, once streaming, asynchronous ones for the 1 kHz loop.
//
// Streaming (libusb's asynchronous API, as libnifalcon's FalconCommLibUSB.cpp): one bulk-IN transfer is
// kept submitted (the FTDI chip completes it at least every latency period, 1 ms in normal mode, with
// status bytes and whatever payload arrived) and at most one bulk-OUT transfer is in flight. An event
// thread owns every libusb call; the real-time thread only touches atomics: the command goes through a
// seqlock mailbox (post(), then an eventfd wakes the event thread), the received payload comes back
// through a lock-free single-producer single-consumer byte ring (poll()). Transfers and buffers are
// allocated once in start_streaming(); nothing on the tick path allocates, locks or waits.
#pragma once

#include <array>
#include <atomic>
#include <cstdint>
#include <string>
#include <thread>

#include "devices/falcon_device.hpp"
#include "devices/transport.hpp"

struct libusb_context;
struct libusb_device_handle;
struct libusb_transfer;

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

    TransportStatus start_streaming() noexcept override;
    void stop_streaming() noexcept override;
    TransportStatus post(std::span<const std::uint8_t> data, bool& replaced) noexcept override;
    TransportResult poll(std::span<std::uint8_t> buffer) noexcept override;
    // The handler's thread only touches atomics, writes the eventfd and sleeps (nanosleep); the event thread
    // (another thread, running until the process ends) submits the packet with libusb as any command. Not
    // confirmed (false) when the signal stopped the event thread itself, or the stream had failed.
    bool post_final_from_signal_handler(std::span<const std::uint8_t> packet, int timeout_ms) noexcept override;

    // Streaming statistics (any thread).
    [[nodiscard]] std::uint64_t ring_overflows() const noexcept {
        return ring_overflows_.load(std::memory_order_relaxed);
    }

  private:
    LibusbFtdiTransport(libusb_context* context, libusb_device_handle* handle) noexcept
        : context_(context), handle_(handle) {}
    TransportStatus map(int libusb_error) noexcept;

    // Event thread side.
    void event_loop() noexcept;
    void submit_out_if_due() noexcept;
    void fail_stream(TransportStatus status) noexcept;
    static void on_in_done(libusb_transfer* transfer);
    static void on_out_done(libusb_transfer* transfer);
    bool ring_push(const std::uint8_t* data, std::size_t n) noexcept;

    libusb_context* context_ = nullptr;
    libusb_device_handle* handle_ = nullptr;
    std::array<std::uint8_t, 512> raw_{};      // one bulk-IN transfer (8 full-speed packets)
    std::array<std::uint8_t, 512> pending_{};  // payload not yet handed out
    std::size_t pending_size_ = 0;
    int last_error_code_ = 0;

    // Streaming state.
    static constexpr std::size_t kPacketBytes = 16;
    static constexpr std::size_t kRingSize = 4096;  // power of two; ~250 status packets
    bool streaming_ = false;
    std::thread event_thread_;
    int wake_fd_ = -1;
    libusb_transfer* in_transfer_ = nullptr;
    libusb_transfer* out_transfer_ = nullptr;
    std::array<std::uint8_t, 512> in_buffer_{};
    std::array<std::uint8_t, kPacketBytes> out_buffer_{};
    std::atomic<bool> stop_{false};
    std::atomic<bool> in_active_{false};
    std::atomic<bool> out_active_{false};
    std::atomic<int> stream_status_{0};  // TransportStatus of the first failure, 0 = Ok
    // Seqlock mailbox for the newest command: odd sequence = being written.
    std::atomic<std::uint32_t> mailbox_seq_{0};
    std::array<std::atomic<std::uint64_t>, 2> mailbox_{};
    std::uint32_t posted_seq_ = 0;             // real-time thread: last sequence it published
    std::atomic<std::uint32_t> sent_seq_{0};   // event thread: sequence of the last packet submitted
    std::uint32_t in_flight_seq_ = 0;          // event thread: the sequence of the OUT transfer in flight
    std::atomic<std::uint32_t> done_seq_{0};   // event thread: the sequence of the last OUT transfer completed
    std::atomic<bool> final_{false};           // a fatal-signal handler posted the last command: post() ignored
    std::atomic<bool> stream_running_{false};  // the event thread runs (for the signal handler)
    // Received payload ring (event thread produces, real-time thread consumes).
    std::array<std::uint8_t, kRingSize> ring_{};
    std::atomic<std::size_t> ring_head_{0};
    std::atomic<std::size_t> ring_tail_{0};
    std::atomic<std::uint64_t> ring_overflows_{0};
};

}  // namespace hapticd
