// SPDX-License-Identifier: Apache-2.0
// FTDI helpers. Baud values: FTDI AN232B-05 (divisor of 3 MHz, eighths in bits 14..15);
// libnifalcon FalconCommLibUSB.cpp: "Baud for 9600 is 0x4138".
#include <gtest/gtest.h>

#include <vector>

#include "devices/ftdi_protocol.hpp"

namespace hapticd::ftdi {
namespace {

TEST(Ftdi, BaudValues) {
    EXPECT_EQ(baud_value(9600), 0x4138);     // 312.5 -> 312 | code(1/2) = 1 << 14
    EXPECT_EQ(baud_value(115200), 0x001A);   // 26.04 -> 26 (nearest eighth: 26 + 0/8)
    EXPECT_EQ(baud_value(1500000), 0x0002);  // the Falcon's normal mode (libnifalcon divisor 0x2)
    EXPECT_EQ(baud_value(3000000), 0x0000);
    EXPECT_EQ(kBaud9600, baud_value(9600));
}

TEST(Ftdi, ModemControlValues) {
    // ftdi_sio.h: DTR high = 0x0101, DTR low = 0x0100, RTS high = 0x0202, RTS low = 0x0200.
    EXPECT_EQ(modem_dtr(true), 0x0101);
    EXPECT_EQ(modem_dtr(false), 0x0100);
    EXPECT_EQ(modem_rts(true), 0x0202);
    EXPECT_EQ(modem_rts(false), 0x0200);
}

TEST(Ftdi, StatusBytesAreStrippedFromEveryPacket) {
    // Two full 64-byte packets and a 4-byte one: 62 + 62 + 2 payload bytes.
    std::vector<std::uint8_t> raw;
    std::vector<std::uint8_t> expected;
    for (int packet = 0; packet < 3; ++packet) {
        raw.push_back(0x31);  // modem status
        raw.push_back(0x60);  // line status
        const int n = packet < 2 ? 62 : 2;
        for (int i = 0; i < n; ++i) {
            const auto b = static_cast<std::uint8_t>(packet * 100 + i);
            raw.push_back(b);
            expected.push_back(b);
        }
    }
    std::vector<std::uint8_t> out(raw.size());
    ASSERT_EQ(strip_ftdi_status(raw.data(), raw.size(), out.data()), expected.size());
    out.resize(expected.size());
    EXPECT_EQ(out, expected);
    // In place, and a status-only packet gives no payload.
    EXPECT_EQ(strip_ftdi_status(raw.data(), raw.size(), raw.data()), expected.size());
    const std::uint8_t status_only[2] = {0x31, 0x60};
    EXPECT_EQ(strip_ftdi_status(status_only, 2, out.data()), 0U);
}

}  // namespace
}  // namespace hapticd::ftdi
