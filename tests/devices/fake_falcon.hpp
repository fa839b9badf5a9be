// SPDX-License-Identifier: Apache-2.0
// A scripted Novint Falcon for tests, behind ScriptedTransport: the loader (handshake, echo at the
// bootloader baud rate) and, after a complete firmware upload and the switch to normal mode, the
// firmware answering every 16-byte command with a status packet. Behaviour from libnifalcon
// (FalconCommLibUSB.cpp setFirmwareMode(), FalconFirmware.cpp loadFirmware(), FalconFirmwareNovintSDK).
#pragma once

#include <cmath>
#include <functional>
#include <memory>
#include <vector>

#include "devices/falcon_device.hpp"
#include "devices/falcon_kinematics.hpp"
#include "devices/falcon_protocol.hpp"
#include "devices/ftdi_protocol.hpp"
#include "devices/transport_scripted.hpp"

namespace hapticd::test {

struct FakeFalcon {
    // Loader behaviour
    bool firmware_running = false;
    std::size_t firmware_size = 0;  // bytes the loader expects before it starts the firmware
    bool answer_handshake = true;
    bool leading_zero = false;      // the "Apple" variant of the handshake answer
    int corrupt_echo_attempts = 0;  // the first N upload attempts get one corrupted echo byte
    // A slow loader: every echo chunk is held back for this many reads, which return nothing (the FTDI
    // chip's status-only packets every 16 ms while the loader works).
    int empty_reads_before_echo = 0;
    // Firmware behaviour
    falcon::Status status;        // what the firmware reports
    int packets_until_homed = 0;  // homing-mode packets before the homed flags are set (-1: never)
    // After homing the user pulls the grip out (libnifalcon FalconCubeTest.cpp waits for z > 0.170 m):
    // this many packets after the homed flags, the encoders jump to the pose `pulled_out` (-1: never).
    int packets_until_pulled_out = 2;
    falcon::Vec3 pulled_out{0.0, 0.0, 0.175};
    std::function<void(ScriptedTransport&, const falcon::Packet&)> after_status;  // e.g. inject garbage

    // Observations
    std::vector<falcon::Command> commands;  // decoded commands received in normal mode
    int upload_attempts = 0;
    int opens = 0;        // open() calls (the firmware upload reopens between attempts)
    int latency_ms = 16;  // FTDI latency timer (set by the emulated FTDI control requests)
    int empty_reads_served = 0;
    ScriptedTransport* transport = nullptr;

    std::uint16_t baud = 0;
    std::size_t uploaded = 0;
    int homing_packets = 0;
    int homed_at_packet = -1;

    // Encoder counts of a position (inverse kinematics, then the inverse of encoder_to_angle()).
    static std::array<std::int16_t, 3> encoders_at(const falcon::Vec3& p) {
        const falcon::Geometry g = falcon::Geometry::published();
        falcon::Vec3 theta{};
        if (!falcon::inverse_kinematics(p, g, theta)) return {0, 0, 0};
        const double per_count = falcon::encoder_to_angle(1, g) - falcon::encoder_to_angle(0, g);
        std::array<std::int16_t, 3> e{};
        for (std::size_t i = 0; i < 3; ++i) {
            e[i] = static_cast<std::int16_t>(std::lround((theta[i] - falcon::encoder_to_angle(0, g)) / per_count));
        }
        return e;
    }

    OpenedTransport open() {
        auto t = std::make_unique<ScriptedTransport>();
        transport = t.get();
        t->on_write = [this](ScriptedTransport& tr, std::span<const std::uint8_t> data) { on_write(tr, data); };
        t->on_read = [this](ScriptedTransport& tr) { on_read(tr); };
        ++opens;
        OpenedTransport o;
        o.transport = std::move(t);
        o.status = TransportStatus::Ok;
        return o;
    }

    std::vector<std::uint8_t> held_echo;
    int hold_reads = 0;
    void on_read(ScriptedTransport& tr) {
        if (held_echo.empty()) return;
        if (hold_reads-- > 0) {
            ++empty_reads_served;
            return;
        }
        tr.rx.insert(tr.rx.end(), held_echo.begin(), held_echo.end());
        held_echo.clear();
    }

    void on_write(ScriptedTransport& tr, std::span<const std::uint8_t> data) {
        // Track the baud rate from the latest control requests.
        for (const auto& c : tr.controls) {
            if (c.request == ftdi::kRequestBaudRate) baud = c.value;
        }
        if (firmware_running && baud == ftdi::kBaudNormal) {
            if (data.size() != falcon::kPacketSize || data[0] != falcon::kStart) return;
            falcon::Command c;
            c.homing_mode = (data[13] - falcon::kNibbleBase) & falcon::kHomingModeBit;
            c.leds = static_cast<std::uint8_t>((data[13] - falcon::kNibbleBase) & 0x0E);
            for (std::size_t a = 0; a < 3; ++a) {
                std::uint16_t bits = 0;
                for (int n = 0; n < 4; ++n)
                    bits = static_cast<std::uint16_t>(bits | ((data[1 + 4 * a + n] - 0x41) & 0xF) << (4 * n));
                c.torque[a] = static_cast<std::int16_t>(bits);
            }
            commands.push_back(c);
            if (c.homing_mode && packets_until_homed >= 0 && ++homing_packets > packets_until_homed) {
                if (status.homed_mask != 7) homed_at_packet = homing_packets;
                status.homed_mask = 7;
                if (packets_until_pulled_out >= 0 && homing_packets == homed_at_packet + packets_until_pulled_out) {
                    status.encoder = encoders_at(pulled_out);
                }
            }
            const falcon::Packet p = falcon::encode_status(status);
            tr.push_rx(p);
            if (after_status) after_status(tr, p);
            return;
        }
        if (firmware_running) return;  // wrong baud: the answer would be line noise; nothing useful
        static constexpr std::uint8_t kQuery[3] = {0x0A, 0x43, 0x0D};
        if (data.size() == 3 && std::equal(data.begin(), data.end(), kQuery)) {
            if (!answer_handshake) return;
            if (leading_zero) tr.rx.push_back(0x00);
            for (std::uint8_t b : {0x0A, 0x44, 0x2C, 0x0D}) tr.rx.push_back(b);
            uploaded = 0;
            ++upload_attempts;
            return;
        }
        if (baud != ftdi::kBaudBootloader) return;
        if (data.size() == 1 && data[0] == 0x41 && uploaded == 0) {
            tr.rx.push_back(0x41);
            return;
        }
        for (std::size_t i = 0; i < data.size(); ++i) {
            std::uint8_t echo = data[i];
            if (upload_attempts <= corrupt_echo_attempts && uploaded + i == 70) echo ^= 0x5A;
            if (empty_reads_before_echo > 0) {
                held_echo.push_back(echo);
            } else {
                tr.rx.push_back(echo);
            }
        }
        hold_reads = empty_reads_before_echo;
        uploaded += data.size();
        if (firmware_size != 0 && uploaded >= firmware_size) firmware_running = true;
    }
};

}  // namespace hapticd::test
