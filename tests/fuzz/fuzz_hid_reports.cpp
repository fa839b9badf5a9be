// SPDX-License-Identifier: Apache-2.0
// libFuzzer target: the HID report descriptor parser and the PID layout built from it
// (src/devices/hid_report_descriptor.*, hid_ffb_protocol.*). The input is a 2-byte little-endian length,
// that many bytes of report descriptor, then an input report. Invariants: no out-of-bounds read or
// write for any descriptor; every encoded report fits its stated size (<= 64 bytes); a decoded position
// is finite; a magnitude stays inside the Magnitude field's logical range.
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <string>
#include <vector>

#include "devices/hid_ffb_protocol.hpp"

namespace hid = hapticd::hid;

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    if (size < 2) return 0;
    const std::size_t split = std::min<std::size_t>(size, 2 + (data[0] | (data[1] << 8)));
    const std::vector<std::uint8_t> descriptor(data + 2, data + split);  // exact-size heap copies for ASan
    const std::vector<std::uint8_t> report(data + split, data + size);
    hid::PidLayout pid;
    std::string error;
    if (!hid::build_pid_layout(descriptor.data(), descriptor.size(), pid, error)) {
        if (error.empty()) std::abort();
        return 0;
    }
    hid::Layout layout;
    double position = 0.0;
    if (!report.empty() && hid::decode_position(report.data(), report.size(), pid, layout, position) &&
        !std::isfinite(position)) {
        std::abort();
    }
    bool saturated = false;
    for (double f : {-1e9, -1.0, 0.0, 1.0, 1e9}) {
        const hid::Report r = hid::encode_constant_force(f, 1, pid, layout, saturated);
        if (r.size > hid::kMaxReportBytes) std::abort();
        // When the logical range fits the field's bits, the value read back lies inside the range.
        const hid::ReportField& m = *pid.cf_magnitude;
        if (m.bit_size < 2 || m.bit_size >= 32) continue;
        const bool is_signed = m.logical_min < 0;
        const std::int64_t lo_bits = is_signed ? -(std::int64_t{1} << (m.bit_size - 1)) : 0;
        const std::int64_t hi_bits =
            is_signed ? (std::int64_t{1} << (m.bit_size - 1)) - 1 : (std::int64_t{1} << m.bit_size) - 1;
        std::int64_t magnitude = 0;
        if (m.logical_min >= lo_bits && m.logical_max <= hi_bits &&
            hid::get_field(r.bytes.data(), r.size, m, true, magnitude) &&
            (magnitude < m.logical_min || magnitude > m.logical_max)) {
            std::abort();
        }
    }
    for (const hid::Report& r :
         {hid::encode_set_effect(1, pid), hid::encode_device_gain(1.0, pid), hid::encode_create_effect(pid),
          hid::encode_device_control(hid::DeviceControl::Reset, pid)}) {
        if (r.size > hid::kMaxReportBytes) std::abort();
    }
    return 0;
}
