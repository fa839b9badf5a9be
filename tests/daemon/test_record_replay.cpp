// SPDX-License-Identifier: Apache-2.0
// --record and --replay as real processes (docs/recording.md): hapticd --serve in lockstep on the 3-axis simulated
// device (tests/server/sim3.toml, the simulated hand at rest holding the handle with its spring), a client adding
// a plane around the handle (the hand presses against it while it moves out), moving it, then leaving (a
// departure); SIGTERM ends the run. The replay must reproduce every force bit for bit, run as many ticks and take
// as many batches as recorded; a recording whose force or position was changed (checksum made valid again) is
// named at the changed tick; bad files end with exit code 10 and a message naming the file and the defect.
#include <cmath>
#include <cstring>
#include <fstream>
#include <iterator>

#include "common/test_paths.hpp"
#include "record_replay_support.hpp"

namespace hapticd::server_test {
namespace {

// The recorded run, made once for the tests of this file: its path. Each step waits for the loop's ticks (the
// state's tick counter), not for time: the batches land at least kGap ticks apart however fast the lockstep
// loop runs.
const std::string& recorded_run() {
    static const std::string path = [] {
        constexpr std::uint64_t kGap = 300;
        const Names n = names("record");
        const std::string file = (scratch() / "run.rec").string();
        Child daemon(HAPTICD_BINARY,
                     daemon_args(n, {"--lockstep", "--serve-wait-commit", "--hand-stiffness", "-1", "--hand-damping",
                                     "-1", "--record", file}),
                     "record_daemon");
        EXPECT_TRUE(wait_for_socket(n.socket)) << daemon.err();
        const cl::StateReader state = cl::StateReader::open(n.shm);
        {
            cl::Client c =
                cl::Client::connect({.socket_path = n.socket, .client_name = "recorder-test", .timeout_s = 60.0});
            // The handle rests at the origin: the plane's surface (y = -offset; normal -y, across the config wall's x)
            // is behind it, so it appears at the handle and moves out (the activation rule) against the hand's spring.
            const auto plane = [](double offset) {
                return cl::Plane{.normal = {0.0, -1.0, 0.0}, .offset = offset, .gains = cl::Gains::by_criterion("CE2")};
            };
            cl::Batch add;
            add.add(plane(0.002));
            const cl::CommitResult r = c.commit(add);
            std::uint64_t seq = r.commit_seq;
            for (int i = 1; i <= 5; ++i) {
                const cl::StateSample applied =
                    wait_state(state, [&](const cl::StateSample& s) { return s.last_commit_seq >= seq; });
                wait_state(state, [&](const cl::StateSample& s) { return s.tick >= applied.tick + kGap; });
                cl::Batch move;
                move.modify(r.object_ids.at(0), plane(0.002 + 0.0005 * i));
                seq = c.commit(move).commit_seq;
            }
            const cl::StateSample applied =
                wait_state(state, [&](const cl::StateSample& s) { return s.last_commit_seq >= seq; });
            wait_state(state, [&](const cl::StateSample& s) { return s.tick >= applied.tick + kGap; });
        }  // the client leaves: a departure, the plane ramps out
        stop_after_the_client_left(state, daemon);
        return file;
    }();
    return path;
}

TEST(RecordReplay, TheReplayReproducesEveryForceBitForBit) {
    const Recording r = read_recording(recorded_run());
    // add, 5 moves, the departure.
    ASSERT_EQ(r.batches.size(), 7U);
    std::size_t departures = 0, nonzero = 0;
    for (const auto& b : r.batches) departures += b.source == CommitSource::Departure ? 1 : 0;
    for (const auto& t : r.ticks) nonzero += t.force[1] != 0.0 ? 1 : 0;
    std::printf("[ record ] %zu ticks (%zu with force), %zu batches (%zu departures), %zu bytes\n", r.ticks.size(),
                nonzero, r.batches.size(), departures, read_bytes(recorded_run()).size());
    EXPECT_EQ(departures, 1U);
    ASSERT_GT(nonzero, 1000U);  // the comparison is not one of zeros

    expect_replays_bit_for_bit(recorded_run(), "replay_ok", r.ticks.size(), r.batches.size());
}

// The middle one of the ticks in steady contact with the plane: force along -y (its normal) between 1 mN and
// 1 N, changing by less than 1 N from the tick before and to the tick after. There neither the saturation
// (10 N, sim3.toml) nor the rate limit (1e4 N/s: 10 N per tick) acts, also with the force changed by K 1 um
// (0.07 N for the CE2 plane), so the force is the plane's law of that tick's position.
std::uint64_t pressed_tick(const Recording& r) {
    std::vector<std::uint64_t> pressed;
    for (std::size_t i = 1; i + 1 < r.ticks.size(); ++i) {
        const double f = r.ticks[i].force[1];
        if (f < -1e-3 && f > -1.0 && r.ticks[i].contact_mask != 0 && std::abs(f - r.ticks[i - 1].force[1]) < 1.0 &&
            std::abs(r.ticks[i + 1].force[1] - f) < 1.0) {
            pressed.push_back(r.ticks[i].tick);
        }
    }
    return pressed.empty() ? 0 : pressed[pressed.size() / 2];
}

TEST(RecordReplay, AChangedForceIsNamedAtItsTick) {
    const Recording r = read_recording(recorded_run());
    const std::uint64_t tick = pressed_tick(r);
    ASSERT_GT(tick, 0U);
    std::vector<char> bytes = read_bytes(recorded_run());
    const std::size_t at = tick_offset(bytes, tick);
    ASSERT_GT(at, 0U);
    rec::TickChunk t;
    std::memcpy(&t, bytes.data() + at, sizeof t);
    const double original = t.force[1];
    t.force[1] = std::nextafter(t.force[1], 0.0);  // one ulp
    std::memcpy(bytes.data() + at, &t, sizeof t);
    reseal(bytes);
    const std::string file = (scratch() / "force_tampered.rec").string();
    write_bytes(file, bytes);

    const Replay out = replay(file, "replay_force");
    EXPECT_EQ(out.code, 11) << out.err;
    char values[200];
    std::snprintf(values, sizeof values, "force[1] recorded %.17g N, replayed %.17g N", t.force[1], original);
    EXPECT_NE(out.err.find("1 of " + std::to_string(r.ticks.size()) + " ticks differ; the first is tick " +
                           std::to_string(tick) + ": "),
              std::string::npos)
        << out.err;
    EXPECT_NE(out.err.find(values), std::string::npos) << out.err;
}

// A position changed by 1 um at a tick of steady contact (pressed_tick): with no delay buffer that tick's force is
// the plane's law of the position read in the same tick, K (offset - n.x) + ..., K = 7.4e4 N/m (CE2 for 0.30 kg,
// 1 ms): a change of 0.074 N, far above the force's rounding, so that tick is the first to differ.
TEST(RecordReplay, AChangedPositionIsNamedAtItsTick) {
    const Recording r = read_recording(recorded_run());
    const std::uint64_t tick = pressed_tick(r);
    ASSERT_GT(tick, 0U);
    std::vector<char> bytes = read_bytes(recorded_run());
    const std::size_t at = tick_offset(bytes, tick);
    rec::TickChunk t;
    std::memcpy(&t, bytes.data() + at, sizeof t);
    t.position[1] += 1e-6;
    std::memcpy(bytes.data() + at, &t, sizeof t);
    reseal(bytes);
    const std::string file = (scratch() / "position_tampered.rec").string();
    write_bytes(file, bytes);

    const Replay out = replay(file, "replay_position");
    EXPECT_EQ(out.code, 11) << out.err;
    EXPECT_NE(out.err.find("ticks differ; the first is tick " + std::to_string(tick) + ": force[1]"), std::string::npos)
        << out.err;
}

// Bad files: exit 10, the file's path and the defect in the message, never a crash.
TEST(RecordReplay, BadRecordingsAreRefusedWithTheirDefect) {
    const std::vector<char> good = read_bytes(recorded_run());
    ASSERT_GT(good.size(), 4096U);
    struct Case {
        std::string name;
        std::vector<char> bytes;
        std::string message;
    };
    std::vector<Case> cases;
    cases.push_back({"empty", {}, "too short (0 bytes)"});
    std::vector<char> garbage(5000);
    for (std::size_t i = 0; i < garbage.size(); ++i) garbage[i] = static_cast<char>((i * 2654435761U) >> 13U);
    cases.push_back({"garbage", garbage, "not a hapticd recording (wrong magic"});
    std::vector<char> version = good;
    version[8] = 7;
    cases.push_back({"version", version, "format version 7 is not supported; accepted: 1 .. 2"});
    cases.push_back({"cut_mid_record", std::vector<char>(good.begin(), good.end() - 300),
                     "truncated: 84 bytes after the last whole"});
    cases.push_back({"cut_at_record", std::vector<char>(good.begin(), good.end() - 256), "truncated: no end record"});
    std::vector<char> flipped = good;
    flipped[header_size_of(good) + 3 * rec::kChunkSize + 30] ^= 0x10;
    cases.push_back({"flipped_bit", flipped, "corrupt: the records' checksum does not match"});
    std::vector<char> header = good;
    header[16] = 'x';
    cases.push_back({"header", header, "the header is not a JSON object"});
    std::vector<char> incomplete = good;
    rec::EndChunk end;
    std::memcpy(&end, incomplete.data() + incomplete.size() - rec::kChunkSize, sizeof end);
    end.complete = 0;
    end.dropped_ticks = 3;
    std::memcpy(incomplete.data() + incomplete.size() - rec::kChunkSize, &end, sizeof end);
    cases.push_back({"incomplete", incomplete, "incomplete: 3 tick and 0 batch records were dropped"});
    std::vector<char> status = good;  // intact (checksum resealed), but a device status no device returns
    status[tick_offset(status, 5) + 4] = 9;
    reseal(status);
    cases.push_back({"status", status,
                     "corrupt: tick 5 has device statuses 9, 0 and fault 0 (accepted: statuses 0 .. 7, fault 0 .. 3)"});
    std::vector<char> mesh = good;  // intact (resealed), its first update a client's mesh that names no mesh record
    for (std::size_t at = header_size_of(mesh); at + rec::kChunkSize <= mesh.size(); at += rec::kChunkSize) {
        rec::UpdateChunkA a;
        std::memcpy(&a, mesh.data() + at, sizeof a);
        if (a.kind != rec::kUpdateA) continue;
        a.object_kind = static_cast<std::uint8_t>(ObjectKind::Mesh);
        std::memcpy(mesh.data() + at, &a, sizeof a);
        break;
    }
    reseal(mesh);
    cases.push_back({"mesh", mesh, "update 0 of batch record 0 sets or moves a mesh object but names no mesh record"});
    for (const Case& c : cases) {
        const std::string file = (scratch() / ("bad_" + c.name + ".rec")).string();
        write_bytes(file, c.bytes);
        const Replay out = replay(file, "replay_bad_" + c.name);
        EXPECT_EQ(out.code, 10) << c.name << ": " << out.err;
        EXPECT_NE(out.err.find("recording '" + file + "': "), std::string::npos) << c.name << ": " << out.err;
        EXPECT_NE(out.err.find(c.message), std::string::npos) << c.name << ": " << out.err;
    }
    const Replay missing = replay((scratch() / "no_such.rec").string(), "replay_missing");
    EXPECT_EQ(missing.code, 10);
    EXPECT_NE(missing.err.find("cannot open"), std::string::npos) << missing.err;
    Child extra(HAPTICD_BINARY, {"--replay", recorded_run(), "--duration", "1"}, "replay_extra_option");
    EXPECT_EQ(extra.wait(), 2);
    EXPECT_NE(extra.err().find("only --quiet may be given with it (got '--duration')"), std::string::npos)
        << extra.err();
}

// A version-1 file (updates in two chunks, no mesh records) still replays: the plane session's recording with every
// update's third chunk taken out, the version word 1 and the checksum resealed (what the recorder wrote before the
// meshes were recorded, but for the header's layout, which --replay does not read).
TEST(RecordReplay, AVersion1RecordingStillReplays) {
    const std::vector<char> good = read_bytes(recorded_run());
    std::vector<char> v1(good.begin(), good.begin() + header_size_of(good));
    std::size_t dropped = 0;
    for (std::size_t at = header_size_of(good); at + rec::kChunkSize <= good.size(); at += rec::kChunkSize) {
        std::uint32_t kind = 0;
        std::memcpy(&kind, good.data() + at, 4);
        if (kind == rec::kUpdateC) {
            ++dropped;
            continue;
        }
        v1.insert(v1.end(), good.begin() + static_cast<long>(at),
                  good.begin() + static_cast<long>(at + rec::kChunkSize));
    }
    ASSERT_GT(dropped, 0U);
    const std::uint32_t version = 1;
    std::memcpy(v1.data() + 8, &version, 4);
    reseal(v1);
    const std::string file = (scratch() / "version1.rec").string();
    write_bytes(file, v1);
    const Recording r = read_recording(file);
    EXPECT_EQ(r.version, 1U);
    expect_replays_bit_for_bit(file, "replay_version1", r.ticks.size(), r.batches.size());
}

// The profile a recording was made with changed: the replay refuses (exit 10) rather than compare another scene.
TEST(RecordReplay, AChangedDeviceProfileIsRefused) {
    const std::string profile = (scratch() / "changing.toml").string();
    std::filesystem::copy_file(HAPTICD_SERVER_TEST_DIR + "/sim3.toml", profile,
                               std::filesystem::copy_options::overwrite_existing);
    const std::string file = (scratch() / "profile.rec").string();
    Child run(HAPTICD_BINARY,
              {"--config", "", "--device", profile, "--lockstep", "--duration", "0.2", "--quiet", "--record", file},
              "profile_record");
    ASSERT_EQ(run.wait(), 0) << run.err();
    const Replay same = replay(file, "profile_replay_same");
    EXPECT_EQ(same.code, 0) << same.err;
    std::ofstream(profile, std::ios::app) << "\n# changed\n";
    const Replay changed = replay(file, "profile_replay_changed");
    EXPECT_EQ(changed.code, 10) << changed.err;
    EXPECT_NE(changed.err.find("the device profile '" + profile + "' changed since the recording"), std::string::npos)
        << changed.err;
}

}  // namespace
}  // namespace hapticd::server_test

namespace hapticd::server_test {
namespace {

// A device that fails (the simulated one's fail_at_tick = 150): the run ends at tick 150 with exit 6; the
// recording holds the failing read's status, and the replay, whose playback device returns it at the same tick,
// reproduces the zero-force end: 151 ticks, identical.
TEST(RecordReplay, ADeviceFaultReplaysAtItsTick) {
    const std::string profile = (scratch() / "failing.toml").string();
    std::filesystem::copy_file(HAPTICD_SOURCE_CONFIG_DIR + "/devices/sim.toml", profile,
                               std::filesystem::copy_options::overwrite_existing);
    std::ofstream(profile, std::ios::app) << "\nfail_at_tick = 150\n";
    const std::string file = (scratch() / "failing.rec").string();
    Child run(HAPTICD_BINARY,
              {"--config", "", "--device", profile, "--lockstep", "--duration", "1", "--quiet", "--record", file},
              "failing_record");
    ASSERT_EQ(run.wait(), 6) << run.err();
    const Recording r = read_recording(file);
    ASSERT_EQ(r.ticks.size(), 151U);
    EXPECT_NE(r.ticks.back().read_status, 0U);
    EXPECT_EQ(r.ticks.back().fault, 1U);
    EXPECT_NE(r.ticks[100].force[0], 0.0);  // the step pressed the wall before the fault
    for (const double f : r.ticks.back().force) EXPECT_EQ(f, 0.0);
    const Replay out = replay(file, "failing_replay");
    EXPECT_EQ(out.code, 0) << out.err;
    EXPECT_NE(out.out.find("151 ticks, 0 batches: every force identical"), std::string::npos) << out.out;
}

}  // namespace
}  // namespace hapticd::server_test
