// SPDX-License-Identifier: Apache-2.0
#include "devices/ftdi_protocol.hpp"

#include <cmath>

namespace hapticd::ftdi {

std::uint16_t baud_value(std::uint32_t baud) noexcept {
    if (baud == 0) return 0;
    if (baud >= 3000000) return 0;  // divisor 0: 3 Mbaud
    if (baud >= 2000000) return 1;  // divisor 1: 2 Mbaud
    const double divisor = 3e6 / static_cast<double>(baud);
    const auto eighths = static_cast<std::uint32_t>(std::lround(divisor * 8.0));
    const std::uint32_t integer = eighths / 8;
    if (integer > 0x3FFF) return 0;
    // AN232B-05 sub-integer codes: 0 -> 0, 1/8 -> 3, 2/8 -> 2, 3/8 -> 4, 4/8 -> 1, 5/8 -> 5, 6/8 -> 6, 7/8 -> 7.
    static constexpr std::uint32_t kFractionCode[8] = {0, 3, 2, 4, 1, 5, 6, 7};
    const std::uint32_t code = kFractionCode[eighths % 8];
    // Bits 14..15 of wValue hold code bits 0..1; bit 2 goes to wIndex (not returned: see the header).
    return static_cast<std::uint16_t>(integer | ((code & 3U) << 14));
}

std::size_t strip_ftdi_status(const std::uint8_t* raw, std::size_t raw_size, std::uint8_t* out) noexcept {
    std::size_t written = 0;
    for (std::size_t start = 0; start < raw_size; start += kMaxPacket) {
        const std::size_t end = start + kMaxPacket < raw_size ? start + kMaxPacket : raw_size;
        for (std::size_t i = start + kStatusBytes; i < end; ++i) out[written++] = raw[i];
    }
    return written;
}

}  // namespace hapticd::ftdi
