// SPDX-License-Identifier: Apache-2.0
// Firmware-upload state machine against the scripted Falcon loader (fake_falcon.hpp).
#include <gtest/gtest.h>

#include <numeric>
#include <vector>

#include "devices/falcon_firmware.hpp"
#include "fake_falcon.hpp"

namespace hapticd::falcon {
namespace {

using test::FakeFalcon;

std::vector<std::uint8_t> image(std::size_t n) {
    std::vector<std::uint8_t> v(n);
    for (std::size_t i = 0; i < n; ++i) v[i] = static_cast<std::uint8_t>((i * 37 + 11) & 0xFF);
    return v;
}

struct Fixture {
    FakeFalcon falcon;
    OpenedTransport opened = falcon.open();
    ScriptedTransport& t = *falcon.transport;
};

TEST(FalconFirmware, UploadsInChunksWithEchoCheckThenSwitchesToNormalMode) {
    Fixture f;
    const auto img = image(200);  // 62 + 62 + 62 + 14
    f.falcon.firmware_size = img.size();
    const FirmwareUploadResult r = upload_firmware(f.t, img);
    ASSERT_TRUE(r.ok) << r.message;
    EXPECT_EQ(r.stage, FirmwareStage::Done);
    EXPECT_EQ(r.attempts_used, 1);
    EXPECT_EQ(r.bytes_confirmed, 200U);
    // Writes: handshake, 'A', four chunks.
    ASSERT_EQ(f.t.writes.size(), 6U);
    EXPECT_EQ(f.t.writes[0], (std::vector<std::uint8_t>{0x0A, 0x43, 0x0D}));
    EXPECT_EQ(f.t.writes[1], (std::vector<std::uint8_t>{0x41}));
    EXPECT_EQ(f.t.writes[2].size(), 62U);
    EXPECT_EQ(f.t.writes[5].size(), 14U);
    // The control requests of libnifalcon's setFirmwareMode()/setNormalMode(), in order.
    using C = ScriptedTransport::Control;
    const std::vector<std::pair<int, int>> expected{
        {0, 0},      {0, 1},      {0, 2},              // reset, purge RX, purge TX
        {9, 16},     {3, 0x4138}, {4, 8},              // latency 16 ms, 9600 baud, 8N1
        {2, 0},      {1, 0x0200}, {1, 0x0100},         // no flow control, RTS low, DTR low
        {1, 0x0101}, {0, 1},                           // DTR high, purge RX
        {1, 0x0100}, {3, 0x15},                        // sync: DTR low, ~140 kbaud
        {9, 1},      {3, 0x2},    {0, 1},      {0, 2}  // normal: latency 1 ms, 1.5 Mbaud, purge
    };
    ASSERT_EQ(f.t.controls.size(), expected.size());
    for (std::size_t i = 0; i < expected.size(); ++i) {
        const C& c = f.t.controls[i];
        EXPECT_EQ(c.request, expected[i].first) << "control #" << i;
        EXPECT_EQ(c.value, expected[i].second) << "control #" << i;
        EXPECT_EQ(c.index, 0) << "control #" << i;
    }
}

TEST(FalconFirmware, AcceptsTheHandshakeAnswerWithLeadingZero) {
    Fixture f;
    f.falcon.leading_zero = true;
    const auto img = image(62);
    EXPECT_TRUE(upload_firmware(f.t, img).ok);
}

TEST(FalconFirmware, EchoMismatchIsRetriedFromTheStart) {
    Fixture f;
    f.falcon.corrupt_echo_attempts = 1;
    const auto img = image(300);
    const FirmwareUploadResult r = upload_firmware(f.t, img);
    ASSERT_TRUE(r.ok) << r.message;
    EXPECT_EQ(r.attempts_used, 2);
    EXPECT_EQ(f.falcon.upload_attempts, 2);  // the handshake was repeated
}

TEST(FalconFirmware, PersistentEchoMismatchEndsWithAClearError) {
    Fixture f;
    f.falcon.corrupt_echo_attempts = 100;
    const auto img = image(300);
    FirmwareUploadConfig cfg;
    cfg.attempts = 3;
    const FirmwareUploadResult r = upload_firmware(f.t, img, cfg);
    EXPECT_FALSE(r.ok);
    EXPECT_EQ(r.attempts_used, 3);
    EXPECT_EQ(r.stage, FirmwareStage::Upload);
    EXPECT_EQ(r.bytes_confirmed, 62U);  // the first chunk was fine; byte 70 is in the second
    EXPECT_NE(r.message.find("after 3 attempt(s)"), std::string::npos) << r.message;
    EXPECT_NE(r.message.find("echo mismatch at firmware byte 70"), std::string::npos) << r.message;
}

// The FTDI chip answers reads with status-only packets (no payload) every 16 ms while the loader
// works; libnifalcon's loadFirmware() keeps reading. 20 empty reads per chunk (0.32 s at 16 ms) are
// waited through; the old limit was 3 per chunk, cumulative.
TEST(FalconFirmware, SlowLoaderIsWaitedFor) {
    Fixture f;
    f.falcon.empty_reads_before_echo = 20;
    const auto img = image(300);  // 5 chunks
    f.falcon.firmware_size = img.size();
    const FirmwareUploadResult r = upload_firmware(f.t, img);
    ASSERT_TRUE(r.ok) << r.message;
    EXPECT_EQ(r.attempts_used, 1);
    EXPECT_EQ(f.falcon.empty_reads_served, 5 * 20);
}

TEST(FalconFirmware, LoaderThatStopsEchoingTimesOutAfterThePatience) {
    Fixture f;
    f.falcon.empty_reads_before_echo = 1'000'000;  // never within the limit below
    FirmwareUploadConfig cfg;
    cfg.attempts = 1;
    cfg.max_consecutive_empty_reads = 50;
    const FirmwareUploadResult r = upload_firmware(f.t, image(100), cfg);
    EXPECT_FALSE(r.ok);
    EXPECT_EQ(r.stage, FirmwareStage::Upload);  // the sync 'A' is answered; the first chunk's echo never comes
    EXPECT_EQ(r.transport, TransportStatus::Timeout);
    EXPECT_EQ(f.falcon.empty_reads_served, 51);
}

TEST(FalconFirmware, DefaultsFollowLibnifalcon) {
    const FirmwareUploadConfig cfg;
    EXPECT_EQ(cfg.handshake_tries, 100);  // FalconCommLibUSB.cpp setFirmwareMode()
    EXPECT_EQ(cfg.attempts, 10);          // FalconCLIBase.cpp loadFirmware(10, ...)
}

TEST(FalconFirmware, SilentLoaderFailsInTheHandshake) {
    Fixture f;
    f.falcon.answer_handshake = false;
    FirmwareUploadConfig cfg;
    cfg.attempts = 2;
    cfg.handshake_tries = 5;
    const FirmwareUploadResult r = upload_firmware(f.t, image(10), cfg);
    EXPECT_FALSE(r.ok);
    EXPECT_EQ(r.stage, FirmwareStage::Handshake);
    EXPECT_EQ(r.attempts_used, 2);
    EXPECT_EQ(f.t.writes.size(), 10U);  // 5 handshake tries per attempt
    EXPECT_NE(r.message.find("stage 'handshake'"), std::string::npos) << r.message;
    // The message counts what the tries saw: the silent loader's reads all came back empty.
    EXPECT_NE(r.message.find("5 of 5 tries"), std::string::npos) << r.message;
    EXPECT_NE(r.message.find("5 read(s) with no answer, 0 with a wrong one"), std::string::npos) << r.message;
}

TEST(FalconFirmware, DisconnectStopsRetrying) {
    Fixture f;
    f.t.disconnected = true;
    const FirmwareUploadResult r = upload_firmware(f.t, image(10));
    EXPECT_FALSE(r.ok);
    EXPECT_EQ(r.attempts_used, 1);
    EXPECT_EQ(r.transport, TransportStatus::Disconnected);
}

TEST(FalconFirmware, FailedControlRequestIsReported) {
    Fixture f;
    f.t.fail_control_at = 4;  // the baud-rate request
    FirmwareUploadConfig cfg;
    cfg.attempts = 1;
    const FirmwareUploadResult r = upload_firmware(f.t, image(10), cfg);
    EXPECT_FALSE(r.ok);
    EXPECT_EQ(r.stage, FirmwareStage::Configure);
    EXPECT_NE(r.message.find("0x4138"), std::string::npos) << r.message;
}

TEST(FalconFirmware, EmptyImageIsRefused) {
    Fixture f;
    const FirmwareUploadResult r = upload_firmware(f.t, {});
    EXPECT_FALSE(r.ok);
    EXPECT_TRUE(f.t.writes.empty());
}

}  // namespace
}  // namespace hapticd::falcon
