// SPDX-License-Identifier: Apache-2.0
// Falcon packet codec: byte vectors worked out by hand from the format in libnifalcon
// include/falcon/firmware/FalconFirmwareNovintSDK.h ("Input Layout", "Output Layout", "Motor Value
// Extraction Example") and libnifalcon's src/firmware/FalconFirmwareNovintSDK.cpp (nibble order, byte 13 bits).
#include <gtest/gtest.h>

#include <random>
#include <string>

#include "devices/falcon_protocol.hpp"

namespace hapticd::falcon {
namespace {

std::string as_text(const Packet& p) { return std::string(p.begin(), p.end()); }

const std::uint8_t* bytes(const std::string& s) { return reinterpret_cast<const std::uint8_t*>(s.data()); }

TEST(FalconProtocol, NullCommandIsAllA) {
    // FalconFirmwareNovintSDK.h: "A null input/output string looks like: <AAAAAAAAAAAAAA>".
    EXPECT_EQ(as_text(encode_command(Command{})), "<AAAAAAAAAAAAAA>");
}

TEST(FalconProtocol, CommandKnownVector) {
    // torque 0 = -1447 = 0xFA59 as int16; nibbles LSB first 9,5,A,F; + 0x41 -> 'J','F','K','P'
    //   (the header's extraction example: bytes 0x4A 0x46 0x4B 0x50 <-> 0xFA59, magnitude 1447).
    // torque 1 = 4096 = 0x1000 -> nibbles 0,0,0,1 -> "AAAB";  torque 2 = 1 -> "BAAA".
    // byte 13 = red LED 0x08 | homing 0x01 = 0x09 -> 'J';  byte 14 = 'A'.
    Command c;
    c.torque = {-1447, 4096, 1};
    c.leds = kLedRed;
    c.homing_mode = true;
    EXPECT_EQ(as_text(encode_command(c)), "<JFKPAAABBAAAJA>");
}

TEST(FalconProtocol, CommandTorqueIsClampedToProtocolRange) {
    // +-4096 is the torque cap (libnifalcon FalconKinematic.h: "Force values are capped at 4096").
    Command c;
    c.torque = {5000, -32768, 4097};
    // 4096 = 0x1000 -> "AAAB"; -4096 = 0xF000 -> nibbles 0,0,0,F -> "AAAP".
    EXPECT_EQ(as_text(encode_command(c)), "<AAABAAAPAAABAA>");
}

TEST(FalconProtocol, StatusKnownVectorDecodes) {
    // byte 13 = homed flags 0x7 << 4 | button 0x2 = 0x72, + 0x41 = 0xB3.
    std::string s = "<JFKPAAABBAAA";
    s += static_cast<char>(0xB3);
    s += "A>";
    Status st;
    ASSERT_TRUE(decode_status(bytes(s), st));
    EXPECT_EQ(st.encoder[0], -1447);
    EXPECT_EQ(st.encoder[1], 4096);
    EXPECT_EQ(st.encoder[2], 1);
    EXPECT_EQ(st.homed_mask, 7);
    EXPECT_EQ(st.buttons, 2);
}

TEST(FalconProtocol, MalformedStatusIsRejected) {
    Status st;
    EXPECT_FALSE(decode_status(bytes("<AAAAAAAAAAAAAA)"), st));  // no end marker
    EXPECT_FALSE(decode_status(bytes("(AAAAAAAAAAAAAA>"), st));  // no start marker
    EXPECT_FALSE(decode_status(bytes("<AAAAQAAAAAAAAA>"), st));  // 'Q' = 0x51 is not a nibble byte
    EXPECT_FALSE(decode_status(bytes("<AAAA@AAAAAAAAA>"), st));  // '@' = 0x40 below 'A'
    EXPECT_FALSE(decode_status(bytes("<AAAAAAAAAAAA>A>"), st));  // a frame character in byte 13
}

// Bytes 13 and 14 carry values outside 'A'..'P' on real Falcons; libnifalcon (FalconFirmwareNovintSDK.cpp
// formatOutput()) accepts them and decodes byte 13 as ((b - 0x41) >> 4) & 7 / (b - 0x41) & 0x0f.
TEST(FalconProtocol, Bytes13And14AreToleratedAsLibnifalconDoes) {
    Status st;
    std::string high = "<AAAAAAAAAAAA";
    high += static_cast<char>(0xC1);  // 0xC1 - 0x41 = 0x80: homed bits 0, grip 0 (the 0x80 bit is dropped)
    high += static_cast<char>(0x20);  // byte 14: any value
    high += ">";
    ASSERT_TRUE(decode_status(bytes(high), st));
    EXPECT_EQ(st.homed_mask, 0);
    EXPECT_EQ(st.buttons, 0);
    std::string low = "<AAAAAAAAAAAA";
    low += static_cast<char>(0x30);  // (0x30 - 0x41) mod 256 = 0xEF: homed (0xE & 7) = 6, grip 0xF
    low += "Z>";
    ASSERT_TRUE(decode_status(bytes(low), st));
    EXPECT_EQ(st.homed_mask, 6);
    EXPECT_EQ(st.buttons, 0xF);
}

TEST(FalconProtocol, StatusRoundTripOverRandomValues) {
    std::mt19937 rng(5);
    std::uniform_int_distribution<int> value(-32768, 32767);
    std::uniform_int_distribution<int> bits(0, 7);
    for (int i = 0; i < 2000; ++i) {
        Status in;
        for (auto& e : in.encoder) e = static_cast<std::int16_t>(value(rng));
        in.homed_mask = static_cast<std::uint8_t>(bits(rng));
        in.buttons = static_cast<std::uint8_t>(bits(rng) * 2 + 1);
        const Packet p = encode_status(in);
        Status out;
        ASSERT_TRUE(decode_status(p.data(), out));
        EXPECT_EQ(out.encoder, in.encoder);
        EXPECT_EQ(out.homed_mask, in.homed_mask);
        EXPECT_EQ(out.buttons, in.buttons);
    }
}

TEST(FalconProtocol, CommandBytesAreAlwaysPrintableFrameBytes) {
    std::mt19937 rng(6);
    std::uniform_int_distribution<int> value(-32768, 32767);
    for (int i = 0; i < 500; ++i) {
        Command c;
        for (auto& t : c.torque) t = static_cast<std::int16_t>(value(rng));
        c.leds = static_cast<std::uint8_t>(i & 0xFF);
        c.homing_mode = (i & 1) != 0;
        const Packet p = encode_command(c);
        EXPECT_EQ(p[0], '<');
        EXPECT_EQ(p[15], '>');
        for (std::size_t k = 1; k < 15; ++k) {
            EXPECT_GE(p[k], 'A');
            EXPECT_LE(p[k], 'P');
        }
    }
}

class FrameParserTest : public ::testing::Test {
  protected:
    Status make(std::int16_t e0) {
        Status s;
        s.encoder = {e0, static_cast<std::int16_t>(-e0), 7};
        s.homed_mask = 7;
        return s;
    }
    std::string frame(std::int16_t e0) {
        const Packet p = encode_status(make(e0));
        return std::string(p.begin(), p.end());
    }
    std::size_t feed(const std::string& s) { return parser.feed(bytes(s), s.size(), latest); }
    FrameParser parser;
    Status latest;
};

TEST_F(FrameParserTest, ResynchronisesAfterGarbage) {
    EXPECT_EQ(feed("xyz\x01\xff" + frame(100)), 1U);
    EXPECT_EQ(latest.encoder[0], 100);
    EXPECT_EQ(parser.counters().garbage_bytes, 5U);
    EXPECT_EQ(parser.counters().frames, 1U);
}

TEST_F(FrameParserTest, ShortFrameIsCountedAndDropped) {
    EXPECT_EQ(feed(frame(1).substr(0, 9) + frame(2)), 1U);
    EXPECT_EQ(latest.encoder[0], 2);
    EXPECT_EQ(parser.counters().short_frames, 1U);
    EXPECT_EQ(parser.counters().malformed, 0U);
}

TEST_F(FrameParserTest, MalformedFrameIsCountedAndNeverDecoded) {
    std::string bad = frame(-30000);
    bad[15] = 'X';  // end marker missing
    std::string bad_range = frame(-30000);
    bad_range[3] = 'Z';
    EXPECT_EQ(feed(frame(5) + bad + bad_range), 1U);
    EXPECT_EQ(latest.encoder[0], 5);  // the malformed frames did not overwrite it
    EXPECT_EQ(parser.counters().malformed, 2U);
}

TEST_F(FrameParserTest, FramesSplitAcrossReadsAreReassembled) {
    const std::string stream = frame(11) + frame(12) + frame(13);
    std::size_t decoded = 0;
    for (char c : stream) decoded += feed(std::string(1, c));
    EXPECT_EQ(decoded, 3U);
    EXPECT_EQ(latest.encoder[0], 13);
    EXPECT_EQ(parser.counters().garbage_bytes, 0U);
}

TEST_F(FrameParserTest, RandomGarbageWithoutStartMarkerNeverYieldsAFrame) {
    std::mt19937 rng(7);
    std::string junk;
    for (int i = 0; i < 4096; ++i) {
        auto c = static_cast<char>(rng() & 0xFF);
        if (c == '<') c = 'A';
        junk += c;
    }
    EXPECT_EQ(feed(junk), 0U);
    EXPECT_EQ(parser.counters().garbage_bytes, 4096U);
    EXPECT_EQ(feed(frame(42)), 1U);  // and the stream recovers at the next frame
    EXPECT_EQ(latest.encoder[0], 42);
}

}  // namespace
}  // namespace hapticd::falcon
