// HID PID report encoding/decoding. Layouts: OpenFFBoard ffb_defs.h (reportHID_t: id 1, 4 button bytes,
// int16 X at offset 5; FFB_SetConstantForce_Data_t: id 5, block, int16 magnitude; FFB_SetEffect_t) and
// the USB HID PID 1.0 usage values (effect operation, device control, block load status).
#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "devices/hid_ffb_protocol.hpp"

namespace hapticd::hid {
namespace {

Layout openffboard() {
    Layout l;
    l.position_scale = 0.001;  // units per count, for the test
    l.force_scale = 1000.0;    // counts per N
    return l;
}

TEST(HidProtocol, DecodesTheSignedXAxisOfTheInputReport) {
    // X = -2 = 0xFFFE little-endian at bytes 5, 6.
    const std::vector<std::uint8_t> report{0x01, 0x00, 0x00, 0x00, 0x00, 0xFE, 0xFF, 0x34, 0x12};
    double p = 0.0;
    ASSERT_TRUE(decode_position(report.data(), report.size(), openffboard(), p));
    EXPECT_DOUBLE_EQ(p, -0.002);
    // X = 0x1234 = 4660 when the axis is the next field.
    Layout l = openffboard();
    l.position_offset = 7;
    ASSERT_TRUE(decode_position(report.data(), report.size(), l, p));
    EXPECT_DOUBLE_EQ(p, 4.660);
}

TEST(HidProtocol, UnsignedOneAndFourByteAxesWithZeroOffset) {
    Layout l = openffboard();
    l.position_signed = false;
    l.position_bytes = 1;
    l.position_offset = 1;
    l.position_zero = 128.0;
    l.position_scale = 0.5;
    const std::vector<std::uint8_t> r1{0x01, 0xFF};
    double p = 0.0;
    ASSERT_TRUE(decode_position(r1.data(), r1.size(), l, p));
    EXPECT_DOUBLE_EQ(p, (255.0 - 128.0) * 0.5);
    l.position_bytes = 4;
    l.position_signed = true;
    l.position_zero = 0.0;
    l.position_scale = 1.0;
    const std::vector<std::uint8_t> r4{0x01, 0xFE, 0xFF, 0xFF, 0xFF};  // -2 as int32
    ASSERT_TRUE(decode_position(r4.data(), r4.size(), l, p));
    EXPECT_DOUBLE_EQ(p, -2.0);
}

TEST(HidProtocol, WrongIdOrShortReportIsRejected) {
    double p = 42.0;
    const std::vector<std::uint8_t> wrong_id{0x02, 0, 0, 0, 0, 1, 0};
    const std::vector<std::uint8_t> too_short{0x01, 0, 0, 0, 0, 1};
    EXPECT_FALSE(decode_position(wrong_id.data(), wrong_id.size(), openffboard(), p));
    EXPECT_FALSE(decode_position(too_short.data(), too_short.size(), openffboard(), p));
    EXPECT_FALSE(decode_position(too_short.data(), 0, openffboard(), p));
    EXPECT_EQ(p, 42.0);
}

TEST(HidProtocol, ConstantForceReportKnownBytes) {
    bool sat = true;
    // 1.5 N * 1000 = 1500 = 0x05DC -> DC 05.
    EXPECT_EQ(encode_constant_force(1.5, 1, openffboard(), sat), (std::array<std::uint8_t, 4>{0x05, 0x01, 0xDC, 0x05}));
    EXPECT_FALSE(sat);
    // -1.5 N -> -1500 = 0xFA24 -> 24 FA.
    EXPECT_EQ(encode_constant_force(-1.5, 3, openffboard(), sat), (std::array<std::uint8_t, 4>{0x05, 0x03, 0x24, 0xFA}));
    // 20 N -> 20000 counts, clamped to the logical maximum 10000 = 0x2710 -> 10 27.
    EXPECT_EQ(encode_constant_force(20.0, 1, openffboard(), sat), (std::array<std::uint8_t, 4>{0x05, 0x01, 0x10, 0x27}));
    EXPECT_TRUE(sat);
    // -10000 = 0xD8F0 -> F0 D8.
    EXPECT_EQ(encode_constant_force(-1e9, 1, openffboard(), sat), (std::array<std::uint8_t, 4>{0x05, 0x01, 0xF0, 0xD8}));
    // Non-finite: zero force.
    EXPECT_EQ(encode_constant_force(NAN, 1, openffboard(), sat), (std::array<std::uint8_t, 4>{0x05, 0x01, 0x00, 0x00}));
}

TEST(HidProtocol, ConstantForceRoundTrip) {
    const Layout l = openffboard();
    for (int counts = -10000; counts <= 10000; counts += 7) {
        bool sat = false;
        const auto r = encode_constant_force(counts / 1000.0, 1, l, sat);
        const auto back = static_cast<std::int16_t>(static_cast<std::uint16_t>(r[2] | (r[3] << 8)));
        ASSERT_EQ(back, counts);
        ASSERT_FALSE(sat);
    }
}

TEST(HidProtocol, EffectSetUpReports) {
    const Layout l = openffboard();
    EXPECT_EQ(encode_create_effect(l), (std::array<std::uint8_t, 4>{0x11, 0x01, 0x00, 0x00}));
    EXPECT_EQ(encode_effect_operation(2, EffectOperation::Start, l), (std::array<std::uint8_t, 4>{0x0A, 0x02, 0x01, 0x01}));
    EXPECT_EQ(encode_effect_operation(2, EffectOperation::Stop, l), (std::array<std::uint8_t, 4>{0x0A, 0x02, 0x03, 0x01}));
    EXPECT_EQ(encode_device_control(DeviceControl::EnableActuators, l), (std::array<std::uint8_t, 2>{0x0C, 0x01}));
    EXPECT_EQ(encode_block_free(2, l), (std::array<std::uint8_t, 2>{0x0B, 0x02}));
    const auto set = encode_set_effect(2, l);
    EXPECT_EQ(set[0], 0x01);  // Set Effect report id
    EXPECT_EQ(set[1], 0x02);  // block
    EXPECT_EQ(set[2], 0x01);  // constant force
    EXPECT_EQ(set[3], 0xFF);  // duration 0xFFFF: infinite
    EXPECT_EQ(set[4], 0xFF);
    EXPECT_EQ(set[11], 0xFF);  // gain
    EXPECT_EQ(set[13], 0x01);  // X axis enabled
}

TEST(HidProtocol, BlockLoadReport) {
    const Layout l = openffboard();
    std::uint8_t block = 0;
    const std::vector<std::uint8_t> ok{0x12, 0x03, 0x01, 0x28, 0x00};
    ASSERT_TRUE(decode_block_load(ok.data(), ok.size(), l, block));
    EXPECT_EQ(block, 3);
    const std::vector<std::uint8_t> full{0x12, 0x03, 0x02, 0x00, 0x00};
    EXPECT_FALSE(decode_block_load(full.data(), full.size(), l, block));
    const std::vector<std::uint8_t> wrong{0x13, 0x03, 0x01};
    EXPECT_FALSE(decode_block_load(wrong.data(), wrong.size(), l, block));
}

}  // namespace
}  // namespace hapticd::hid
