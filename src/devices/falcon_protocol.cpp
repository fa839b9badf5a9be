// SPDX-License-Identifier: Apache-2.0
#include "devices/falcon_protocol.hpp"

#include <algorithm>

namespace hapticd::falcon {

namespace {

void put_value(std::int16_t value, std::uint8_t* out) noexcept {
    const auto bits = static_cast<std::uint16_t>(value);
    for (int nibble = 0; nibble < 4; ++nibble) {
        out[nibble] = static_cast<std::uint8_t>(((bits >> (4 * nibble)) & 0xF) + kNibbleBase);
    }
}

bool is_nibble_byte(std::uint8_t b) noexcept { return b >= kNibbleBase && b <= kNibbleBase + 0xF; }

std::int16_t get_value(const std::uint8_t* in) noexcept {
    std::uint16_t bits = 0;
    for (int nibble = 0; nibble < 4; ++nibble) {
        bits = static_cast<std::uint16_t>(bits | ((in[nibble] - kNibbleBase) & 0xF) << (4 * nibble));
    }
    return static_cast<std::int16_t>(bits);
}

}  // namespace

Packet encode_command(const Command& command) noexcept {
    Packet p{};
    p[0] = kStart;
    for (std::size_t axis = 0; axis < 3; ++axis) {
        const auto t = std::clamp<std::int16_t>(command.torque[axis], -kMaxTorqueCommand, kMaxTorqueCommand);
        put_value(t, &p[1 + 4 * axis]);
    }
    const auto control = static_cast<std::uint8_t>((command.leds & (kLedGreen | kLedBlue | kLedRed)) |
                                                   (command.homing_mode ? kHomingModeBit : 0));
    p[13] = static_cast<std::uint8_t>(control + kNibbleBase);
    p[14] = kNibbleBase;
    p[15] = kEnd;
    return p;
}

Packet encode_status(const Status& status) noexcept {
    Packet p{};
    p[0] = kStart;
    for (std::size_t axis = 0; axis < 3; ++axis) put_value(status.encoder[axis], &p[1 + 4 * axis]);
    p[13] = static_cast<std::uint8_t>((((status.homed_mask & 7) << 4) | (status.buttons & 0xF)) + kNibbleBase);
    p[14] = kNibbleBase;
    p[15] = kEnd;
    return p;
}

bool decode_status(const std::uint8_t* packet, Status& status) noexcept {
    if (packet[0] != kStart || packet[15] != kEnd) return false;
    for (std::size_t i = 1; i <= 12; ++i) {
        if (!is_nibble_byte(packet[i])) return false;
    }
    // Bytes 13 and 14 are not range-checked, as in libnifalcon (FalconFirmwareNovintSDK.cpp
    // formatOutput(): only '<' at 0 and '>' at 15 are required; byte 13 is decoded as
    // ((b - 0x41) >> 4) & 7 for the homed flags and (b - 0x41) & 0x0f for the grip, byte 14 is ignored).
    // A frame character inside them is still a broken frame ('>' ends a packet early in libnifalcon).
    for (std::size_t i = 13; i <= 14; ++i) {
        if (packet[i] == kStart || packet[i] == kEnd) return false;
    }
    for (std::size_t axis = 0; axis < 3; ++axis) status.encoder[axis] = get_value(&packet[1 + 4 * axis]);
    const auto control = static_cast<std::uint8_t>(packet[13] - kNibbleBase);  // modulo 256, as libnifalcon
    status.homed_mask = static_cast<std::uint8_t>((control >> 4) & 7);
    status.buttons = static_cast<std::uint8_t>(control & 0xF);
    return true;
}

std::size_t FrameParser::feed(const std::uint8_t* data, std::size_t size, Status& latest) noexcept {
    std::size_t decoded = 0;
    for (std::size_t i = 0; i < size; ++i) {
        const std::uint8_t b = data[i];
        if (pending_size_ == 0) {
            if (b == kStart) {
                pending_[pending_size_++] = b;
            } else {
                ++counters_.garbage_bytes;
            }
            continue;
        }
        if (b == kStart) {  // a new frame starts inside this one: the current frame was cut short
            ++counters_.short_frames;
            pending_size_ = 0;
            pending_[pending_size_++] = b;
            continue;
        }
        pending_[pending_size_++] = b;
        if (pending_size_ < kPacketSize) continue;
        // No '<' inside (it would have restarted the frame), so a bad frame is dropped as a whole.
        Status s;
        if (decode_status(pending_.data(), s)) {
            latest = s;
            ++decoded;
            ++counters_.frames;
        } else {
            ++counters_.malformed;
        }
        pending_size_ = 0;
    }
    return decoded;
}

}  // namespace hapticd::falcon
