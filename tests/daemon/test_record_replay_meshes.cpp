// SPDX-License-Identifier: Apache-2.0
// --record and --replay of a session with a client's mesh (docs/recording.md, "Meshes"): hapticd --serve in
// lockstep on the 3-axis simulated device (tests/server/sim3.toml, the simulated hand at rest holding the handle
// at the origin with its spring); a client uploads a solid box (8 vertices, 12 triangles: two vertex and two
// triangle chunks, the second of each partly filled) and a surface it never renders, adds the box beside the
// handle, moves it (position and orientation) until the handle is inside its outline (the proxy holds it on the
// face), removes it and leaves. The replay must reproduce every force bit for bit; the file holds the rendered
// mesh only, exactly as uploaded; broken mesh records end with exit code 10 and a message naming the file and
// the defect, never a crash.
#include <cmath>
#include <cstring>
#include <limits>

#include "common/test_paths.hpp"
#include "record_replay_support.hpp"

namespace hapticd::server_test::record_meshes {

constexpr double kHalf = 0.01;  // m: the box [-a, a]^3

std::vector<cl::Vec3> box_vertices() {
    std::vector<cl::Vec3> v;
    for (int i = 0; i < 8; ++i)
        v.push_back({(i & 1) ? kHalf : -kHalf, (i & 2) ? kHalf : -kHalf, (i & 4) ? kHalf : -kHalf});
    return v;
}

// Wound with outward normals (b - a) x (c - a) (tests/server/test_server_meshes.cpp: box).
std::vector<std::array<std::uint32_t, 3>> box_triangles() {
    return {{0, 2, 1}, {1, 2, 3}, {4, 5, 6}, {5, 7, 6}, {0, 1, 4}, {1, 5, 4},
            {2, 6, 3}, {3, 6, 7}, {0, 4, 2}, {2, 4, 6}, {1, 3, 5}, {3, 7, 5}};
}

struct MeshRun {
    std::string file;
    std::uint32_t box = 0;      // the rendered mesh's id
    std::uint32_t surface = 0;  // uploaded, never rendered
};

// The box at y = `y` (its face y = y - a toward the handle), turned by `angle` about z.
cl::Mesh box_at(std::uint32_t mesh, double y, double angle) {
    return cl::Mesh{.mesh = mesh,
                    .position = {0.0, y, 0.0},
                    .orientation = {std::cos(angle / 2), 0.0, 0.0, std::sin(angle / 2)},
                    .gains = cl::Gains::explicit_gains(2000.0, 2.0),  // N/m, N s/m: stable beside the config wall
                    .static_friction = 0.4,
                    .dynamic_friction = 0.3,
                    .shading_crease_angle_deg = 30.0};  // a box's faces stay flat at 30 deg: recorded, not visible
}

// Made once. Each step waits kGap ticks of the loop after its batch is applied (the state's counters).
const MeshRun& mesh_run() {
    static const MeshRun run = [] {
        constexpr std::uint64_t kGap = 300;
        MeshRun out;
        const Names n = names("record_mesh");
        out.file = (scratch() / "mesh_run.rec").string();
        Child daemon(HAPTICD_BINARY,
                     daemon_args(n, {"--lockstep", "--serve-wait-commit", "--hand-stiffness", "-1", "--hand-damping",
                                     "-1", "--record", out.file}),
                     "record_mesh_daemon");
        EXPECT_TRUE(wait_for_socket(n.socket)) << daemon.err();
        const cl::StateReader state = cl::StateReader::open(n.shm);
        {
            cl::Client c =
                cl::Client::connect({.socket_path = n.socket, .client_name = "record-mesh-test", .timeout_s = 60.0});
            out.box = c.upload_mesh(box_vertices(), box_triangles(), true);
            out.surface = c.upload_mesh({{0.0, 0.0, 0.03}, {0.01, 0.0, 0.03}, {0.0, 0.01, 0.03}}, {{{0, 1, 2}}}, false);
            const auto settle = [&](std::uint64_t seq) {
                const cl::StateSample applied =
                    wait_state(state, [&](const cl::StateSample& s) { return s.last_commit_seq >= seq; });
                wait_state(state, [&](const cl::StateSample& s) { return s.tick >= applied.tick + kGap; });
            };
            cl::Batch add;
            add.add(box_at(out.box, 0.02, 0.0));
            const cl::CommitResult r = c.commit(add);
            settle(r.commit_seq);
            // Toward the handle: the face y = y - a passes the origin at the last two poses (the hand's spring holds
            // the handle there; the proxy stays on the face).
            const double ys[] = {0.015, 0.0115, 0.0102, 0.0099, 0.0098};
            for (std::size_t i = 0; i < std::size(ys); ++i) {
                cl::Batch move;
                move.modify(r.object_ids.at(0), box_at(out.box, ys[i], 0.01 * static_cast<double>(i)));
                settle(c.commit(move).commit_seq);
            }
            cl::Batch remove;
            remove.remove(r.object_ids.at(0));
            settle(c.commit(remove).commit_seq);
        }  // the client leaves
        stop_after_the_client_left(state, daemon);
        return out;
    }();
    return run;
}

// The byte offset of the first chunk of `kind` (0 when none): chunk starts only, from the header on.
std::size_t chunk_offset(const std::vector<char>& bytes, std::uint32_t kind) {
    for (std::size_t at = header_size_of(bytes); at + rec::kChunkSize <= bytes.size(); at += rec::kChunkSize) {
        std::uint32_t k = 0;
        std::memcpy(&k, bytes.data() + at, 4);
        if (k == kind) return at;
    }
    return 0;
}

TEST(RecordReplayMeshes, AMeshSessionReplaysBitForBit) {
    const MeshRun& run = mesh_run();
    const Recording r = read_recording(run.file);
    EXPECT_EQ(r.version, rec::kFormatVersion);
    // The rendered box only, exactly as uploaded; the surface never rendered is not in the file.
    ASSERT_EQ(r.meshes.size(), 1U);
    ASSERT_EQ(r.meshes.count(run.box), 1U);
    EXPECT_EQ(r.meshes.count(run.surface), 0U);
    const mesh::MeshHierarchy& h = *r.meshes.at(run.box);
    EXPECT_EQ(h.mode(), mesh::MeshMode::solid);
    const auto v = box_vertices();
    ASSERT_EQ(h.mesh().vertices.size(), v.size());
    for (std::size_t i = 0; i < v.size(); ++i) {
        for (int k = 0; k < 3; ++k) EXPECT_EQ(h.mesh().vertices[i][k], v[i][static_cast<std::size_t>(k)]);
    }
    EXPECT_EQ(h.mesh().triangles, box_triangles());
    // add, 5 moves, the removal; every mesh update names the box and carries its orientation, friction and shading.
    std::size_t mesh_updates = 0;
    for (const auto& b : r.batches) {
        for (const auto& u : b.updates) {
            if (u.params.kind != ObjectKind::Mesh) continue;
            ++mesh_updates;
            EXPECT_EQ(u.params.mesh_id, run.box);
            EXPECT_EQ(u.params.mesh, &h);
            EXPECT_EQ(u.params.static_friction, 0.4);
            EXPECT_EQ(u.params.dynamic_friction, 0.3);
            EXPECT_EQ(u.params.crease_angle_deg, 30.0);
            EXPECT_EQ(u.params.shading, h.shading(30.0));
            EXPECT_NE(u.params.shading, nullptr);
        }
    }
    EXPECT_GE(r.batches.size(), 7U);
    EXPECT_GE(mesh_updates, 7U);
    std::size_t contact = 0, pushed = 0;
    for (const auto& t : r.ticks) {
        contact += t.contact_mask != 0 ? 1 : 0;
        pushed += t.force[1] < -1e-3 ? 1 : 0;
    }
    std::printf("[ record ] %zu ticks (%zu in contact with the box, %zu pushed along -y), %zu batches, %zu bytes\n",
                r.ticks.size(), contact, pushed, r.batches.size(), read_bytes(run.file).size());
    ASSERT_GT(contact, 300U);  // the handle was inside the box's outline: the comparison is not one of zeros
    ASSERT_GT(pushed, 300U);

    expect_replays_bit_for_bit(run.file, "replay_mesh_ok", r.ticks.size(), r.batches.size());
}

// The replay renders the recorded hierarchy: the box's face y = -a (vertices 0, 1, 4, 5) moved by 1 um toward the
// handle (the file resealed) pushes the handle harder by K 1 um, so the replay names a tick in contact (exit 11),
// not a bad file.
TEST(RecordReplayMeshes, AMovedFaceChangesTheReplayedForce) {
    std::vector<char> bytes = read_bytes(mesh_run().file);
    const std::size_t at = chunk_offset(bytes, rec::kMeshVertices);
    ASSERT_GT(at, 0U);
    rec::MeshVerticesChunk first, second;  // vertices 0 .. 4, 5 .. 7
    std::memcpy(&first, bytes.data() + at, sizeof first);
    std::memcpy(&second, bytes.data() + at + rec::kChunkSize, sizeof second);
    for (double* y : {&first.xyz[1], &first.xyz[4], &first.xyz[13], &second.xyz[1]}) {
        ASSERT_EQ(*y, -kHalf);
        *y += 1e-6;
    }
    std::memcpy(bytes.data() + at, &first, sizeof first);
    std::memcpy(bytes.data() + at + rec::kChunkSize, &second, sizeof second);
    reseal(bytes);
    const std::string file = (scratch() / "mesh_face_moved.rec").string();
    write_bytes(file, bytes);
    const Replay out = replay(file, "replay_mesh_face");
    EXPECT_EQ(out.code, 11) << out.err;
    EXPECT_NE(out.err.find("ticks differ; the first is tick "), std::string::npos) << out.err;
}

// Broken mesh records: exit 10, the file's path and the defect in the message.
TEST(RecordReplayMeshes, BrokenMeshRecordsAreRefusedWithTheirDefect) {
    const MeshRun& run = mesh_run();
    const std::vector<char> good = read_bytes(run.file);
    const std::size_t mesh_at = chunk_offset(good, rec::kMesh);
    ASSERT_GT(mesh_at, 0U);
    const std::size_t index = (mesh_at - header_size_of(good)) / rec::kChunkSize;
    const std::string name = "mesh record " + std::to_string(index) + " (mesh " + std::to_string(run.box) + ")";
    struct Case {
        std::string name;
        std::vector<char> bytes;
        std::string message;
    };
    std::vector<Case> cases;
    const auto with_head = [&](std::uint64_t vertices, std::uint64_t triangles) {
        std::vector<char> bytes = good;
        rec::MeshChunk m;
        std::memcpy(&m, bytes.data() + mesh_at, sizeof m);
        m.vertices = vertices;
        m.triangles = triangles;
        std::memcpy(bytes.data() + mesh_at, &m, sizeof m);
        reseal(bytes);
        return bytes;
    };
    cases.push_back({"mesh_vertices_beyond_limit", with_head(200001, 12),
                     name + " has mode 1, 200001 vertices and 12 triangles (accepted: mesh id 1 .. 2^32-1"});
    cases.push_back({"mesh_triangles_beyond_limit", with_head(8, 200001),
                     name + " has mode 1, 8 vertices and 200001 triangles (accepted: "});
    {
        // The file's chunks up to the mesh record's end, then the end chunk; the head announces 199 999 vertices.
        std::vector<char> bytes = with_head(199999, 12);
        std::vector<char> cut(bytes.begin(), bytes.begin() + static_cast<long>(mesh_at + 5 * rec::kChunkSize));
        cut.insert(cut.end(), bytes.end() - static_cast<long>(rec::kChunkSize), bytes.end());
        reseal(cut);
        cases.push_back({"mesh_counts_beyond_file", cut,
                         name + " announces 40000 vertex and 2 triangle chunks; only 4 "
                                "chunks follow it"});
    }
    cases.push_back(
        {"mesh_count_mismatch", with_head(9, 12),
         "chunk 1 after " + name + " has kind 8 and count 3; expected the mesh's vertices (kind 8, count 4)"});
    {
        std::vector<char> bytes = good;  // the last triangle chunk cut out: a tick or batch read in its place
        const std::size_t last = mesh_at + 4 * rec::kChunkSize;
        bytes.erase(bytes.begin() + static_cast<long>(last), bytes.begin() + static_cast<long>(last + rec::kChunkSize));
        reseal(bytes);
        cases.push_back({"mesh_triangles_cut", bytes, "chunk 3 after " + name + " has kind "});
    }
    {
        std::vector<char> bytes = good;
        rec::MeshVerticesChunk c;
        std::memcpy(&c, bytes.data() + mesh_at + rec::kChunkSize, sizeof c);
        c.xyz[4] = std::numeric_limits<double>::quiet_NaN();  // vertex 1, y
        std::memcpy(bytes.data() + mesh_at + rec::kChunkSize, &c, sizeof c);
        reseal(bytes);
        cases.push_back({"mesh_nan", bytes, name + " (solid) is invalid: mesh: vertex 1 coordinate y = "});
    }
    {
        std::vector<char> bytes = good;
        rec::MeshTrianglesChunk c;
        std::memcpy(&c, bytes.data() + mesh_at + 3 * rec::kChunkSize, sizeof c);
        c.indices[2] = 8;  // triangle 0's third vertex: one past the 8 vertices
        std::memcpy(bytes.data() + mesh_at + 3 * rec::kChunkSize, &c, sizeof c);
        reseal(bytes);
        cases.push_back(
            {"mesh_index", bytes, name + " (solid) is invalid: mesh: triangle 0 vertex index 2 = 8, accepted 0..7"});
    }
    {
        std::vector<char> bytes = good;  // the first mesh update names a mesh the file does not hold
        const std::size_t at = chunk_offset(bytes, rec::kUpdateC);
        ASSERT_GT(at, mesh_at);
        rec::UpdateChunkC c;
        std::memcpy(&c, bytes.data() + at, sizeof c);
        c.mesh = run.box + 1000;
        std::memcpy(bytes.data() + at, &c, sizeof c);
        reseal(bytes);
        cases.push_back({"mesh_unknown", bytes,
                         "names mesh " + std::to_string(run.box + 1000) + ", which no mesh record before it holds"});
    }
    cases.push_back({"mesh_cut_off",
                     std::vector<char>(good.begin(), good.begin() + static_cast<long>(mesh_at + 2 * rec::kChunkSize)),
                     "truncated: no end record"});
    for (const Case& c : cases) {
        const std::string file = (scratch() / ("bad_" + c.name + ".rec")).string();
        write_bytes(file, c.bytes);
        const Replay out = replay(file, "replay_bad_" + c.name);
        EXPECT_EQ(out.code, 10) << c.name << ": " << out.err;
        EXPECT_NE(out.err.find("recording '" + file + "': "), std::string::npos) << c.name << ": " << out.err;
        EXPECT_NE(out.err.find(c.message), std::string::npos) << c.name << ": " << out.err;
    }
}

}  // namespace hapticd::server_test::record_meshes
