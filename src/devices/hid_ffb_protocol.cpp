#include "devices/hid_ffb_protocol.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace hapticd::hid {

bool decode_position(const std::uint8_t* report, std::size_t size, const Layout& l, double& position) noexcept {
    if (size == 0 || report[0] != l.input_report_id) return false;
    if (l.position_bytes != 1 && l.position_bytes != 2 && l.position_bytes != 4) return false;
    if (l.position_offset < 1 || l.position_offset + l.position_bytes > size) return false;
    std::uint32_t raw = 0;
    for (std::size_t i = 0; i < l.position_bytes; ++i) raw |= static_cast<std::uint32_t>(report[l.position_offset + i]) << (8 * i);
    double count = 0.0;
    if (l.position_signed) {
        const unsigned bits = static_cast<unsigned>(8 * l.position_bytes);
        const std::int64_t sign = std::int64_t{1} << (bits - 1);
        std::int64_t v = static_cast<std::int64_t>(raw);
        if (v >= sign) v -= sign * 2;
        count = static_cast<double>(v);
    } else {
        count = static_cast<double>(raw);
    }
    position = (count - l.position_zero) * l.position_scale;
    return true;
}

std::array<std::uint8_t, 4> encode_constant_force(double force, std::uint8_t block, const Layout& l,
                                                  bool& saturated) noexcept {
    const double limit = std::min<double>(l.force_max_counts, std::numeric_limits<std::int16_t>::max());
    double counts = std::isfinite(force) ? std::round(force * l.force_scale) : 0.0;
    saturated = std::abs(counts) > limit;
    counts = std::clamp(counts, -limit, limit);
    const auto magnitude = static_cast<std::uint16_t>(static_cast<std::int16_t>(counts));
    return {l.constant_force_report_id, block, static_cast<std::uint8_t>(magnitude & 0xFF),
            static_cast<std::uint8_t>(magnitude >> 8)};
}

std::array<std::uint8_t, 16> encode_set_effect(std::uint8_t block, const Layout& l) noexcept {
    return {l.set_effect_report_id,
            block,
            kEffectTypeConstant,
            0xFF, 0xFF,  // duration: infinite
            0x00, 0x00,  // trigger repeat interval
            0x00, 0x00,  // sample period
            0x00, 0x00,  // start delay
            0xFF,        // gain
            0xFF,        // trigger button: none
            0x01,        // enable axis: X
            0x00,        // direction X
            0x00};       // direction Y
}

std::array<std::uint8_t, 4> encode_effect_operation(std::uint8_t block, EffectOperation op, const Layout& l) noexcept {
    return {l.effect_operation_report_id, block, static_cast<std::uint8_t>(op), 0x01 /* loop count */};
}

std::array<std::uint8_t, 2> encode_device_control(DeviceControl control, const Layout& l) noexcept {
    return {l.device_control_report_id, static_cast<std::uint8_t>(control)};
}

std::array<std::uint8_t, 2> encode_block_free(std::uint8_t block, const Layout& l) noexcept {
    return {l.block_free_report_id, block};
}

std::array<std::uint8_t, 4> encode_create_effect(const Layout& l) noexcept {
    return {l.create_effect_report_id, kEffectTypeConstant, 0x00, 0x00};
}

bool decode_block_load(const std::uint8_t* report, std::size_t size, const Layout& l, std::uint8_t& block) noexcept {
    if (size < 3 || report[0] != l.block_load_report_id) return false;
    if (report[1] == 0 || report[2] != kBlockLoadSuccess) return false;
    block = report[1];
    return true;
}

}  // namespace hapticd::hid
