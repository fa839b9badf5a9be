// SPDX-License-Identifier: Apache-2.0
#include "daemon/recording_reader.hpp"

#include <algorithm>
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

std::uint32_t kind_at(const std::vector<char>& bytes, std::size_t offset) {
    std::uint32_t kind = 0;
    std::memcpy(&kind, bytes.data() + offset, 4);
    return kind;
}

std::size_t chunks_for(std::uint64_t items, std::uint32_t per_chunk) {
    return static_cast<std::size_t>((items + per_chunk - 1) / per_chunk);
}

// The mesh record at chunk i (version 2): checked, validated with mesh_error under the protocol's limits
// (docs/protocol.md, section 4a; mesh::MeshLimits are the server's MeshStoreLimits) and built as the server's
// worker builds it. `chunks`: the chunks before the end chunk. Returns the chunks it spans.
std::size_t read_mesh(const std::vector<char>& bytes, std::size_t header_size, std::size_t i, std::size_t chunks,
                      Recording& r) {
    using namespace recording;
    const std::string& path = r.path;
    const std::size_t at = header_size + i * kChunkSize;
    const auto m = chunk_at<MeshChunk>(bytes, at);
    const std::string name = "mesh record " + std::to_string(i) + " (mesh " + std::to_string(m.mesh) + ")";
    const mesh::MeshLimits limits{};
    if (m.mesh == 0 || m.mode > 1 || m.vertices < 3 || m.vertices > limits.max_vertices || m.triangles < 1 ||
        m.triangles > limits.max_triangles) {
        bad(path, "corrupt: " + name + " has mode " + std::to_string(m.mode) + ", " + std::to_string(m.vertices) +
                      " vertices and " + std::to_string(m.triangles) +
                      " triangles (accepted: mesh id 1 .. 2^32-1, mode " + "0 surface or 1 solid, 3 .. " +
                      std::to_string(limits.max_vertices) + " vertices, 1 .. " + std::to_string(limits.max_triangles) +
                      " triangles: the protocol's limits)");
    }
    if (r.meshes.count(m.mesh) != 0) bad(path, "corrupt: " + name + " repeats the id of an earlier mesh record");
    const std::size_t nv = chunks_for(m.vertices, kVerticesPerChunk);
    const std::size_t nt = chunks_for(m.triangles, kTrianglesPerChunk);
    if (i + 1 + nv + nt > chunks) {
        bad(path, "corrupt: " + name + " announces " + std::to_string(nv) + " vertex and " + std::to_string(nt) +
                      " triangle chunks; only " + std::to_string(chunks - i - 1) + " chunks follow it");
    }
    mesh::TriangleMesh data;
    data.vertices.reserve(static_cast<std::size_t>(m.vertices));
    data.triangles.reserve(static_cast<std::size_t>(m.triangles));
    for (std::size_t k = 0; k < nv; ++k) {
        const std::size_t c_at = at + (1 + k) * kChunkSize;
        const auto c = chunk_at<MeshVerticesChunk>(bytes, c_at);
        const std::uint64_t expected = std::min<std::uint64_t>(kVerticesPerChunk, m.vertices - k * kVerticesPerChunk);
        if (c.kind != kMeshVertices || c.count != expected) {
            bad(path, "corrupt: chunk " + std::to_string(k) + " after " + name + " has kind " + std::to_string(c.kind) +
                          " and count " + std::to_string(c.count) + "; expected the mesh's vertices (kind 8, count " +
                          std::to_string(expected) + ")");
        }
        for (std::uint32_t v = 0; v < c.count; ++v)
            data.vertices.emplace_back(c.xyz[3 * v], c.xyz[3 * v + 1], c.xyz[3 * v + 2]);
    }
    for (std::size_t k = 0; k < nt; ++k) {
        const std::size_t c_at = at + (1 + nv + k) * kChunkSize;
        const auto c = chunk_at<MeshTrianglesChunk>(bytes, c_at);
        const std::uint64_t expected =
            std::min<std::uint64_t>(kTrianglesPerChunk, m.triangles - k * kTrianglesPerChunk);
        if (c.kind != kMeshTriangles || c.count != expected) {
            bad(path, "corrupt: chunk " + std::to_string(nv + k) + " after " + name + " has kind " +
                          std::to_string(c.kind) + " and count " + std::to_string(c.count) +
                          "; expected the mesh's triangles (kind 9, count " + std::to_string(expected) + ")");
        }
        for (std::uint32_t t = 0; t < c.count; ++t)
            data.triangles.push_back({c.indices[3 * t], c.indices[3 * t + 1], c.indices[3 * t + 2]});
    }
    const mesh::MeshMode mode = m.mode == 1 ? mesh::MeshMode::solid : mesh::MeshMode::surface;
    if (const std::optional<std::string> why = mesh::mesh_error(data, mode, limits)) {
        bad(path, "corrupt: " + name + " (" + (m.mode == 1 ? "solid" : "surface") + ") is invalid: " + *why);
    }
    try {
        r.meshes.emplace(m.mesh, mesh::MeshHierarchy::build(std::move(data), mode));
    } catch (const std::exception& e) {
        bad(path, name + ": building its hierarchy failed: " + e.what());
    }
    return 1 + nv + nt;
}

}  // namespace

Recording read_recording(const std::string& path) {
    std::ifstream in(path, std::ios::binary);
    if (!in) bad(path, std::string("cannot open: ") + std::strerror(errno));
    const std::vector<char> bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    if (in.bad()) bad(path, "read error");
    return parse_recording(path, bytes);
}

Recording parse_recording(const std::string& path, const std::vector<char>& bytes) {
    using namespace recording;
    Recording r;
    r.path = path;
    if (bytes.size() < 16)
        bad(path, "too short (" + std::to_string(bytes.size()) + " bytes) to be a hapticd recording");
    if (std::memcmp(bytes.data(), kMagic, 8) != 0)
        bad(path, "not a hapticd recording (wrong magic: the file must start with \"HAPTREC\\0\")");
    std::uint32_t header_size = 0;
    std::memcpy(&r.version, bytes.data() + 8, 4);
    std::memcpy(&header_size, bytes.data() + 12, 4);
    if (r.version < kOldestFormatVersion || r.version > kFormatVersion) {
        bad(path, "format version " + std::to_string(r.version) + " is not supported; accepted: " +
                      std::to_string(kOldestFormatVersion) + " .. " + std::to_string(kFormatVersion));
    }
    const bool v2 = r.version >= 2;
    const std::size_t parts = v2 ? 3 : 2;  // chunks per update
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
    if (!v2) r.end.meshes = 0;  // reserved bytes in version 1
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
        const std::uint32_t kind = kind_at(bytes, at);
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
        } else if (kind == kMesh && v2) {
            i += read_mesh(bytes, header_size, i, chunks - 1, r) - 1;
        } else if (kind == kBatch) {
            const auto b = chunk_at<BatchChunk>(bytes, at);
            if (b.count > kSceneObjectCapacity || b.source > kJumpedAhead || i + parts * b.count + 1 >= chunks) {
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
                const std::size_t a_at = at + (1 + parts * u) * kChunkSize;
                const auto a = chunk_at<UpdateChunkA>(bytes, a_at);
                const auto bb = chunk_at<UpdateChunkB>(bytes, a_at + kChunkSize);
                const UpdateChunkC cc = v2 ? chunk_at<UpdateChunkC>(bytes, a_at + 2 * kChunkSize) : UpdateChunkC{};
                const std::string which = "update " + std::to_string(u) + " of batch record " + std::to_string(i);
                if (!v2 && a.kind == kUpdateA && a.object_kind == static_cast<std::uint8_t>(ObjectKind::Mesh)) {
                    bad(path, which +
                                  " is a client's mesh, which a version-1 recording does not hold (its triangles "
                                  "came through the mesh upload, not the batch); accepted: version-1 recordings of "
                                  "planes, springs and fields (docs/recording.md, \"Limits\")");
                }
                if (a.kind != kUpdateA || bb.kind != kUpdateB || cc.kind != kUpdateC ||
                    a.slot >= kSceneObjectCapacity || a.action > 3 || a.object_kind > 3 || a.constraint > 2) {
                    bad(path, "corrupt: " + which + " is invalid");
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
                for (std::size_t k = 0; k < 4; ++k) p.orientation[k] = cc.orientation[k];
                p.static_friction = cc.static_friction;
                p.dynamic_friction = cc.dynamic_friction;
                if (v2 && p.kind == ObjectKind::Mesh && cc.mesh == 0 && a.action <= 1) {
                    bad(path, "corrupt: " + which + " sets or moves a mesh object but names no mesh record");
                }
                if (cc.mesh != 0) {
                    const auto found = r.meshes.find(cc.mesh);
                    if (p.kind != ObjectKind::Mesh || found == r.meshes.end()) {
                        bad(path, "corrupt: " + which + " names mesh " + std::to_string(cc.mesh) +
                                      (p.kind != ObjectKind::Mesh ? " but is not a mesh object"
                                                                  : ", which no mesh record before it holds"));
                    }
                    p.mesh = found->second.get();
                    p.mesh_id = cc.mesh;
                }
                if (cc.shading != 0) {
                    if (p.mesh == nullptr ||
                        !(cc.crease_angle_deg >= 0.0 && cc.crease_angle_deg <= mesh::kMaxCreaseAngleDeg)) {
                        bad(path, "corrupt: " + which + " shades with crease angle " +
                                      std::to_string(cc.crease_angle_deg) +
                                      " deg (accepted: 0 .. 80, on a mesh object)");
                    }
                    p.crease_angle_deg = cc.crease_angle_deg;
                    p.shading = p.mesh->shading(cc.crease_angle_deg);
                    if (p.shading == nullptr) {
                        bad(path, "corrupt: " + which + " shades mesh " + std::to_string(cc.mesh) +
                                      " with more crease angles than a mesh keeps");
                    }
                }
                rb.updates.push_back(s);
                ++updates;
            }
            r.batches.push_back(std::move(rb));
            i += parts * b.count;
        } else {
            bad(path, "corrupt: record " + std::to_string(i) + " has kind " + std::to_string(kind) +
                          (v2 ? " (accepted: 1 tick, 2 batch, 7 mesh)" : " (accepted: 1 tick, 2 batch)"));
        }
    }
    if (r.ticks.size() != r.end.ticks || r.batches.size() != r.end.batches || updates != r.end.updates ||
        r.meshes.size() != r.end.meshes) {
        bad(path, "corrupt: " + std::to_string(r.ticks.size()) + " ticks, " + std::to_string(r.batches.size()) +
                      " batches, " + std::to_string(updates) + " updates and " + std::to_string(r.meshes.size()) +
                      " meshes found; the end record counts " + std::to_string(r.end.ticks) + ", " +
                      std::to_string(r.end.batches) + ", " + std::to_string(r.end.updates) + " and " +
                      std::to_string(r.end.meshes));
    }
    if (r.ticks.empty()) bad(path, "holds no tick: nothing to replay");
    return r;
}

}  // namespace hapticd
