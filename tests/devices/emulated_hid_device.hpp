// SPDX-License-Identifier: Apache-2.0
// An OpenFFBoard-like USB HID PID device emulated under umockdev (Debian's umockdev 0.17): sysfs entries
// (usb device, interface, hid device with its report descriptor and uevent, hidraw node) in a
// UMockdevTestbed, and an ioctl handler attached to /dev/hidraw0 that answers what the REAL hidapi
// (hidraw backend) and hapticd's driver do with the node: HIDIOCGRDESCSIZE / HIDIOCGRDESC, HIDIOCGRAWINFO,
// feature reports (HIDIOCSFEATURE / HIDIOCGFEATURE: Create New Effect, PID Block Load), output reports
// (write) and input reports (read). Firmware behaviour modelled on OpenFFBoard's FFBWheel send_report():
// an input report only when the position changed or after 100 ms without one; otherwise a read finds
// nothing (EAGAIN, as a non-blocking hidraw read).
//
// umockdev forwards read() to the handler but not poll(); hidapi polls before it reads, so the node's pty
// is made readable once (one byte written to its master side) and the handler then decides per read.
// The test process must run with libumockdev-preload.so.0 preloaded (see UmockdevPreload below).
#pragma once

#include <chrono>
#include <cstdint>
#include <mutex>
#include <string>
#include <vector>

struct _UMockdevTestbed;
struct _UMockdevIoctlBase;
struct _UMockdevIoctlClient;

namespace hapticd::test {

class EmulatedHidDevice {
  public:
    EmulatedHidDevice();  // builds the testbed; check ok() / error()
    ~EmulatedHidDevice();
    EmulatedHidDevice(const EmulatedHidDevice&) = delete;
    EmulatedHidDevice& operator=(const EmulatedHidDevice&) = delete;

    [[nodiscard]] bool ok() const { return ok_; }
    [[nodiscard]] const std::string& error() const { return error_; }

    // Device behaviour (any thread).
    void set_position(std::int16_t x);
    void set_silent(bool silent);        // no input report at all (a device that stopped answering)
    void set_unplugged(bool unplugged);  // every read/write/ioctl fails with ENODEV

    // Observations.
    [[nodiscard]] std::vector<std::vector<std::uint8_t>> output_reports() const;
    [[nodiscard]] std::vector<std::vector<std::uint8_t>> feature_reports() const;
    [[nodiscard]] int input_reports_sent() const;
    // umockdev's testbed directory (UMOCKDEV_DIR); the node is <root>/dev/hidraw0, a symlink to a pty.
    [[nodiscard]] std::string root_dir() const;
    static constexpr const char* kNode = "/dev/hidraw0";

    // Handler entry points (umockdev worker thread).
    bool on_ioctl(_UMockdevIoctlClient* client);
    bool on_read(_UMockdevIoctlClient* client);
    bool on_write(_UMockdevIoctlClient* client);

  private:
    std::vector<std::uint8_t> input_report_locked() const;

    _UMockdevTestbed* testbed_ = nullptr;
    _UMockdevIoctlBase* handler_ = nullptr;
    bool ok_ = false;
    std::string error_;
    std::vector<std::uint8_t> descriptor_;
    mutable std::mutex mutex_;
    std::int16_t x_ = 0;
    std::int16_t last_sent_x_ = 0;
    bool sent_any_ = false;
    bool silent_ = false;
    bool unplugged_ = false;
    int inputs_sent_ = 0;
    std::chrono::steady_clock::time_point last_sent_{};
    std::vector<std::vector<std::uint8_t>> outputs_;
    std::vector<std::vector<std::uint8_t>> features_;
};

}  // namespace hapticd::test
