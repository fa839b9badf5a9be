// SPDX-License-Identifier: Apache-2.0
#include "daemon/recording_reader.hpp"

#include <cerrno>
#include <cstring>
#include <fstream>
#include <iterator>

#include "hapticd/state_layout.hpp"

namespace hapticd {

namespace {

[[noreturn]] void bad(const std::string& path, const std::string& what) {
    throw RecordingError("recording '" + path + "': " + what);
}

template <class Chunk>
Chunk chunk_at(const std::vector<char>& bytes, std::size_t offset) {
    Chunk c;
    std::memcpy(&c, bytes.data() + offset, sizeof c);
    return c;
}

}  // namespace

Recording read_recording(const std::string& path) {
    using namespace recording;
    std::ifstream in(path, std::ios::binary);
    if (!in) bad(path, std::string("cannot open: ") + std::strerror(errno));
    std::vector<char> bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    if (in.bad()) bad(path, "read error");
    Recording r;
    r.path = path;
    if (bytes.size() < 16)
        bad(path, "too short (" + std::to_string(bytes.size()) + " bytes) to be a hapticd recording");
    if (std::memcmp(bytes.data(), kMagic, 8) != 0)
        bad(path, "not a hapticd recording (wrong magic: the file must start with \"HAPTREC\\0\")");
    std::uint32_t header_size = 0;
    std::memcpy(&r.version, bytes.data() + 8, 4);
    std::memcpy(&header_size, bytes.data() + 12, 4);
    if (r.version != kFormatVersion) {
        bad(path, "format version " + std::to_string(r.version) +
                      " is not supported; accepted: " + std::to_string(kFormatVersion));
    }
    if (header_size < kChunkSize || header_size % kChunkSize != 0 || header_size > bytes.size()) {
        bad(path, "header size " + std::to_string(header_size) + " is invalid (a multiple of " +
                      std::to_string(kChunkSize) + " within the file's " + std::to_string(bytes.size()) +
                      " bytes): truncated or corrupt");
    }
    r.header = nlohmann::json::parse(bytes.begin() + 16, bytes.begin() + header_size, nullptr, false);
    if (!r.header.is_object()) bad(path, "the header is not a JSON object: corrupt");
    const std::size_t body = bytes.size() - header_size;
    if (body % kChunkSize != 0) {
        bad(path, "truncated: " + std::to_string(body % kChunkSize) + " bytes after the last whole " +
                      std::to_string(kChunkSize) + "-byte record");
    }
    const std::size_t chunks = body / kChunkSize;
    if (chunks == 0 || chunk_at<EndChunk>(bytes, bytes.size() - kChunkSize).kind != kEnd) {
        bad(path, "truncated: no end record (the recording was cut off before hapticd closed it)");
    }
    r.end = chunk_at<EndChunk>(bytes, bytes.size() - kChunkSize);
    const std::uint64_t checksum = fnv1a64(bytes.data() + header_size, body - kChunkSize);
    if (checksum != r.end.checksum) bad(path, "corrupt: the records' checksum does not match the end record's");
    if (r.end.complete != 1) {
        bad(path, "incomplete: " + std::to_string(r.end.dropped_ticks) + " tick and " +
                      std::to_string(r.end.dropped_batches) +
                      " batch records were dropped (recorder ring full) or a write failed; a replay needs every record "
                      "(record with --lockstep, or raise --record-capacity)");
    }

    std::uint64_t updates = 0;
    for (std::size_t i = 0; i + 1 < chunks; ++i) {
        const std::size_t at = header_size + i * kChunkSize;
        std::uint32_t kind = 0;
        std::memcpy(&kind, bytes.data() + at, 4);
        if (kind == kTick) {
            const auto t = chunk_at<TickChunk>(bytes, at);
            // DeviceStatus runs 0 .. 7 (devices/device.hpp), the protocol's fault numbers 0 .. 3.
            if (t.read_status > 7 || t.write_status > 7 || t.fault > static_cast<std::uint8_t>(StateFault::Watchdog)) {
                bad(path, "corrupt: tick " + std::to_string(t.tick) + " has device statuses " +
                              std::to_string(t.read_status) + ", " + std::to_string(t.write_status) + " and fault " +
                              std::to_string(t.fault) + " (accepted: statuses 0 .. 7, fault 0 .. 3)");
            }
            if (t.tick != r.ticks.size()) {
                bad(path, "corrupt: record " + std::to_string(i) + " is tick " + std::to_string(t.tick) +
                              ", expected tick " + std::to_string(r.ticks.size()));
            }
            r.ticks.push_back(t);
        } else if (kind == kBatch) {
            const auto b = chunk_at<BatchChunk>(bytes, at);
            if (b.count > kSceneObjectCapacity || b.source > kJumpedAhead || i + 2 * b.count + 1 >= chunks) {
                bad(path, "corrupt: batch record " + std::to_string(i) + " (count " + std::to_string(b.count) +
                              ", source " + std::to_string(b.source) + ") is invalid or its updates are missing");
            }
            if (b.tick != r.ticks.size()) {
                bad(path, "corrupt: batch record " + std::to_string(i) + " names tick " + std::to_string(b.tick) +
                              " before tick " + std::to_string(r.ticks.size()));
            }
            RecordedBatch rb;
            rb.tick = b.tick;
            rb.index = b.index;
            rb.source = static_cast<CommitSource>(b.source);
            rb.seq = b.seq;
            for (std::uint32_t u = 0; u < b.count; ++u) {
                const std::size_t a_at = at + (1 + 2 * u) * kChunkSize;
                const auto a = chunk_at<UpdateChunkA>(bytes, a_at);
                const auto bb = chunk_at<UpdateChunkB>(bytes, a_at + kChunkSize);
                if (a.kind == kUpdateA && a.object_kind == static_cast<std::uint8_t>(ObjectKind::Mesh)) {
                    bad(path, "update " + std::to_string(u) + " of batch record " + std::to_string(i) +
                                  " is a client's mesh, which a recording does not hold (its triangles came through "
                                  "the mesh upload, not the batch); accepted: recordings of planes, springs and "
                                  "fields (docs/recording.md, \"Limits\")");
                }
                if (a.kind != kUpdateA || bb.kind != kUpdateB || a.slot >= kSceneObjectCapacity || a.action > 3 ||
                    a.object_kind > 2 || a.constraint > 2) {
                    bad(path, "corrupt: update " + std::to_string(u) + " of batch record " + std::to_string(i) +
                                  " is invalid");
                }
                SlotUpdate s;
                s.slot = a.slot;
                s.action = static_cast<SlotUpdate::Action>(a.action);
                ObjectParams& p = s.params;
                p.id = a.id;
                p.kind = static_cast<ObjectKind>(a.object_kind);
                p.bilateral = a.bilateral != 0;
                p.constraint = static_cast<SpringConstraint>(a.constraint);
                for (std::size_t k = 0; k < 3; ++k) {
                    p.direction[k] = a.direction[k];
                    p.point[k] = a.point[k];
                    p.force[k] = a.force[k];
                    p.point_rate[k] = bb.point_rate[k];
                    for (std::size_t c = 0; c < 3; ++c) p.jacobian[k][c] = bb.jacobian[3 * k + c];
                }
                p.offset = a.offset;
                p.radius = a.radius;
                p.K = a.K;
                p.B = a.B;
                p.offset_rate = a.offset_rate;
                rb.updates.push_back(s);
                ++updates;
            }
            r.batches.push_back(std::move(rb));
            i += 2 * b.count;
        } else {
            bad(path, "corrupt: record " + std::to_string(i) + " has kind " + std::to_string(kind) +
                          " (accepted: 1 tick, 2 batch)");
        }
    }
    if (r.ticks.size() != r.end.ticks || r.batches.size() != r.end.batches || updates != r.end.updates) {
        bad(path, "corrupt: " + std::to_string(r.ticks.size()) + " ticks, " + std::to_string(r.batches.size()) +
                      " batches and " + std::to_string(updates) + " updates found; the end record counts " +
                      std::to_string(r.end.ticks) + ", " + std::to_string(r.end.batches) + " and " +
                      std::to_string(r.end.updates));
    }
    if (r.ticks.empty()) bad(path, "holds no tick: nothing to replay");
    return r;
}

}  // namespace hapticd
