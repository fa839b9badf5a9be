// Firmware upload to the Novint Falcon (pure logic over an FtdiTransport; no libusb here).
//
// The Falcon boots into a loader and needs its firmware on every power-up. Sequence (source: libnifalcon
// src/comm/FalconCommLibUSB.cpp setFirmwareMode()/setNormalMode() and src/core/FalconFirmware.cpp
// loadFirmware()):
//  1. Configure:  reset, purge RX/TX, latency 16 ms, 9600 baud, 8N1, no flow control, RTS low, DTR low,
//                 then DTR high (this puts the loader into its command mode).
//  2. Handshake:  send 0x0A 0x43 0x0D; the loader answers 0x0A 0x44 0x2C 0x0D (some hosts see an extra
//                 leading 0x00); repeated up to `handshake_tries` times.
//  3. Sync:       DTR low, baud divisor 0x15 (~140 kbaud), send 'A' (0x41), expect 'A' back.
//  4. Upload:     the image in chunks of at most 62 bytes (one 64-byte full-speed packet minus the two
//                 FTDI status bytes); the loader echoes every byte, which must equal what was sent.
//  5. Normal:     latency 1 ms, baud divisor 0x2 (1.5 Mbaud), purge RX/TX.
// A failed attempt (any step) restarts from step 1, up to `attempts` times; the final error names the
// stage, the attempt count and the cause.
#pragma once

#include <cstddef>
#include <cstdint>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "devices/transport.hpp"

namespace hapticd::falcon {

enum class FirmwareStage : std::uint8_t { Configure, Handshake, Sync, Upload, NormalMode, Done };

std::string_view to_string(FirmwareStage stage) noexcept;

struct FirmwareUploadConfig {
    std::size_t chunk_size = 62;
    int attempts = 3;
    int handshake_tries = 20;
    int timeout_ms = 1000;
};

struct FirmwareUploadResult {
    bool ok = false;
    FirmwareStage stage = FirmwareStage::Configure;  // where the last attempt ended
    int attempts_used = 0;
    std::size_t bytes_confirmed = 0;  // echoed correctly in the last attempt
    TransportStatus transport = TransportStatus::Ok;
    std::string message;
};

FirmwareUploadResult upload_firmware(FtdiTransport& transport, std::span<const std::uint8_t> image,
                                     const FirmwareUploadConfig& config = {});

// Reads a firmware image; on failure returns an empty vector and sets `error`.
std::vector<std::uint8_t> read_firmware_file(const std::string& path, std::string& error);

// Only the normal-mode settings (step 5), for a Falcon whose firmware is already running.
TransportStatus set_normal_mode(FtdiTransport& transport) noexcept;

}  // namespace hapticd::falcon
