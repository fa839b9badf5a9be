// SPDX-License-Identifier: Apache-2.0
#include "devices/hid_device.hpp"

#include <fcntl.h>
#include <hidapi.h>
#include <linux/hidraw.h>
#include <sys/ioctl.h>
#include <unistd.h>

#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <vector>

#include "devices/transport_libusb.hpp"  // kUdevHint

namespace hapticd {

namespace {

std::string hex4(unsigned v) {
    char buf[8];
    std::snprintf(buf, sizeof buf, "%04x", v & 0xFFFFU);
    return buf;
}

// The report descriptor of a hidraw node (HIDIOCGRDESCSIZE / HIDIOCGRDESC, linux/hidraw.h).
bool read_report_descriptor(const std::string& path, std::vector<std::uint8_t>& out, std::string& error) {
    const int fd = ::open(path.c_str(), O_RDWR | O_CLOEXEC);
    if (fd < 0) {
        error = "cannot open " + path + ": " + std::strerror(errno);
        return false;
    }
    int size = 0;
    hidraw_report_descriptor desc{};
    bool ok = ::ioctl(fd, HIDIOCGRDESCSIZE, &size) == 0 && size > 0 && size <= HID_MAX_DESCRIPTOR_SIZE;
    if (ok) {
        desc.size = static_cast<std::uint32_t>(size);
        ok = ::ioctl(fd, HIDIOCGRDESC, &desc) == 0;
    }
    if (!ok) error = "cannot read the report descriptor of " + path + ": " + std::strerror(errno);
    ::close(fd);
    if (ok) out.assign(desc.value, desc.value + desc.size);
    return ok;
}

}  // namespace

HidFfbDevice::HidFfbDevice(HidDeviceConfig config)
    : config_(std::move(config)), pid_(std::make_unique<hid::PidLayout>()) {}

HidFfbDevice::~HidFfbDevice() { close(); }

DeviceStatus HidFfbDevice::fail(DeviceStatus status, std::string message) {
    error_ = std::move(message);
    rt_error_ = "";
    return status;
}

bool HidFfbDevice::write_report(const hid::Report& r) noexcept {
    if (r.size == 0) return true;  // the device has no such report
    return hid_write(handle_, r.bytes.data(), r.size) == static_cast<int>(r.size);
}

DeviceStatus HidFfbDevice::open() {
    close();
    const hid::Layout& l = config_.layout;
    const std::string ids = "USB HID " + hex4(l.vendor_id) + ":" + hex4(l.product_id);
    if (hid_init() != 0) return fail(DeviceStatus::HardwareFault, "HidFfbDevice::open: hidapi initialisation failed");
    path_.clear();
    // All devices, filtered here (see device_list.cpp: hidapi 0.13's VID:PID filter can miss devices).
    hid_device_info* list = hid_enumerate(0, 0);
    int seen = 0;
    for (hid_device_info* d = list; d != nullptr; d = d->next) {
        if (d->vendor_id != l.vendor_id || d->product_id != l.product_id || d->path == nullptr) continue;
        if (seen++ == config_.device_index) path_ = d->path;
    }
    hid_free_enumeration(list);
    if (path_.empty()) {
        return fail(DeviceStatus::Disconnected,
                    "no force-feedback device found (looked for " + ids +
                        (config_.device_index > 0 ? ", device #" + std::to_string(config_.device_index) : "") +
                        "); is it plugged in? `hapticd --list-devices` shows what hapticd sees; "
                        "--simulate runs the profile on the simulated device");
    }
    std::vector<std::uint8_t> descriptor;
    std::string error;
    if (!read_report_descriptor(path_, descriptor, error)) {
        const bool denied = error.find("Permission denied") != std::string::npos;
        return fail(DeviceStatus::HardwareFault, ids + ": " + error + (denied ? "; " + std::string(kUdevHint) : ""));
    }
    pid_ = std::make_unique<hid::PidLayout>();
    if (!hid::build_pid_layout(descriptor.data(), descriptor.size(), *pid_, error)) {
        return fail(DeviceStatus::Unsupported, ids + " (" + path_ + "): " + error);
    }
    handle_ = hid_open_path(path_.c_str());
    if (handle_ == nullptr) {
        return fail(DeviceStatus::HardwareFault,
                    "cannot open " + ids + " (" + path_ + ", permission denied?): " + std::string(kUdevHint));
    }
    hid_set_nonblocking(handle_, 1);
    // Start-up as Linux's hid-pidff.c: Reset and Stop All Effects (effects or blocks left by another
    // program stop acting; pidff_reset()), Device Gain to the maximum (pidff_set_gain(0xFFFF)), Enable
    // Actuators; then one constant-force effect: Create New Effect -> Block Load -> Set Effect ->
    // magnitude 0 -> Start.
    const hid::PidLayout& p = *pid_;
    const bool reset_ok = write_report(hid::encode_device_control(hid::DeviceControl::Reset, p)) &&
                          write_report(hid::encode_device_control(hid::DeviceControl::StopAll, p)) &&
                          write_report(hid::encode_device_gain(1.0, p)) &&
                          write_report(hid::encode_device_control(hid::DeviceControl::EnableActuators, p));
    const hid::Report create = hid::encode_create_effect(p);
    if (!reset_ok ||
        hid_send_feature_report(handle_, create.bytes.data(), create.size) != static_cast<int>(create.size)) {
        close();
        return fail(DeviceStatus::HardwareFault,
                    ids +
                        ": the device refused the force-feedback set-up reports "
                        "(Reset / Stop All / Device Gain / Enable Actuators / Create New Effect)");
    }
    std::array<std::uint8_t, hid::kMaxReportBytes> load{};
    load[0] = p.block_load_id;
    const int got = hid_get_feature_report(handle_, load.data(), std::max<std::size_t>(p.block_load_bytes, 2));
    if (got < 2 || !hid::decode_block_load(load.data(), static_cast<std::size_t>(got), p, block_)) {
        close();
        return fail(DeviceStatus::HardwareFault,
                    ids + ": the device did not allocate a constant-force effect (PID Block Load)");
    }
    bool saturated = false;
    if (!write_report(hid::encode_set_effect(block_, p)) ||
        !write_report(hid::encode_constant_force(0.0, block_, p, config_.layout, saturated)) ||
        !write_report(hid::encode_effect_operation(block_, hid::EffectOperation::Start, p))) {
        close();
        return fail(DeviceStatus::HardwareFault, ids + ": starting the constant-force effect failed");
    }
    // The fatal-signal handler's descriptor and reports (zero_force_from_signal_handler).
    signal_reports_ = {hid::encode_constant_force(0.0, block_, p, config_.layout, saturated),
                       hid::encode_effect_operation(block_, hid::EffectOperation::Stop, p),
                       hid::encode_device_control(hid::DeviceControl::StopAll, p)};
    signal_fd_ = ::open(path_.c_str(), O_WRONLY | O_CLOEXEC);  // -1: the handler cannot zero (reported then)
    counters_ = DeviceCounters{};
    have_position_ = false;
    consecutive_stale_ = 0;
    return DeviceStatus::Ok;
}

DeviceStatus HidFfbDevice::home() {
    if (handle_ == nullptr) return fail(DeviceStatus::NotOpen, "HidFfbDevice::home: called before open()");
    // Wait (up to 1 s: the device sends at least every ~100 ms) for a first input report so that the
    // first tick has a real position.
    for (int i = 0; i < 1000 && !have_position_; ++i) {
        const int n = hid_read_timeout(handle_, report_.data(), report_.size(), 1);
        if (n < 0) return fail(DeviceStatus::Disconnected, "HidFfbDevice::home: the HID device stopped answering");
        double p = 0.0;
        if (n > 0 && hid::decode_position(report_.data(), static_cast<std::size_t>(n), *pid_, config_.layout, p)) {
            position_ = p;
            have_position_ = true;
        }
    }
    if (!have_position_) {
        return fail(DeviceStatus::Timeout, "HidFfbDevice::home: no input report with id " +
                                               std::to_string(pid_->input_id) +
                                               " (the one holding X, from the report descriptor) within 1 s");
    }
    return DeviceStatus::Ok;
}

bool HidFfbDevice::zero_force_from_signal_handler() noexcept {
    const int fd = signal_fd_;
    if (fd < 0) return false;
    bool all = true;
    for (const hid::Report& r : signal_reports_) {
        if (r.size == 0) continue;  // the device has no such report
        all = ::write(fd, r.bytes.data(), r.size) == static_cast<ssize_t>(r.size) && all;
    }
    return all;
}

void HidFfbDevice::close() noexcept {
    if (signal_fd_ >= 0) {
        ::close(signal_fd_);
        signal_fd_ = -1;
    }
    if (handle_ == nullptr) return;
    bool saturated = false;
    write_report(hid::encode_constant_force(0.0, block_, *pid_, config_.layout, saturated));
    write_report(hid::encode_effect_operation(block_, hid::EffectOperation::Stop, *pid_));
    write_report(hid::encode_block_free(block_, *pid_));
    write_report(hid::encode_device_control(hid::DeviceControl::StopAll, *pid_));
    hid_close(handle_);
    handle_ = nullptr;
}

DeviceStatus HidFfbDevice::read_position(AxisVector& position) noexcept {
    if (handle_ == nullptr) return DeviceStatus::NotOpen;
    bool fresh = false;
    for (int i = 0; i < 16; ++i) {  // drain queued reports, keep the newest position
        const int n = hid_read(handle_, report_.data(), report_.size());
        if (n < 0) {
            rt_error_ = "HID device disconnected (read failed)";
            return DeviceStatus::Disconnected;
        }
        if (n == 0) break;
        if (pid_->ids && report_[0] != pid_->input_id) continue;  // other reports (PID state, ...)
        double p = 0.0;
        if (hid::decode_position(report_.data(), static_cast<std::size_t>(n), *pid_, config_.layout, p) &&
            std::isfinite(p)) {
            position_ = p;
            fresh = true;
            ++counters_.packets_ok;
        } else {
            ++counters_.packets_short;  // right id, too short: dropped
        }
    }
    if (!fresh) {
        ++counters_.stale_reads;
        if (config_.max_stale_reads > 0 && ++consecutive_stale_ > config_.max_stale_reads) {
            rt_error_ = "no input report from the HID device for too many ticks (it sends at least every ~100 ms)";
            return DeviceStatus::Timeout;
        }
    } else {
        consecutive_stale_ = 0;
    }
    position = AxisVector{};
    position[0] = position_;
    return DeviceStatus::Ok;
}

DeviceStatus HidFfbDevice::write_force(const AxisVector& force) noexcept {
    if (handle_ == nullptr) return DeviceStatus::NotOpen;
    DeviceStatus result = DeviceStatus::Ok;
    double f = force[0];
    if (!std::isfinite(f)) {
        rt_error_ = "non-finite force command";
        result = DeviceStatus::InvalidArgument;
        f = 0.0;
    }
    const double limit = config_.capabilities.max_force;
    const bool saturated = f > limit || f < -limit;
    f = f > limit ? limit : (f < -limit ? -limit : f);
    bool protocol_saturated = false;
    const hid::Report report = hid::encode_constant_force(f, block_, *pid_, config_.layout, protocol_saturated);
    if (saturated || protocol_saturated) ++counters_.saturated_commands;
    if (!write_report(report)) {
        rt_error_ = "HID device disconnected (write failed)";
        return DeviceStatus::Disconnected;
    }
    return result;
}

}  // namespace hapticd
