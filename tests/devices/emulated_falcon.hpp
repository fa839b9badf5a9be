// SPDX-License-Identifier: Apache-2.0
// A Novint Falcon emulated under umockdev for the REAL libusb-1.0 (usbfs backend): the sysfs entry of an
// FT232R with the Falcon's VID:PID 0403:cb48 (device and configuration descriptors, bus 001 device 002)
// and an ioctl handler on /dev/bus/usb/001/002 that answers usbfs URBs the way the FTDI chip does
// (pattern of libusb's own tests/umockdev.c): control requests go to the FTDI state (latency timer,
// baud rate, modem lines), bulk OUT bytes go to the scripted Falcon (fake_falcon.hpp: loader,
// firmware, one status packet per command), bulk IN URBs complete with the two FTDI status bytes plus
// whatever the Falcon has sent, or with the status bytes alone when the latency timer (16 ms in the
// loader mode, 1 ms in normal mode) runs out with nothing to send. Faults: unplug (every URB -> ENODEV),
// a stalled IN endpoint (-EPIPE), garbage injected into the stream, silence (no status packets).
//
// A loader that takes its time (set_slow_loader()): after DTR goes high (the end of the loader set-up,
// FalconCommLibUSB.cpp setFirmwareMode()) the loader ignores what it is sent for `wake_up`, and it holds
// the echo of every firmware chunk for `burn_per_chunk` (the chunk being written to the microcontroller's
// memory) and, in lockstep with the host, until at least one bulk IN came back status-only during the hold: a
// host thread preempted past the hold still meets the packets the test is about. Meanwhile the FTDI chip answers each
// bulk IN with the 2 status bytes alone when its latency timer (16 ms in the loader mode) runs out, which is what the
// driver's handshake tries and per-chunk empty reads see. The emulation counts those status-only packets and times the
// load.
#pragma once

#include <chrono>
#include <cstdint>
#include <deque>
#include <mutex>
#include <span>
#include <string>
#include <vector>

#include "fake_falcon.hpp"

struct _UMockdevTestbed;
struct _UMockdevIoctlBase;
struct _UMockdevIoctlClient;
struct _UMockdevIoctlData;

namespace hapticd::test {

class EmulatedFalcon {
  public:
    EmulatedFalcon();
    ~EmulatedFalcon();
    EmulatedFalcon(const EmulatedFalcon&) = delete;
    EmulatedFalcon& operator=(const EmulatedFalcon&) = delete;

    [[nodiscard]] bool ok() const { return ok_; }
    [[nodiscard]] const std::string& error() const { return error_; }

    // The scripted Falcon behind the FTDI emulation; lock() around any access after the start.
    std::unique_lock<std::mutex> lock() { return std::unique_lock<std::mutex>(mutex_); }
    FakeFalcon& falcon() { return falcon_; }
    // Unplug: the URBs in flight complete with -ESHUTDOWN and new ones are refused with ENODEV, as usbfs
    // does after a disconnect. (usbfs also reports POLLERR on the node; umockdev's pty cannot.)
    void unplug();
    void set_stalled(bool v) {
        auto l = lock();
        stalled_ = v;
    }
    void set_silent(bool v) {
        auto l = lock();
        silent_ = v;
    }
    [[nodiscard]] std::uint64_t in_urbs_completed() {
        auto l = lock();
        return in_completed_;
    }
    // umockdev's testbed directory (UMOCKDEV_DIR); the usbfs node is <root>/dev/bus/usb/001/002.
    [[nodiscard]] std::string root_dir() const;
    static constexpr const char* kNode = "/dev/bus/usb/001/002";

    struct SlowLoader {
        std::chrono::milliseconds wake_up{0};         // from DTR high until the loader listens
        std::chrono::milliseconds burn_per_chunk{0};  // each firmware chunk's echo is held at least this long
    };
    void set_slow_loader(SlowLoader s) {
        auto l = lock();
        slow_ = s;
    }
    struct LoaderLog {
        int ignored_while_waking = 0;       // writes the loader did not hear (handshake tries lost)
        int status_only_while_waking = 0;   // status-only IN packets between DTR high and the handshake answer
        int status_only_while_burning = 0;  // status-only IN packets while a chunk's echo was held
        int chunks_held = 0;
        std::chrono::steady_clock::time_point first_dtr_high{};  // the first load attempt's start
        std::chrono::steady_clock::time_point handshake_answered{};
        std::chrono::steady_clock::time_point last_echo_released{};
    };
    [[nodiscard]] LoaderLog loader_log() {
        auto l = lock();
        return log_;
    }

    bool on_ioctl(_UMockdevIoctlClient* client);

  private:
    struct Flying {
        _UMockdevIoctlData* urb = nullptr;     // referenced
        _UMockdevIoctlData* buffer = nullptr;  // the URB's data buffer, resolved (synced back at reap)
        unsigned long client_addr = 0;
        bool in = false;
        bool done = false;
        std::chrono::steady_clock::time_point submitted;
    };
    bool complete_in(Flying& f, std::chrono::steady_clock::time_point now);
    void loader_write(std::span<const std::uint8_t> data, std::chrono::steady_clock::time_point now);
    struct HeldEcho {
        std::chrono::steady_clock::time_point release;
        std::vector<std::uint8_t> bytes;
        bool status_only_sent = false;  // a bulk IN came back with the status bytes alone during the hold
    };

    _UMockdevTestbed* testbed_ = nullptr;
    _UMockdevIoctlBase* handler_ = nullptr;
    bool ok_ = false;
    std::string error_;
    std::mutex mutex_;
    FakeFalcon falcon_;
    OpenedTransport model_;  // the ScriptedTransport the FakeFalcon answers into
    std::deque<Flying> flying_;
    std::deque<Flying> discarded_;
    bool unplugged_ = false;
    bool stalled_ = false;
    bool silent_ = false;
    std::uint64_t in_completed_ = 0;
    SlowLoader slow_;
    LoaderLog log_;
    std::chrono::steady_clock::time_point dtr_high_{};  // of the current load attempt
    bool loader_answered_ = false;                      // in the current attempt
    std::deque<HeldEcho> held_;
};

}  // namespace hapticd::test
