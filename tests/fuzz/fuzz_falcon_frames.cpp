// SPDX-License-Identifier: Apache-2.0
// libFuzzer target: the Novint Falcon's packet decoders (src/devices/falcon_protocol.*): the frame
// parser fed the input in chunks whose sizes come from the input itself, and decode_status() on every
// 16-byte window. Invariants: no crash; the parser's counters account for bytes (frames * 16 <= bytes
// fed); a decoded status re-encodes to a packet that decodes to the same status.
#include <cstddef>
#include <cstdint>
#include <cstdlib>

#include "devices/falcon_protocol.hpp"

namespace falcon = hapticd::falcon;

static bool same(const falcon::Status& a, const falcon::Status& b) {
    return a.encoder == b.encoder && a.homed_mask == b.homed_mask && a.buttons == b.buttons;
}

static void check_round_trip(const falcon::Status& s) {
    const falcon::Packet p = falcon::encode_status(s);
    falcon::Status again;
    if (!falcon::decode_status(p.data(), again) || !same(s, again)) std::abort();
}

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    if (size == 0) return 0;
    const std::size_t chunk = 1 + data[0] % 40;
    falcon::FrameParser parser;
    falcon::Status latest;
    std::size_t decoded = 0;
    for (std::size_t at = 1; at < size; at += chunk) {
        const std::size_t n = at + chunk <= size ? chunk : size - at;
        const std::size_t got = parser.feed(data + at, n, latest);
        if (got > n / falcon::kPacketSize + 1) std::abort();
        decoded += got;
        if (got > 0) check_round_trip(latest);
    }
    const auto& c = parser.counters();
    if (c.frames != decoded || c.frames * falcon::kPacketSize > size) std::abort();
    if (c.garbage_bytes > size) std::abort();
    for (std::size_t at = 0; at + falcon::kPacketSize <= size; ++at) {
        falcon::Status s;
        if (falcon::decode_status(data + at, s)) check_round_trip(s);
    }
    // Commands: torques from the input are clamped to +-kMaxTorqueCommand and framed.
    if (size >= 8) {
        falcon::Command cmd;
        for (int i = 0; i < 3; ++i)
            cmd.torque[static_cast<std::size_t>(i)] =
                static_cast<std::int16_t>(data[1 + 2 * i] | (data[2 + 2 * i] << 8));
        cmd.leds = static_cast<std::uint8_t>(data[7] & 0x0E);
        cmd.homing_mode = (data[7] & 1) != 0;
        const falcon::Packet p = falcon::encode_command(cmd);
        if (p[0] != falcon::kStart || p[falcon::kPacketSize - 1] != falcon::kEnd) std::abort();
        for (std::size_t i = 1; i + 1 < falcon::kPacketSize; ++i)
            if (p[i] < falcon::kNibbleBase || p[i] > falcon::kNibbleBase + 15) std::abort();
    }
    return 0;
}
