// SPDX-License-Identifier: Apache-2.0
// The layout of a hapticd recording (`hapticd --record FILE`, docs/recording.md): a header, then a stream of
// 128-byte chunks, each starting with a little-endian u32 kind, in the order the loop produced them:
//   header   bytes 0..7 magic "HAPTREC\0", 8..11 u32 format version, 12..15 u32 header size H (a multiple of
//            128, >= 128); bytes 16..H-1 a UTF-8 JSON object padded with spaces (docs/recording.md lists its keys)
//   tick     (kind 1) one per tick, after the batches that tick took
//   batch    (kind 2) one batch the loop took from a ring at the start of its tick, followed by `count` update
//            records: in version 2 three chunks each (kinds 3, 4, 6: one SlotUpdate in three parts), in version 1
//            two (kinds 3, 4)
//   mesh     (kind 7, version 2) a client's mesh, before the first batch that renders it: its id, mode and
//            counts, followed by its vertices (kind 8, 5 a chunk) and triangles (kind 9, 10 a chunk)
//   end      (kind 5) the last chunk: counts, the drops, and the FNV-1a 64 checksum of every chunk before it
// All integers and doubles little-endian (the writer is the daemon's own memory layout; the static_asserts
// below pin the offsets, and recording.cpp refuses a big-endian host).
#pragma once

#include <cstddef>
#include <cstdint>

namespace hapticd::recording {

inline constexpr char kMagic[8] = {'H', 'A', 'P', 'T', 'R', 'E', 'C', '\0'};
// Version 2 adds the third update part (a mesh object's mesh, orientation and friction) and the mesh records;
// readers accept versions kOldestFormatVersion .. kFormatVersion (a version-1 file has neither).
inline constexpr std::uint32_t kFormatVersion = 2;
inline constexpr std::uint32_t kOldestFormatVersion = 1;
inline constexpr std::size_t kChunkSize = 128;

enum ChunkKind : std::uint32_t {
    kTick = 1,
    kBatch = 2,
    kUpdateA = 3,
    kUpdateB = 4,
    kEnd = 5,
    kUpdateC = 6,        // version 2
    kMesh = 7,           // version 2
    kMeshVertices = 8,   // version 2
    kMeshTriangles = 9,  // version 2
};

// What a mesh's data chunks hold: 120 bytes after the kind and count words.
inline constexpr std::uint32_t kVerticesPerChunk = 5;    // 15 doubles
inline constexpr std::uint32_t kTrianglesPerChunk = 10;  // 30 u32 indices

// Which ring the loop took a batch from (SceneObjects::apply_commits).
enum BatchSource : std::uint8_t {
    kFromCommitRing = 0,  // the clients' batches, applied (or held until the ramps in progress end)
    kFromDepartures = 1,  // a departure (a client that left), taken ahead of the others
    kJumpedAhead = 2,     // a batch of the commit ring applied at once ahead of a departure (take_departures)
};

struct TickChunk {
    std::uint32_t kind = kTick;
    std::uint8_t read_status = 0;   // DeviceStatus of read_position (0 Ok)
    std::uint8_t write_status = 0;  // DeviceStatus of write_force (0 Ok)
    std::uint8_t fault = 0;         // the protocol's fault numbers: 0 none, 1 device, 2 non-finite, 3 watchdog
    std::uint8_t gain_row = 0;      // --retune: the config walls' row from the next tick on (0 held, 1 released)
    std::uint64_t tick = 0;
    double time_s = 0.0;  // the tick's scheduled time since the loop started, s (period x slot: skipped periods count)
    double position[3] = {};                // m (rad), as read from the device
    double velocity[3] = {};                // m/s, the objects' backward difference (0 without --serve)
    double force[3] = {};                   // N (N m), the force written to the device in this tick
    std::uint64_t contact_mask = 0;         // bit s: client object in slot s in contact (SceneObjects::contact_mask)
    std::uint64_t config_contact_mask = 0;  // bit i: config wall i in contact (Scene::contact_mask)
    std::int64_t wake_latency_ns = 0;       // wake-up less the deadline (0 in lockstep)
    std::uint32_t batches = 0;              // batch chunks of this tick (they precede it)
    std::uint32_t reserved1 = 0;
};

struct BatchChunk {
    std::uint32_t kind = kBatch;
    std::uint8_t source = kFromCommitRing;  // BatchSource
    std::uint8_t reserved0[3] = {};
    std::uint64_t tick = 0;   // the tick whose apply_commits took it
    std::uint64_t seq = 0;    // the server's batch sequence number
    std::uint32_t count = 0;  // updates (each two chunks) that follow
    std::uint32_t index = 0;  // its place among the batches of its tick (0, 1, ...)
    std::uint8_t reserved1[96] = {};
};

// The first half of a SlotUpdate (scene/scene_objects.hpp: SlotUpdate, ObjectParams).
struct UpdateChunkA {
    std::uint32_t kind = kUpdateA;
    std::uint8_t slot = 0;
    std::uint8_t action = 0;       // SlotUpdate::Action: 0 Set, 1 Move, 2 Remove, 3 Cut
    std::uint8_t object_kind = 0;  // ObjectKind: 0 plane, 1 spring, 2 field
    std::uint8_t bilateral = 0;
    std::uint8_t constraint = 0;  // SpringConstraint: 0 point, 1 line, 2 plane
    std::uint8_t reserved0[3] = {};
    std::uint32_t id = 0;
    double direction[3] = {};
    double offset = 0.0;
    double point[3] = {};
    double radius = 0.0;
    double force[3] = {};
    double K = 0.0;
    double B = 0.0;
    double offset_rate = 0.0;
};

// The second half.
struct UpdateChunkB {
    std::uint32_t kind = kUpdateB;
    std::uint32_t reserved0 = 0;
    double jacobian[9] = {};  // rows
    double point_rate[3] = {};
    std::uint8_t reserved1[24] = {};
};

// The third part (version 2): what only a mesh object has (ObjectParams: mesh_id, orientation, friction, shading).
struct UpdateChunkC {
    std::uint32_t kind = kUpdateC;
    std::uint32_t mesh = 0;                        // the mesh record's id (0: none, every kind but a mesh)
    double orientation[4] = {1.0, 0.0, 0.0, 0.0};  // unit quaternion w, x, y, z
    double static_friction = 0.0;
    double dynamic_friction = 0.0;
    // Force shading (ObjectParams::crease_angle_deg): 1 on, with the crease angle in degrees; 0 off. Version-2 files
    // written before it hold zeros here (reserved): off, as they were rendered.
    std::uint32_t shading = 0;
    std::uint32_t reserved0 = 0;
    double crease_angle_deg = 0.0;
    std::uint8_t reserved[56] = {};
};

// A client's mesh (version 2), written once, before the first batch that renders it; followed by
// ceil(vertices / 5) vertex chunks and ceil(triangles / 10) triangle chunks.
struct MeshChunk {
    std::uint32_t kind = kMesh;
    std::uint8_t mode = 0;  // mesh::MeshMode: 0 surface, 1 solid
    std::uint8_t reserved0[3] = {};
    std::uint32_t mesh = 0;  // its id (the server's: ObjectParams::mesh_id), 1 .. 2^32-1
    std::uint32_t reserved1 = 0;
    std::uint64_t vertices = 0;
    std::uint64_t triangles = 0;
    std::uint8_t reserved2[96] = {};
};

struct MeshVerticesChunk {
    std::uint32_t kind = kMeshVertices;
    std::uint32_t count = 0;                 // vertices in this chunk: 5, the last one 1 .. 5
    double xyz[3 * kVerticesPerChunk] = {};  // m, in the mesh's frame
};

struct MeshTrianglesChunk {
    std::uint32_t kind = kMeshTriangles;
    std::uint32_t count = 0;                             // triangles in this chunk: 10, the last one 1 .. 10
    std::uint32_t indices[3 * kTrianglesPerChunk] = {};  // vertex indices, (a, b, c) per triangle
};

struct EndChunk {
    std::uint32_t kind = kEnd;
    std::uint32_t complete = 0;         // 1: no record was dropped and every write succeeded
    std::uint64_t ticks = 0;            // tick chunks written
    std::uint64_t batches = 0;          // batch chunks written
    std::uint64_t updates = 0;          // update pairs written
    std::uint64_t dropped_ticks = 0;    // tick records dropped (ring full, real-time mode)
    std::uint64_t dropped_batches = 0;  // batch records dropped
    std::uint64_t checksum = 0;         // FNV-1a 64 of every chunk before this one
    std::uint64_t meshes = 0;           // mesh records written (version 2)
    std::uint8_t reserved[64] = {};
};

static_assert(sizeof(TickChunk) == kChunkSize && offsetof(TickChunk, tick) == 8 &&
              offsetof(TickChunk, position) == 24 && offsetof(TickChunk, velocity) == 48 &&
              offsetof(TickChunk, force) == 72 && offsetof(TickChunk, contact_mask) == 96 &&
              offsetof(TickChunk, config_contact_mask) == 104 && offsetof(TickChunk, wake_latency_ns) == 112 &&
              offsetof(TickChunk, batches) == 120);
static_assert(sizeof(BatchChunk) == kChunkSize && offsetof(BatchChunk, tick) == 8 && offsetof(BatchChunk, seq) == 16 &&
              offsetof(BatchChunk, count) == 24 && offsetof(BatchChunk, index) == 28);
static_assert(sizeof(UpdateChunkA) == kChunkSize && offsetof(UpdateChunkA, id) == 12 &&
              offsetof(UpdateChunkA, direction) == 16 && offsetof(UpdateChunkA, offset) == 40 &&
              offsetof(UpdateChunkA, point) == 48 && offsetof(UpdateChunkA, radius) == 72 &&
              offsetof(UpdateChunkA, force) == 80 && offsetof(UpdateChunkA, K) == 104 &&
              offsetof(UpdateChunkA, offset_rate) == 120);
static_assert(sizeof(UpdateChunkB) == kChunkSize && offsetof(UpdateChunkB, jacobian) == 8 &&
              offsetof(UpdateChunkB, point_rate) == 80);
static_assert(sizeof(EndChunk) == kChunkSize && offsetof(EndChunk, ticks) == 8 && offsetof(EndChunk, checksum) == 48 &&
              offsetof(EndChunk, meshes) == 56);
static_assert(sizeof(UpdateChunkC) == kChunkSize && offsetof(UpdateChunkC, mesh) == 4 &&
              offsetof(UpdateChunkC, orientation) == 8 && offsetof(UpdateChunkC, static_friction) == 40 &&
              offsetof(UpdateChunkC, dynamic_friction) == 48 && offsetof(UpdateChunkC, shading) == 56 &&
              offsetof(UpdateChunkC, crease_angle_deg) == 64);
static_assert(sizeof(MeshChunk) == kChunkSize && offsetof(MeshChunk, mode) == 4 && offsetof(MeshChunk, mesh) == 8 &&
              offsetof(MeshChunk, vertices) == 16 && offsetof(MeshChunk, triangles) == 24);
static_assert(sizeof(MeshVerticesChunk) == kChunkSize && offsetof(MeshVerticesChunk, count) == 4 &&
              offsetof(MeshVerticesChunk, xyz) == 8);
static_assert(sizeof(MeshTrianglesChunk) == kChunkSize && offsetof(MeshTrianglesChunk, count) == 4 &&
              offsetof(MeshTrianglesChunk, indices) == 8);

// FNV-1a 64 (Fowler, Noll, Vo: offset basis 14695981039346656037, prime 1099511628211), continued from `h`.
[[nodiscard]] inline std::uint64_t fnv1a64(const void* data, std::size_t size,
                                           std::uint64_t h = 14695981039346656037ULL) noexcept {
    const auto* p = static_cast<const unsigned char*>(data);
    for (std::size_t i = 0; i < size; ++i) {
        h ^= p[i];
        h *= 1099511628211ULL;
    }
    return h;
}

}  // namespace hapticd::recording
