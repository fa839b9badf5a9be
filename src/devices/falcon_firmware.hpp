// SPDX-License-Identifier: Apache-2.0
// Firmware upload to the Novint Falcon (pure logic over an FtdiTransport; no libusb here).
//
// The Falcon boots into a loader and needs its firmware on every power-up. Sequence (source: libnifalcon
// src/comm/FalconCommLibUSB.cpp setFirmwareMode()/setNormalMode() and src/core/FalconFirmware.cpp
// loadFirmware()):
//  1. Configure:  reset, purge RX/TX, latency 16 ms, 9600 baud, 8N1, no flow control, RTS low, DTR low,
//                 then DTR high (this puts the loader into its command mode).
//  2. Handshake:  send 0x0A 0x43 0x0D; the loader answers 0x0A 0x44 0x2C 0x0D (some hosts see an extra
//                 leading 0x00); repeated up to `handshake_tries` times (100, as libnifalcon's
//                 setFirmwareMode(): with the 16 ms latency timer each empty read is one status-only
//                 packet, so the loader gets about 1.6 s to wake up).
//  3. Sync:       DTR low, baud divisor 0x15 (~140 kbaud), send 'A' (0x41), expect 'A' back.
//  4. Upload:     the image in chunks of at most 62 bytes (one 64-byte full-speed packet minus the two
//                 FTDI status bytes); the loader echoes every byte, which must equal what was sent.
//                 Reads that return only the FTDI status bytes (every 16 ms while the loader is busy)
//                 are not errors: libnifalcon's loadFirmware() keeps reading until the chunk's echo is
//                 complete. Here a chunk fails only when no echo byte arrived for `echo_patience_ms`
//                 (or `max_consecutive_empty_reads` empty reads in a row); progress resets both.
//  5. Normal:     latency 1 ms, baud divisor 0x2 (1.5 Mbaud), purge RX/TX.
// A failed attempt (any step) restarts from step 1, up to `attempts` times (10, as libnifalcon's
// FalconCLIBase.cpp: loadFirmware(10, ...)); between attempts the device is closed and reopened when a
// `reopen` callback is given (the FTDI chip starts from a clean USB state). The final error names the
// stage, the attempt count and the cause.
#pragma once

#include <cstddef>
#include <cstdint>
#include <functional>
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
    int attempts = 10;
    int handshake_tries = 100;
    int timeout_ms = 1000;
    int echo_patience_ms = 2000;            // no echo byte for this long: the chunk fails
    int max_consecutive_empty_reads = 250;  // ~4 s of 16 ms status-only packets; bounds scripted tests
};

// Closes the transport and opens the device again; returns the new transport or null (then `error`
// says why). The previous transport must not be used after the call.
using ReopenTransport = std::function<FtdiTransport*(std::string& error)>;

struct FirmwareUploadResult {
    bool ok = false;
    FirmwareStage stage = FirmwareStage::Configure;  // where the last attempt ended
    int attempts_used = 0;
    std::size_t bytes_confirmed = 0;  // echoed correctly in the last attempt
    TransportStatus transport = TransportStatus::Ok;
    std::string message;
};

FirmwareUploadResult upload_firmware(FtdiTransport& transport, std::span<const std::uint8_t> image,
                                     const FirmwareUploadConfig& config = {}, const ReopenTransport& reopen = {});

// Reads a firmware image; on failure returns an empty vector and sets `error`.
std::vector<std::uint8_t> read_firmware_file(const std::string& path, std::string& error);

// Only the normal-mode settings (step 5), for a Falcon whose firmware is already running.
TransportStatus set_normal_mode(FtdiTransport& transport) noexcept;

}  // namespace hapticd::falcon
