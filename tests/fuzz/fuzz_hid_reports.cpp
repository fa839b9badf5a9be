// libFuzzer target: HID PID report decoders (src/devices/hid_ffb_protocol.*). The first 8 bytes choose
// the layout (report ids, position offset, field width 1/2/4 and signedness, scale), the rest is the
// report. Invariants: no out-of-bounds read for any offset/width (the report buffer is exactly `size`
// bytes), a decoded position is finite, nothing is written on failure; the block-load decoder likewise.
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <vector>

#include "devices/hid_ffb_protocol.hpp"

namespace hid = hapticd::hid;

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    if (size < 8) return 0;
    hid::Layout layout;
    layout.input_report_id = data[0];
    layout.position_offset = data[1] % 72;
    static const std::size_t widths[] = {1, 2, 4, 3};  // 3 is not a documented width: must be refused
    layout.position_bytes = widths[data[2] % 4];
    layout.position_signed = (data[2] & 4) != 0;
    layout.position_scale = (data[3] & 1) ? 1e-6 : -2.5e3;
    layout.position_zero = static_cast<double>(static_cast<std::int8_t>(data[4])) * 1e3;
    layout.block_load_report_id = data[5];
    layout.force_scale = 1.0 + data[6];
    layout.force_max_counts = 1 + data[7] * 200;
    const std::vector<std::uint8_t> report(data + 8, data + size);  // exact-size heap copy for ASan
    double position = 12345.0;
    if (hid::decode_position(report.data(), report.size(), layout, position)) {
        if (!std::isfinite(position)) std::abort();
        if (layout.position_bytes == 3) std::abort();
    } else if (position != 12345.0) {
        std::abort();
    }
    std::uint8_t block = 77;
    if (!hid::decode_block_load(report.data(), report.size(), layout, block) && block != 77) std::abort();
    bool saturated = false;
    const double force = (static_cast<double>(static_cast<std::int8_t>(data[6])) - 0.5) * 1e3;
    const auto f = hid::encode_constant_force(force, data[5], layout, saturated);
    const int magnitude = static_cast<std::int16_t>(f[2] | (f[3] << 8));
    if (std::abs(magnitude) > layout.force_max_counts) std::abort();
    return 0;
}
