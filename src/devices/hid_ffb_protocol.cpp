// SPDX-License-Identifier: Apache-2.0
#include "devices/hid_ffb_protocol.hpp"

#include <algorithm>
#include <cmath>

namespace hapticd::hid {

namespace {

using namespace usage_id;

const ReportField* field_in(const ReportDescriptor& d, ReportType type, std::uint8_t id, std::uint32_t wanted) {
    for (const ReportField& f : d.fields) {
        if (f.type == type && f.report_id == id && !f.array && f.usage == wanted) return &f;
    }
    return nullptr;
}

const ReportField* array_in(const ReportDescriptor& d, ReportType type, std::uint8_t id, std::uint32_t selector) {
    for (const ReportField& f : d.fields) {
        if (f.type != type || f.report_id != id || !f.array) continue;
        if (std::find(f.usages.begin(), f.usages.end(), selector) != f.usages.end()) return &f;
    }
    return nullptr;
}

const ReportField* first_in_collection(const ReportDescriptor& d, ReportType type, std::uint8_t id,
                                       std::uint32_t collection) {
    for (const ReportField& f : d.fields) {
        if (f.type == type && f.report_id == id && !f.array && f.collection == collection) return &f;
    }
    return nullptr;
}

// Output and feature reports go through hidapi with a leading report id byte (0 without ids).
std::size_t written_size(const ReportDescriptor& d, ReportType type, std::uint8_t id) {
    const std::size_t n = d.report_bytes(type, id);
    if (n == 0) return 0;
    return 1 + n - (d.uses_report_ids ? 1 : 0);
}

Report start(std::uint8_t id, std::size_t size) noexcept {
    Report r;
    r.size = std::min(size, kMaxReportBytes);
    r.bytes[0] = id;
    return r;
}

void put(Report& r, const ReportField* f, std::int64_t v, std::uint32_t element = 0) noexcept {
    if (f != nullptr) put_field(r.bytes.data(), r.size, *f, true, v, element);
}

// Value that selects `selector` in an array field: logical minimum + index (HID 1.11 Sect. 6.2.2.5).
std::int64_t select(const ReportField* f, std::uint32_t selector) noexcept {
    if (f == nullptr) return 0;
    const auto it = std::find(f->usages.begin(), f->usages.end(), selector);
    return f->logical_min + (it - f->usages.begin());
}

std::string missing(const char* what) {
    return std::string("build_pid_layout: the report descriptor has no ") + what +
           " (not a HID PID constant-force device hapticd can drive)";
}

}  // namespace

std::int64_t direction_90_degrees(const ReportField& direction) noexcept {
    const double span = static_cast<double>(direction.logical_max) - static_cast<double>(direction.logical_min) + 1.0;
    return direction.logical_min + static_cast<std::int64_t>(std::lround(span / 4.0));
}

bool build_pid_layout(const std::uint8_t* data, std::size_t size, PidLayout& p, std::string& error) {
    if (!parse_report_descriptor(data, size, p.descriptor, error)) return false;
    const ReportDescriptor& d = p.descriptor;
    p.ids = d.uses_report_ids;
    // Position: Generic Desktop X of an input report.
    p.position = d.find(ReportType::Input, 0, kX);
    if (p.position == nullptr) {
        error = "build_pid_layout: no Generic Desktop X axis in any input report (nothing to read the position from)";
        return false;
    }
    if (p.position->bit_size > 32 || p.position->bit_size < 2) {
        error =
            "build_pid_layout: the X axis is " + std::to_string(p.position->bit_size) + " bits wide (accepted: 2..32)";
        return false;
    }
    p.input_id = p.position->report_id;
    p.input_bytes = d.report_bytes(ReportType::Input, p.input_id);
    // Set Effect (output).
    const ReportField* se = d.find(ReportType::Output, kSetEffectReport, kEffectBlockIndex);
    if (se == nullptr) {
        error = missing("Set Effect report");
        return false;
    }
    p.set_effect_id = se->report_id;
    p.set_effect_bytes = written_size(d, ReportType::Output, p.set_effect_id);
    p.se_block = se;
    p.se_type = array_in(d, ReportType::Output, p.set_effect_id, kEtConstantForce);
    if (p.se_type == nullptr) {
        error = missing("ET Constant Force in the Set Effect report's effect types");
        return false;
    }
    p.se_duration = field_in(d, ReportType::Output, p.set_effect_id, kDuration);
    p.se_trigger_repeat = field_in(d, ReportType::Output, p.set_effect_id, kTriggerRepeatInterval);
    p.se_sample_period = field_in(d, ReportType::Output, p.set_effect_id, kSamplePeriod);
    p.se_start_delay = field_in(d, ReportType::Output, p.set_effect_id, kStartDelay);
    p.se_gain = field_in(d, ReportType::Output, p.set_effect_id, kGain);
    p.se_trigger_button = field_in(d, ReportType::Output, p.set_effect_id, kTriggerButton);
    for (const ReportField& f : d.fields) {
        if (f.type == ReportType::Output && f.report_id == p.set_effect_id && !f.array && f.usage == kX &&
            f.collection == kAxesEnable) {
            p.se_axis_x = &f;
            break;
        }
    }
    p.se_direction_enable = field_in(d, ReportType::Output, p.set_effect_id, kDirectionEnable);
    p.se_direction = first_in_collection(d, ReportType::Output, p.set_effect_id, kDirection);
    if (p.se_direction_enable == nullptr || p.se_direction == nullptr) {
        error = missing(
            "Direction Enable / Direction field in the Set Effect report (hapticd always sets a direction, "
            "as Linux's hid-pidff does)");
        return false;
    }
    // Set Constant Force.
    p.cf_magnitude = d.find(ReportType::Output, kSetConstantForceReport, kMagnitude);
    if (p.cf_magnitude == nullptr) {
        error = missing("Set Constant Force report");
        return false;
    }
    // A constant force pushes both ways: its Magnitude's logical range must hold negative and positive
    // values (OpenFFBoard: -32767..32767; hid-pidff.c scales a signed magnitude into it). An empty or one-sided
    // range (a broken descriptor; found by the fuzz target) would make the clamp of encode_constant_force
    // meaningless.
    if (!(p.cf_magnitude->logical_min < 0 && p.cf_magnitude->logical_max > 0)) {
        error = "build_pid_layout: the Set Constant Force report's Magnitude has logical range [" +
                std::to_string(p.cf_magnitude->logical_min) + ", " + std::to_string(p.cf_magnitude->logical_max) +
                "]; accepted: logical minimum < 0 < logical maximum";
        return false;
    }
    p.constant_id = p.cf_magnitude->report_id;
    p.constant_bytes = written_size(d, ReportType::Output, p.constant_id);
    p.cf_block = field_in(d, ReportType::Output, p.constant_id, kEffectBlockIndex);
    // Effect Operation.
    for (const ReportField& f : d.fields) {
        if (f.type == ReportType::Output && f.array &&
            std::find(f.usages.begin(), f.usages.end(), kOpEffectStart) != f.usages.end()) {
            p.op_operation = &f;
            break;
        }
    }
    if (p.op_operation == nullptr) {
        error = missing("Effect Operation report");
        return false;
    }
    p.operation_id = p.op_operation->report_id;
    p.operation_bytes = written_size(d, ReportType::Output, p.operation_id);
    p.op_block = field_in(d, ReportType::Output, p.operation_id, kEffectBlockIndex);
    p.op_loop_count = field_in(d, ReportType::Output, p.operation_id, kLoopCount);
    // Device Control (Reset, Stop All, Enable Actuators).
    for (const ReportField& f : d.fields) {
        if (f.type == ReportType::Output && f.array &&
            std::find(f.usages.begin(), f.usages.end(), kDcReset) != f.usages.end()) {
            p.control = &f;
            break;
        }
    }
    if (p.control == nullptr) {
        error = missing("PID Device Control report (Reset / Stop All Effects)");
        return false;
    }
    p.control_id = p.control->report_id;
    p.control_bytes = written_size(d, ReportType::Output, p.control_id);
    // Device Gain (optional in PID 1.0; set when present).
    p.device_gain = d.find(ReportType::Output, 0, kDeviceGain);
    if (p.device_gain != nullptr) {
        p.gain_id = p.device_gain->report_id;
        p.gain_bytes = written_size(d, ReportType::Output, p.gain_id);
    }
    // Block Free.
    p.free_block = d.find(ReportType::Output, kBlockFreeReport, kEffectBlockIndex);
    if (p.free_block != nullptr) {
        p.free_id = p.free_block->report_id;
        p.free_bytes = written_size(d, ReportType::Output, p.free_id);
    }
    // Create New Effect / Block Load (feature).
    for (const ReportField& f : d.fields) {
        if (f.type == ReportType::Feature && f.array &&
            std::find(f.usages.begin(), f.usages.end(), kEtConstantForce) != f.usages.end()) {
            p.cr_type = &f;
            break;
        }
    }
    p.bl_block = d.find(ReportType::Feature, kBlockLoadReport, kEffectBlockIndex);
    if (p.cr_type == nullptr || p.bl_block == nullptr) {
        error = missing("Create New Effect / PID Block Load feature report");
        return false;
    }
    p.create_id = p.cr_type->report_id;
    p.create_bytes = written_size(d, ReportType::Feature, p.create_id);
    p.cr_byte_count = field_in(d, ReportType::Feature, p.create_id, kByteCount);
    p.block_load_id = p.bl_block->report_id;
    p.block_load_bytes = written_size(d, ReportType::Feature, p.block_load_id);
    p.bl_status = array_in(d, ReportType::Feature, p.block_load_id, kBlockLoadSuccess);
    if (p.bl_status == nullptr) {
        error = missing("Block Load Status in the PID Block Load report");
        return false;
    }
    for (std::size_t n : {p.set_effect_bytes, p.constant_bytes, p.operation_bytes, p.control_bytes, p.gain_bytes,
                          p.free_bytes, p.create_bytes, p.block_load_bytes}) {
        if (n > kMaxReportBytes) {
            error = "build_pid_layout: a PID report is " + std::to_string(n) + " bytes long (accepted: up to 64)";
            return false;
        }
    }
    return true;
}

bool decode_position(const std::uint8_t* report, std::size_t size, const PidLayout& pid, const Layout& l,
                     double& position) noexcept {
    if (pid.position == nullptr || size == 0) return false;
    if (pid.ids && report[0] != pid.input_id) return false;
    std::int64_t count = 0;
    if (!get_field(report, size, *pid.position, pid.ids, count)) return false;
    position = (static_cast<double>(count) - l.position_zero) * l.position_scale;
    return true;
}

Report encode_constant_force(double force, std::uint8_t block, const PidLayout& pid, const Layout& l,
                             bool& saturated) noexcept {
    Report r = start(pid.constant_id, pid.constant_bytes);
    const double lo = pid.cf_magnitude != nullptr ? pid.cf_magnitude->logical_min : 0.0;
    const double hi = pid.cf_magnitude != nullptr ? pid.cf_magnitude->logical_max : 0.0;
    double counts = std::isfinite(force) ? std::round(force * l.force_scale) : 0.0;
    saturated = counts < lo || counts > hi;
    counts = std::clamp(counts, lo, hi);
    put(r, pid.cf_block, block);
    put(r, pid.cf_magnitude, static_cast<std::int64_t>(counts));
    return r;
}

Report encode_set_effect(std::uint8_t block, const PidLayout& pid) noexcept {
    Report r = start(pid.set_effect_id, pid.set_effect_bytes);
    put(r, pid.se_block, block);
    put(r, pid.se_type, select(pid.se_type, kEtConstantForce));
    put(r, pid.se_duration, 0xFFFF);  // infinite (hid-pidff.c: PID_INFINITE = U16_MAX)
    put(r, pid.se_trigger_repeat, 0);
    put(r, pid.se_sample_period, 0);
    put(r, pid.se_start_delay, 0);
    if (pid.se_gain != nullptr) put(r, pid.se_gain, pid.se_gain->logical_max);
    put(r, pid.se_trigger_button, 0);
    put(r, pid.se_axis_x, 1);
    put(r, pid.se_direction_enable, 1);
    if (pid.se_direction != nullptr) put(r, pid.se_direction, direction_90_degrees(*pid.se_direction));
    return r;
}

Report encode_effect_operation(std::uint8_t block, EffectOperation op, const PidLayout& pid) noexcept {
    Report r = start(pid.operation_id, pid.operation_bytes);
    const std::uint32_t which = op == EffectOperation::Start       ? kOpEffectStart
                                : op == EffectOperation::StartSolo ? kOpEffectStartSolo
                                                                   : kOpEffectStop;
    put(r, pid.op_block, block);
    put(r, pid.op_operation, select(pid.op_operation, which));
    put(r, pid.op_loop_count, 1);
    return r;
}

Report encode_device_control(DeviceControl control, const PidLayout& pid) noexcept {
    Report r = start(pid.control_id, pid.control_bytes);
    const std::uint32_t which = control == DeviceControl::EnableActuators    ? kDcEnableActuators
                                : control == DeviceControl::DisableActuators ? kDcDisableActuators
                                : control == DeviceControl::StopAll          ? kDcStopAllEffects
                                                                             : kDcReset;
    put(r, pid.control, select(pid.control, which));
    return r;
}

Report encode_device_gain(double fraction, const PidLayout& pid) noexcept {
    if (pid.device_gain == nullptr) return {};
    Report r = start(pid.gain_id, pid.gain_bytes);
    const double f = std::isfinite(fraction) ? std::clamp(fraction, 0.0, 1.0) : 0.0;
    const ReportField& g = *pid.device_gain;
    put(r, &g,
        g.logical_min +
            static_cast<std::int64_t>(std::lround(f * (static_cast<double>(g.logical_max) - g.logical_min))));
    return r;
}

Report encode_block_free(std::uint8_t block, const PidLayout& pid) noexcept {
    if (pid.free_block == nullptr) return {};
    Report r = start(pid.free_id, pid.free_bytes);
    put(r, pid.free_block, block);
    return r;
}

Report encode_create_effect(const PidLayout& pid) noexcept {
    Report r = start(pid.create_id, pid.create_bytes);
    put(r, pid.cr_type, select(pid.cr_type, kEtConstantForce));
    put(r, pid.cr_byte_count, 0);
    return r;
}

bool decode_block_load(const std::uint8_t* report, std::size_t size, const PidLayout& pid,
                       std::uint8_t& block) noexcept {
    if (pid.bl_block == nullptr || pid.bl_status == nullptr || size == 0 || report[0] != pid.block_load_id)
        return false;
    std::int64_t index = 0;
    std::int64_t status = 0;
    if (!get_field(report, size, *pid.bl_block, true, index) ||
        !get_field(report, size, *pid.bl_status, true, status)) {
        return false;
    }
    if (status != select(pid.bl_status, kBlockLoadSuccess) || index <= 0 || index > 255) return false;
    block = static_cast<std::uint8_t>(index);
    return true;
}

}  // namespace hapticd::hid
