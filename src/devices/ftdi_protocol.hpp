// SPDX-License-Identifier: Apache-2.0
// FTDI FT232R "SIO" vendor requests used to drive the Novint Falcon (all bmRequestType 0x40, no data).
// Facts from: Linux drivers/usb/serial/ftdi_sio.h (request numbers, modem-control and purge values),
// FTDI application note AN232B-05 (baud divisor encoding), libnifalcon src/comm/FalconCommLibUSB.cpp
// (which requests the Falcon needs, in which order, and the divisor values it uses).
#pragma once

#include <cstddef>
#include <cstdint>

#include "devices/transport.hpp"

namespace hapticd::ftdi {

// Falcon's USB ids (libnifalcon FalconCommLibUSB: FALCON_VENDOR_ID 0x0403, FALCON_PRODUCT_ID 0xCB48).
inline constexpr std::uint16_t kFalconVendorId = 0x0403;
inline constexpr std::uint16_t kFalconProductId = 0xCB48;
// Bulk endpoints of the FT232R (libnifalcon FalconCommLibUSB: reads 0x81, writes 0x02).
inline constexpr std::uint8_t kEndpointIn = 0x81;
inline constexpr std::uint8_t kEndpointOut = 0x02;
// Full-speed bulk packets are 64 bytes; every IN packet starts with 2 modem-status bytes
// (ftdi_sio.h "Modem Status" description; libnifalcon "FTDI tacks 2 bytes onto that").
inline constexpr std::size_t kMaxPacket = 64;
inline constexpr std::size_t kStatusBytes = 2;

// bRequest values (ftdi_sio.h: FTDI_SIO_RESET 0, MODEM_CTRL 1, SET_FLOW_CTRL 2, SET_BAUD_RATE 3,
// SET_DATA 4, SET_LATENCY_TIMER 9).
inline constexpr std::uint8_t kRequestReset = 0;
inline constexpr std::uint8_t kRequestModemCtrl = 1;
inline constexpr std::uint8_t kRequestFlowCtrl = 2;
inline constexpr std::uint8_t kRequestBaudRate = 3;
inline constexpr std::uint8_t kRequestData = 4;
inline constexpr std::uint8_t kRequestLatency = 9;

// wValue of FTDI_SIO_RESET (ftdi_sio.h: SIO 0, purge RX 1, purge TX 2).
inline constexpr std::uint16_t kResetSio = 0;
inline constexpr std::uint16_t kPurgeRx = 1;
inline constexpr std::uint16_t kPurgeTx = 2;

// wValue of MODEM_CTRL: low byte = line state, high byte = which lines to change (ftdi_sio.h:
// DTR bit 0 / mask 0x0100, RTS bit 1 / mask 0x0200).
constexpr std::uint16_t modem_dtr(bool high) noexcept { return static_cast<std::uint16_t>(0x0100 | (high ? 1 : 0)); }
constexpr std::uint16_t modem_rts(bool high) noexcept { return static_cast<std::uint16_t>(0x0200 | (high ? 2 : 0)); }

// wValue of SET_DATA: bits 0..7 data bits, 8..10 parity (0 none), 11..13 stop bits (0 = 1 stop bit).
inline constexpr std::uint16_t kData8N1 = 8;

// Baud divisors (AN232B-05: divisor of the 3 MHz base clock, eighths encoded in bits 14..15 of wValue;
// 0.5 -> code 1). 9600 baud: 3e6 / 9600 = 312.5 -> 0x4000 | 312 = 0x4138 (libnifalcon uses the same).
// Bootloader and normal mode divisors as libnifalcon: 0x15 (21 -> ~140 kbaud) and 0x2 (1.5 Mbaud).
inline constexpr std::uint16_t kBaud9600 = 0x4138;
inline constexpr std::uint16_t kBaudBootloader = 0x0015;
inline constexpr std::uint16_t kBaudNormal = 0x0002;

// Encodes a baud rate for the FT232R (AN232B-05): divisor = 3e6 / baud rounded to the nearest 1/8;
// divisors 0 and 1 mean 3 Mbaud and 2 Mbaud. Returns wValue (wIndex bit 0 would carry the 0.875/0.375/
// 0.625 high bit; the values hapticd uses never need it, returns 0 when baud is out of range).
std::uint16_t baud_value(std::uint32_t baud) noexcept;

// Latency timer in ms (1..255): libnifalcon uses 16 during firmware load and 1 in normal mode.
inline constexpr std::uint16_t kLatencyFirmware = 16;
inline constexpr std::uint16_t kLatencyNormal = 1;

// Removes the 2 status bytes at the start of every kMaxPacket-sized chunk of a raw bulk-IN transfer.
// `out` may alias `raw` (in-place compaction). Returns the number of payload bytes.
std::size_t strip_ftdi_status(const std::uint8_t* raw, std::size_t raw_size, std::uint8_t* out) noexcept;

// The Falcon's index for all requests (libnifalcon passes INTERFACE_ANY = 0).
inline constexpr std::uint16_t kIndex = 0;

inline TransportStatus purge(FtdiTransport& t) noexcept {
    const TransportStatus s = t.control(kRequestReset, kPurgeRx, kIndex);
    return s != TransportStatus::Ok ? s : t.control(kRequestReset, kPurgeTx, kIndex);
}

}  // namespace hapticd::ftdi
