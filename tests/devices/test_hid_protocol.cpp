// SPDX-License-Identifier: Apache-2.0
// HID PID reports laid out from the report descriptor (hid_report_descriptor.hpp, hid_ffb_protocol.hpp)
// against an OpenFFBoard-like descriptor (pid_descriptor.hpp). Expected bytes are worked out by hand from
// the descriptor's items (field order, sizes, logical ranges); the parser is the second way to the same
// numbers.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

#include "common/test_paths.hpp"
#include "devices/hid_ffb_protocol.hpp"
#include "pid_descriptor.hpp"

namespace hapticd::hid {
namespace {

struct Pid {
    explicit Pid(bool axes_32_bit = false) {
        const std::vector<std::uint8_t> d = test::openffboard_like_descriptor(axes_32_bit);
        ok = build_pid_layout(d.data(), d.size(), layout, error);
    }
    PidLayout layout;
    std::string error;
    bool ok = false;
};

Layout scaling() {
    Layout l;
    l.position_scale = 0.001;  // units per count, for the test
    l.force_scale = 1000.0;    // counts per N
    return l;
}

std::vector<std::uint8_t> bytes(const Report& r) {
    return {r.bytes.begin(), r.bytes.begin() + static_cast<long>(r.size)};
}

TEST(HidDescriptor, ReportSizesAndTheXAxisComeFromTheDescriptor) {
    Pid p;
    ASSERT_TRUE(p.ok) << p.error;
    EXPECT_TRUE(p.layout.ids);
    EXPECT_EQ(p.layout.input_id, 1);
    EXPECT_EQ(p.layout.input_bytes, 13U);           // 1 + 64 bits + 2 x 16 bits
    EXPECT_EQ(p.layout.position->bit_offset, 64U);  // after the 64 button bits: byte 9 with the id byte
    EXPECT_EQ(p.layout.position->bit_size, 16U);
    EXPECT_EQ(p.layout.set_effect_bytes, 22U);  // not 16: the default 2-axis descriptor
    EXPECT_EQ(p.layout.constant_bytes, 4U);
    EXPECT_EQ(p.layout.cf_magnitude->logical_min, -32767);
    EXPECT_EQ(p.layout.cf_magnitude->logical_max, 32767);
    Pid wide(true);
    ASSERT_TRUE(wide.ok) << wide.error;
    EXPECT_EQ(wide.layout.input_bytes, 17U);
    EXPECT_EQ(wide.layout.position->bit_size, 32U);
}

TEST(HidDescriptor, PositionIsReadAtByte9ForBoth16And32BitAxes) {
    Pid p;
    ASSERT_TRUE(p.ok) << p.error;
    // Buttons all set (bytes 1..8 = 0xFF: reading X inside them would give -1), X = -2 at bytes 9, 10.
    std::vector<std::uint8_t> r{0x01, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 0xFE, 0xFF, 0x34, 0x12};
    double x = 0.0;
    ASSERT_TRUE(decode_position(r.data(), r.size(), p.layout, scaling(), x));
    EXPECT_DOUBLE_EQ(x, -0.002);
    EXPECT_FALSE(decode_position(r.data(), 10, p.layout, scaling(), x));  // cut inside X
    r[0] = 0x02;
    EXPECT_FALSE(decode_position(r.data(), r.size(), p.layout, scaling(), x));  // another report
    Pid wide(true);
    ASSERT_TRUE(wide.ok);
    const std::vector<std::uint8_t> r32{0x01, 0, 0, 0, 0, 0, 0, 0, 0, 0x40, 0x42, 0x0F, 0x00, 0, 0, 0, 0};  // 1e6
    ASSERT_TRUE(decode_position(r32.data(), r32.size(), wide.layout, scaling(), x));
    EXPECT_DOUBLE_EQ(x, 1000.0);
}

TEST(HidReports, SetEffectHasDirectionEnableAnd90DegreesAndTheDescriptorLength) {
    Pid p;
    ASSERT_TRUE(p.ok) << p.error;
    // id, block 3, type 1 (ET Constant Force is the first of the array, logical minimum 1), duration
    // 0xFFFF, trigger repeat 0, sample period 0, start delay 0, gain 255 (its logical maximum), trigger
    // button 0, then bit 0 = X enabled, bit 1 = Y off, bit 2 = Direction Enable -> 0x05, direction
    // instance 1 = 36000 / 4 = 9000 = 0x2328, instance 2 = 0, type-specific offsets 0.
    const std::vector<std::uint8_t> expected{0x01, 0x03, 0x01, 0xFF, 0xFF, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00,
                                             0xFF, 0x00, 0x05, 0x28, 0x23, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00};
    EXPECT_EQ(bytes(encode_set_effect(3, p.layout)), expected);
}

TEST(HidReports, ConstantForceUsesTheMagnitudeRangeOfTheDescriptor) {
    Pid p;
    ASSERT_TRUE(p.ok);
    bool saturated = true;
    // -1.5 N * 1000 counts/N = -1500 = 0xFA24.
    EXPECT_EQ(bytes(encode_constant_force(-1.5, 2, p.layout, scaling(), saturated)),
              (std::vector<std::uint8_t>{0x05, 0x02, 0x24, 0xFA}));
    EXPECT_FALSE(saturated);
    // 20 N -> 20000 counts: inside +-32767 (it was clamped at 10000 before).
    EXPECT_EQ(bytes(encode_constant_force(20.0, 2, p.layout, scaling(), saturated)),
              (std::vector<std::uint8_t>{0x05, 0x02, 0x20, 0x4E}));
    EXPECT_FALSE(saturated);
    // 40 N -> clamped to 32767 = 0x7FFF; -40 N -> -32767 = 0x8001.
    EXPECT_EQ(bytes(encode_constant_force(40.0, 2, p.layout, scaling(), saturated)),
              (std::vector<std::uint8_t>{0x05, 0x02, 0xFF, 0x7F}));
    EXPECT_TRUE(saturated);
    EXPECT_EQ(bytes(encode_constant_force(-40.0, 2, p.layout, scaling(), saturated)),
              (std::vector<std::uint8_t>{0x05, 0x02, 0x01, 0x80}));
    EXPECT_EQ(bytes(encode_constant_force(NAN, 2, p.layout, scaling(), saturated)),
              (std::vector<std::uint8_t>{0x05, 0x02, 0x00, 0x00}));
}

TEST(HidReports, ControlGainOperationAndBlockLoad) {
    Pid p;
    ASSERT_TRUE(p.ok);
    // Device Control array: Enable 0x97 -> 1, Disable 2, Stop All 3, Reset 0x9A -> 4.
    EXPECT_EQ(bytes(encode_device_control(DeviceControl::Reset, p.layout)), (std::vector<std::uint8_t>{0x0C, 4}));
    EXPECT_EQ(bytes(encode_device_control(DeviceControl::StopAll, p.layout)), (std::vector<std::uint8_t>{0x0C, 3}));
    EXPECT_EQ(bytes(encode_device_control(DeviceControl::EnableActuators, p.layout)),
              (std::vector<std::uint8_t>{0x0C, 1}));
    EXPECT_EQ(bytes(encode_device_gain(1.0, p.layout)), (std::vector<std::uint8_t>{0x0D, 0xFF}));
    // Effect Operation: block, Start = 1 / Stop = 3, loop count 1.
    EXPECT_EQ(bytes(encode_effect_operation(7, EffectOperation::Start, p.layout)),
              (std::vector<std::uint8_t>{0x0A, 7, 1, 1}));
    EXPECT_EQ(bytes(encode_effect_operation(7, EffectOperation::Stop, p.layout)),
              (std::vector<std::uint8_t>{0x0A, 7, 3, 1}));
    EXPECT_EQ(bytes(encode_block_free(7, p.layout)), (std::vector<std::uint8_t>{0x0B, 7}));
    EXPECT_EQ(bytes(encode_create_effect(p.layout)), (std::vector<std::uint8_t>{0x11, 1, 0, 0}));
    std::uint8_t block = 0;
    const std::vector<std::uint8_t> ok{0x12, 0x05, 0x01, 0x00, 0x10};
    ASSERT_TRUE(decode_block_load(ok.data(), ok.size(), p.layout, block));
    EXPECT_EQ(block, 5);
    const std::vector<std::uint8_t> full{0x12, 0x05, 0x02, 0x00, 0x00};
    block = 0;
    EXPECT_FALSE(decode_block_load(full.data(), full.size(), p.layout, block));
    EXPECT_EQ(block, 0);
}

TEST(HidDescriptor, MalformedDescriptorsAreRefusedWithTheOffset) {
    ReportDescriptor d;
    std::string error;
    const std::vector<std::uint8_t> truncated{0x05, 0x01, 0x26, 0xFF};  // Logical Maximum needs 2 bytes
    EXPECT_FALSE(parse_report_descriptor(truncated.data(), truncated.size(), d, error));
    EXPECT_NE(error.find("byte 2"), std::string::npos) << error;
    const std::vector<std::uint8_t> open_collection{0x05, 0x01, 0x09, 0x04, 0xA1, 0x01};
    EXPECT_FALSE(parse_report_descriptor(open_collection.data(), open_collection.size(), d, error));
    EXPECT_NE(error.find("not closed"), std::string::npos) << error;
    const std::vector<std::uint8_t> pop{0xB4};
    EXPECT_FALSE(parse_report_descriptor(pop.data(), pop.size(), d, error));
    const std::vector<std::uint8_t> huge_size{0x75, 0x40};  // Report Size 64
    EXPECT_FALSE(parse_report_descriptor(huge_size.data(), huge_size.size(), d, error));
    EXPECT_NE(error.find("1..32"), std::string::npos) << error;
    // Report Size 16 x Report Count 0x1000040C: 2^32 + 16576 bits, which wraps to 16576 in 32-bit arithmetic
    // (the fuzz target's find, tests/fuzz/corpus/hid_reports/regression-report-count-overflow).
    const std::vector<std::uint8_t> wrapping{0x75, 0x10, 0x97, 0x0C, 0x04, 0x00, 0x10, 0x91, 0x02};
    EXPECT_FALSE(parse_report_descriptor(wrapping.data(), wrapping.size(), d, error));
    EXPECT_NE(error.find("longer than 4096 bytes"), std::string::npos) << error;
    // A keyboard: parses, but has no PID reports.
    const std::vector<std::uint8_t> keyboard{0x05, 0x01, 0x09, 0x06, 0xA1, 0x01, 0x05, 0x07, 0x19, 0xE0, 0x29, 0xE7,
                                             0x15, 0x00, 0x25, 0x01, 0x75, 0x01, 0x95, 0x08, 0x81, 0x02, 0xC0};
    PidLayout p;
    EXPECT_FALSE(build_pid_layout(keyboard.data(), keyboard.size(), p, error));
    EXPECT_NE(error.find("X axis"), std::string::npos) << error;
}

// The input the fuzz target found (tests/fuzz/corpus/hid_reports/regression-magnitude-range-inverted: a
// 2-byte length, then the descriptor): its Set Constant Force Magnitude has Logical Minimum 32766 above
// Logical Maximum 9471. The layout is refused, naming the field and the accepted range, instead of
// clamping forces into an empty range.
TEST(HidDescriptor, MagnitudeWithoutNegativeAndPositiveValuesIsRefused) {
    std::ifstream in(
        std::string(HAPTICOPT_TEST_DATA_DIR) + "/../fuzz/corpus/hid_reports/regression-magnitude-range-inverted",
        std::ios::binary);
    ASSERT_TRUE(in) << "corpus file missing";
    const std::vector<std::uint8_t> input{std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
    ASSERT_GE(input.size(), 2U);
    const std::size_t length = std::min<std::size_t>(input.size() - 2, input[0] | (input[1] << 8));
    PidLayout p;
    std::string error;
    EXPECT_FALSE(build_pid_layout(input.data() + 2, length, p, error));
    EXPECT_NE(error.find("Magnitude has logical range [32766, 9471]"), std::string::npos) << error;
    EXPECT_NE(error.find("logical minimum < 0 < logical maximum"), std::string::npos) << error;
}

TEST(HidDescriptor, FieldsRoundTripAtAnyBitOffset) {
    // put_field/get_field against a bit-by-bit reference: a 13-bit signed field at bit 5.
    ReportField f;
    f.bit_offset = 5;
    f.bit_size = 13;
    f.logical_min = -4096;
    f.logical_max = 4095;
    for (std::int64_t v : {-4096L, -1L, 0L, 1L, 1234L, 4095L}) {
        std::array<std::uint8_t, 4> r{0xAA, 0xAA, 0xAA, 0xAA};
        put_field(r.data(), r.size(), f, true, v);
        for (int bit = 0; bit < 32; ++bit) {
            const bool inside = bit >= 13 && bit < 26;  // 8 (id byte) + 5 .. + 13
            const bool expected =
                inside ? ((static_cast<std::uint64_t>(v) >> (bit - 13)) & 1U) != 0 : ((0xAAU >> (bit % 8)) & 1U) != 0;
            EXPECT_EQ(((r[static_cast<std::size_t>(bit / 8)] >> (bit % 8)) & 1U) != 0, expected)
                << "v " << v << " bit " << bit;
        }
        std::int64_t back = 0;
        ASSERT_TRUE(get_field(r.data(), r.size(), f, true, back));
        EXPECT_EQ(back, v);
    }
}

}  // namespace
}  // namespace hapticd::hid
