#include "devices/hid_device.hpp"

#include <hidapi.h>

#include <cmath>
#include <cstdio>

#include "devices/transport_libusb.hpp"  // kUdevHint

namespace hapticd {

namespace {

std::string hex4(unsigned v) {
    char buf[8];
    std::snprintf(buf, sizeof buf, "%04x", v & 0xFFFFU);
    return buf;
}

bool present(std::uint16_t vid, std::uint16_t pid) {
    hid_device_info* list = hid_enumerate(vid, pid);
    const bool any = list != nullptr;
    hid_free_enumeration(list);
    return any;
}

}  // namespace

HidFfbDevice::~HidFfbDevice() { close(); }

DeviceStatus HidFfbDevice::fail(DeviceStatus status, std::string message) {
    error_ = std::move(message);
    rt_error_ = "";
    return status;
}

bool HidFfbDevice::write_report(const std::uint8_t* data, std::size_t size) noexcept {
    return hid_write(handle_, data, size) == static_cast<int>(size);
}

DeviceStatus HidFfbDevice::open() {
    close();
    const hid::Layout& l = config_.layout;
    const std::string ids = "USB HID " + hex4(l.vendor_id) + ":" + hex4(l.product_id);
    if (hid_init() != 0) return fail(DeviceStatus::HardwareFault, "hidapi initialisation failed");
    handle_ = hid_open(l.vendor_id, l.product_id, nullptr);
    if (handle_ == nullptr) {
        if (!present(l.vendor_id, l.product_id)) {
            return fail(DeviceStatus::Disconnected, "no force-feedback device found (looked for " + ids +
                                                        "); is it plugged in? `hapticd --list-devices` shows what hapticd sees; "
                                                        "--simulate runs the profile on the simulated device");
        }
        return fail(DeviceStatus::HardwareFault, "cannot open " + ids + " (permission denied?): " + std::string(kUdevHint));
    }
    hid_set_nonblocking(handle_, 1);
    // Effect set-up: enable actuators, allocate a constant-force effect, configure it, start it at 0.
    const auto enable = hid::encode_device_control(hid::DeviceControl::EnableActuators, l);
    const auto create = hid::encode_create_effect(l);
    if (!write_report(enable.data(), enable.size()) ||
        hid_send_feature_report(handle_, create.data(), create.size()) != static_cast<int>(create.size())) {
        close();
        return fail(DeviceStatus::HardwareFault, ids + ": the device refused the force-feedback set-up reports "
                                                       "(is it a HID PID device? check the report ids in the profile)");
    }
    std::array<std::uint8_t, 8> load{};
    load[0] = l.block_load_report_id;
    const int got = hid_get_feature_report(handle_, load.data(), load.size());
    if (got < 3 || !hid::decode_block_load(load.data(), static_cast<std::size_t>(got), l, block_)) {
        close();
        return fail(DeviceStatus::HardwareFault, ids + ": the device did not allocate a constant-force effect (PID Block Load)");
    }
    const auto set_effect = hid::encode_set_effect(block_, l);
    bool saturated = false;
    const auto zero = hid::encode_constant_force(0.0, block_, l, saturated);
    const auto start = hid::encode_effect_operation(block_, hid::EffectOperation::Start, l);
    if (!write_report(set_effect.data(), set_effect.size()) || !write_report(zero.data(), zero.size()) ||
        !write_report(start.data(), start.size())) {
        close();
        return fail(DeviceStatus::HardwareFault, ids + ": starting the constant-force effect failed");
    }
    counters_ = DeviceCounters{};
    have_position_ = false;
    consecutive_stale_ = 0;
    return DeviceStatus::Ok;
}

DeviceStatus HidFfbDevice::home() {
    if (handle_ == nullptr) return fail(DeviceStatus::NotOpen, "home() before open()");
    // Wait (up to 1 s) for a first input report so that the first tick has a real position.
    for (int i = 0; i < 1000 && !have_position_; ++i) {
        const int n = hid_read_timeout(handle_, report_.data(), report_.size(), 1);
        if (n < 0) return fail(DeviceStatus::Disconnected, "the HID device stopped answering");
        double p = 0.0;
        if (n > 0 && hid::decode_position(report_.data(), static_cast<std::size_t>(n), config_.layout, p)) {
            position_ = p;
            have_position_ = true;
        }
    }
    if (!have_position_) {
        return fail(DeviceStatus::Timeout, "no input report with id " + std::to_string(config_.layout.input_report_id) +
                                               " within 1 s (check input_report_id in the profile)");
    }
    return DeviceStatus::Ok;
}

void HidFfbDevice::close() noexcept {
    if (handle_ == nullptr) return;
    bool saturated = false;
    const auto zero = hid::encode_constant_force(0.0, block_, config_.layout, saturated);
    const auto stop = hid::encode_effect_operation(block_, hid::EffectOperation::Stop, config_.layout);
    const auto free_block = hid::encode_block_free(block_, config_.layout);
    write_report(zero.data(), zero.size());
    write_report(stop.data(), stop.size());
    write_report(free_block.data(), free_block.size());
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
        if (report_[0] != config_.layout.input_report_id) continue;  // other reports (PID state, ...)
        double p = 0.0;
        if (hid::decode_position(report_.data(), static_cast<std::size_t>(n), config_.layout, p) && std::isfinite(p)) {
            position_ = p;
            fresh = true;
            ++counters_.packets_ok;
        } else {
            ++counters_.packets_malformed;  // right id, too short: dropped
        }
    }
    if (!fresh) {
        ++counters_.stale_reads;
        if (config_.max_stale_reads > 0 && ++consecutive_stale_ > config_.max_stale_reads) {
            rt_error_ = "no input report from the HID device for too many ticks";
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
    bool saturated = f > limit || f < -limit;
    f = f > limit ? limit : (f < -limit ? -limit : f);
    bool protocol_saturated = false;
    const auto report = hid::encode_constant_force(f, block_, config_.layout, protocol_saturated);
    if (saturated || protocol_saturated) ++counters_.saturated_commands;
    if (!write_report(report.data(), report.size())) {
        rt_error_ = "HID device disconnected (write failed)";
        return DeviceStatus::Disconnected;
    }
    return result;
}

}  // namespace hapticd
