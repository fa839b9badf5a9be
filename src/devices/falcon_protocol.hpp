// SPDX-License-Identifier: Apache-2.0
// The Novint Falcon's framed 16-byte packet protocol (Novint SDK firmware), both directions.
//
// Format (source: libnifalcon include/falcon/firmware/FalconFirmwareNovintSDK.h, "Input Layout" and
// "Output Layout", and src/firmware/FalconFirmwareNovintSDK.cpp formatInput()/formatOutput()):
//   byte 0      '<' (0x3C) start of frame          byte 15  '>' (0x3E) end of frame
//   bytes 1..12 three signed 16-bit values, 4 bytes each, least significant nibble first; every
//               byte carries one nibble plus 0x41 ('A'), so nibble bytes are 'A'..'P'
//   byte 13     host -> Falcon: LED bits | homing-mode bit, plus 0x41
//               Falcon -> host: buttons in bits 0..3, per-axis "homed" flags in bits 4..6, plus 0x41
//   byte 14     unknown; the host sends 'A' (0 + 0x41); replies may carry other values (not checked)
// Host -> Falcon values are motor torques; Falcon -> host values are encoder counts.
// Bit assignments of byte 13 to the Falcon follow libnifalcon's code (FalconFirmware.h enums:
// homing 0x01, green 0x02, blue 0x04, red 0x08); the comment block of FalconFirmwareNovintSDK.h lists
// other values (homing 0x10) -- the code is what libnifalcon's users run, so it is used here.
// Torque range: libnifalcon FalconKinematic.h says "Force values are capped at 4096".
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>

namespace hapticd::falcon {

inline constexpr std::size_t kPacketSize = 16;
inline constexpr std::uint8_t kStart = 0x3C;       // '<'
inline constexpr std::uint8_t kEnd = 0x3E;         // '>'
inline constexpr std::uint8_t kNibbleBase = 0x41;  // 'A'
inline constexpr std::int16_t kMaxTorqueCommand = 4096;

// LED and homing-mode bits of byte 13 to the Falcon.
inline constexpr std::uint8_t kHomingModeBit = 0x01;
inline constexpr std::uint8_t kLedGreen = 0x02;
inline constexpr std::uint8_t kLedBlue = 0x04;
inline constexpr std::uint8_t kLedRed = 0x08;
// All three "homed" flags (byte 13 from the Falcon, shifted down by 4).
inline constexpr std::uint8_t kAllAxesHomed = 0x07;

using Packet = std::array<std::uint8_t, kPacketSize>;

struct Command {
    std::array<std::int16_t, 3> torque{};  // clamped to +-kMaxTorqueCommand by encode_command()
    std::uint8_t leds = 0;                 // kLed* bits
    bool homing_mode = false;
};

struct Status {
    std::array<std::int16_t, 3> encoder{};
    std::uint8_t homed_mask = 0;  // bit i: axis i homed
    std::uint8_t buttons = 0;
};

Packet encode_command(const Command& command) noexcept;

// Encodes a status packet (what the Falcon sends); for tests and the scripted device.
Packet encode_status(const Status& status) noexcept;

// Checks the framing ('<' ... '>') and the nibble bytes 1..12 of a status packet and decodes it; bytes
// 13/14 are accepted whatever they hold (as libnifalcon does) except a frame character. false: malformed.
bool decode_status(const std::uint8_t* packet, Status& status) noexcept;

struct FrameCounters {
    std::uint64_t frames = 0;         // valid frames decoded
    std::uint64_t malformed = 0;      // 16 bytes between '<' and the expected '>' that failed the checks
    std::uint64_t short_frames = 0;   // a new '<' arrived before the frame was complete
    std::uint64_t garbage_bytes = 0;  // bytes outside any frame (skipped while looking for '<')
};

// Reassembles frames from an arbitrary byte stream: resynchronises on the next '<' after garbage,
// counts and drops short and malformed frames. Fixed storage: no allocation, noexcept.
class FrameParser {
  public:
    // Feeds bytes; returns how many valid frames were decoded; `latest` receives the newest one.
    std::size_t feed(const std::uint8_t* data, std::size_t size, Status& latest) noexcept;
    void reset() noexcept { pending_size_ = 0; }
    [[nodiscard]] const FrameCounters& counters() const noexcept { return counters_; }

  private:
    Packet pending_{};
    std::size_t pending_size_ = 0;
    FrameCounters counters_;
};

}  // namespace hapticd::falcon
