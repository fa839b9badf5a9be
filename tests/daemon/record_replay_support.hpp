// SPDX-License-Identifier: Apache-2.0
// What the --record / --replay process tests share (test_record_replay.cpp, test_record_replay_meshes.cpp): the
// file's bytes, the end chunk's checksum resealed after a change, a replay run as a process, and waiting for the
// lockstep loop's state.
#pragma once

#include <cstring>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

#include "common/test_paths.hpp"
#include "daemon/recording_format.hpp"
#include "daemon/recording_reader.hpp"
#include "../server/server_fixture.hpp"

namespace hapticd::server_test {

namespace rec = hapticd::recording;

inline std::vector<char> read_bytes(const std::string& path) {
    std::ifstream in(path, std::ios::binary);
    return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

inline void write_bytes(const std::string& path, const std::vector<char>& bytes) {
    std::ofstream out(path, std::ios::binary | std::ios::trunc);
    out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
}

inline std::uint32_t header_size_of(const std::vector<char>& bytes) {
    std::uint32_t h = 0;
    std::memcpy(&h, bytes.data() + 12, 4);
    return h;
}

// The end chunk's checksum recomputed over the (changed) chunks: a recording whose content differs although
// the file is intact, e.g. made by another build.
inline void reseal(std::vector<char>& bytes) {
    const std::uint32_t h = header_size_of(bytes);
    if (bytes.size() < std::size_t{h} + rec::kChunkSize) return;  // no end chunk to reseal
    const std::size_t end_at = bytes.size() - rec::kChunkSize;
    rec::EndChunk end;
    std::memcpy(&end, bytes.data() + end_at, sizeof end);
    end.checksum = rec::fnv1a64(bytes.data() + h, end_at - h);
    std::memcpy(bytes.data() + end_at, &end, sizeof end);
}

// The byte offset of tick `tick`'s chunk.
inline std::size_t tick_offset(const std::vector<char>& bytes, std::uint64_t tick) {
    for (std::size_t at = header_size_of(bytes); at + rec::kChunkSize <= bytes.size(); at += rec::kChunkSize) {
        rec::TickChunk t;
        std::memcpy(&t, bytes.data() + at, sizeof t);
        if (t.kind == rec::kTick && t.tick == tick) return at;
    }
    return 0;
}

struct Replay {
    int code = -1;
    std::string out, err;
};

inline Replay replay(const std::string& file, const std::string& tag) {
    Child r(HAPTICD_BINARY, {"--replay", file}, tag);
    Replay result;
    result.code = r.wait(std::chrono::seconds(300));
    result.out = r.out();
    result.err = r.err();
    return result;
}

// `hapticd --replay file` exits 0 and reports every force of the recording's `ticks` and `batches` identical.
inline void expect_replays_bit_for_bit(const std::string& file, const std::string& tag, std::size_t ticks,
                                       std::size_t batches) {
    const Replay out = replay(file, tag);
    ASSERT_EQ(out.code, 0) << out.err;
    EXPECT_NE(out.out.find(std::to_string(ticks) + " ticks, " + std::to_string(batches) +
                           " batches: every force identical to the recording (bit for bit)"),
              std::string::npos)
        << out.out;
}

// Reads the state until `done` holds for a sample (the loop runs on in lockstep meanwhile).
template <class Done>
inline cl::StateSample wait_state(const cl::StateReader& state, Done done) {
    cl::StateSample s;
    const double end = monotonic_s() + 120.0;
    while (monotonic_s() < end) {
        if (state.read(s) && done(s)) return s;
        std::this_thread::sleep_for(std::chrono::microseconds(50));
    }
    ADD_FAILURE() << "the daemon's state did not reach the awaited condition in 120 s";
    return s;
}

// After the client left: waits until its objects are gone and 100 ticks more are recorded, then stops the daemon
// (SIGTERM) and expects exit 0.
inline void stop_after_the_client_left(const cl::StateReader& state, Child& daemon) {
    const cl::StateSample gone = wait_state(state, [](const cl::StateSample& s) { return s.objects == 0; });
    wait_state(state, [&](const cl::StateSample& s) { return s.tick >= gone.tick + 100; });
    daemon.signal(SIGTERM);
    EXPECT_EQ(daemon.wait(std::chrono::seconds(120)), 0) << daemon.err();
}

}  // namespace hapticd::server_test
