// SPDX-License-Identifier: Apache-2.0
// The mesh store's memory accounting (server/mesh_store.hpp; docs/protocol.md, section 4a, "Limits") with force
// shading: a crease angle's corner normals count in the mesh's bytes from the moment they are built, a new angle
// that would take the session (or every session) beyond its limit is refused before its table is built, naming
// mesh.shading.crease_angle_deg, the bytes and the limit (also through the object resolution, as a commit sees it),
// and the bytes return to zero when the sessions leave. The mesh: an icosphere of 1280 triangles, 642 vertices.
#include <chrono>
#include <cstdint>
#include <memory>
#include <string>
#include <thread>
#include <variant>
#include <vector>

#include <gtest/gtest.h>

#include "mesh/procedural_meshes.hpp"
#include "resolution_device.hpp"
#include "server/mesh_store.hpp"

namespace hapticd::server {
namespace mesh_store_test {

namespace cl = hapticd::client;
using cl::ErrorCode;

mesh::TriangleMesh sphere() { return mesh::icosphere(0.01, 3); }

std::size_t table_bytes() { return mesh::shading_normals_bytes(sphere().triangles.size()); }

// Uploads the sphere for `session` in one chunk of each and waits (up to 20 s) for the worker: its id, or 0.
std::uint32_t upload(MeshStore& store, std::uint64_t session) {
    const mesh::TriangleMesh m = sphere();
    auto begun = store.begin(session, MeshBeginRequest{m.vertices.size(), m.triangles.size(), true}, Clock::now());
    if (!std::holds_alternative<std::uint32_t>(begun)) {
        ADD_FAILURE() << std::get<Refusal>(begun).message;
        return 0;
    }
    const std::uint32_t id = std::get<std::uint32_t>(begun);
    MeshChunkRequest vertices{.mesh = id, .first = 0, .triangles = false, .vertices = {}, .indices = {}};
    for (const auto& v : m.vertices) vertices.vertices.insert(vertices.vertices.end(), {v.x(), v.y(), v.z()});
    MeshChunkRequest triangles{.mesh = id, .first = 0, .triangles = true, .vertices = {}, .indices = {}};
    for (const auto& t : m.triangles) triangles.indices.insert(triangles.indices.end(), t.begin(), t.end());
    for (const MeshChunkRequest* c : {&vertices, &triangles}) {
        if (auto r = store.chunk(session, *c, Clock::now())) {
            ADD_FAILURE() << r->message;
            return 0;
        }
    }
    if (auto r = store.end(session, id)) {
        ADD_FAILURE() << r->message;
        return 0;
    }
    const auto deadline = Clock::now() + std::chrono::seconds(20);
    while (Clock::now() < deadline) {
        store.collect();
        const MeshInfo info = std::get<MeshInfo>(store.status(session, id));
        if (info.state == MeshState::Ready) return id;
        if (info.state == MeshState::Failed) {
            ADD_FAILURE() << info.message;
            return 0;
        }
        std::this_thread::sleep_for(std::chrono::milliseconds(5));
    }
    ADD_FAILURE() << "mesh " << id << " not built within 20 s";
    return 0;
}

std::size_t mesh_bytes(const MeshStore& store, std::uint64_t session, std::uint32_t id) {
    return std::get<MeshInfo>(store.status(session, id)).bytes;
}

// What a store counts for the built sphere without shading: its hierarchy's memory_bytes() (the geometry as the
// chunks filled it), measured on a store of its own.
std::size_t hierarchy_bytes() {
    MeshStore probe;
    const std::uint32_t id = upload(probe, 1);
    if (id == 0) return 0;
    const std::size_t bytes = mesh_bytes(probe, 1, id);
    EXPECT_EQ(bytes, std::get<MeshStore::Built>(probe.built(1, id)).hierarchy->memory_bytes());
    return bytes;
}

// The session limit holds the mesh and one table (and half of another): the first angle is counted exactly, a kept
// angle costs nothing, a second angle is refused (session_limit) before it is built. With the limit on every session
// together instead, the second angle is refused with capacity.
TEST(MeshStoreShading, ANewCreaseAngleBeyondTheSessionsBytesIsRefusedBeforeItIsBuilt) {
    const std::size_t base = hierarchy_bytes();
    const std::size_t table = table_bytes();
    ASSERT_EQ(table, sizeof(mesh::ShadingNormals) + 1280 * 97);
    MeshStoreLimits limits;
    limits.bytes_per_session = base + table + table / 2;
    MeshStore store(limits);
    const std::uint32_t id = upload(store, 1);
    ASSERT_NE(id, 0U);
    ASSERT_EQ(mesh_bytes(store, 1, id), base);
    const auto first = store.shading(1, id, 30.0);
    ASSERT_TRUE(std::holds_alternative<const mesh::ShadingNormals*>(first)) << std::get<Refusal>(first).message;
    const mesh::ShadingNormals* normals = std::get<const mesh::ShadingNormals*>(first);
    ASSERT_NE(normals, nullptr);
    EXPECT_EQ(normals->memory_bytes(), table);  // the size known before the build is the size built
    EXPECT_EQ(mesh_bytes(store, 1, id), base + table);
    EXPECT_EQ(store.session_bytes(1), base + table);
    EXPECT_EQ(store.total_bytes(), base + table);
    const auto built = std::get<MeshStore::Built>(store.built(1, id));
    EXPECT_EQ(built.hierarchy->memory_bytes(), base + table);
    const auto again = store.shading(1, id, 30.0);
    ASSERT_TRUE(std::holds_alternative<const mesh::ShadingNormals*>(again));
    EXPECT_EQ(std::get<const mesh::ShadingNormals*>(again), normals);
    EXPECT_EQ(store.total_bytes(), base + table);

    const auto refused = store.shading(1, id, 45.0);
    ASSERT_TRUE(std::holds_alternative<Refusal>(refused));
    const Refusal& r = std::get<Refusal>(refused);
    EXPECT_EQ(r.code, ErrorCode::SessionLimit);
    EXPECT_EQ(r.message.rfind("mesh.shading.crease_angle_deg = 45: mesh " + std::to_string(id), 0), 0U) << r.message;
    for (const std::string& part :
         std::vector<std::string>{std::to_string(table) + " bytes, 1280 triangles", "this session holds",
                                  std::to_string(base + table) + " bytes", "accepted: at most",
                                  std::to_string(limits.bytes_per_session) + " bytes) per session"}) {
        EXPECT_NE(r.message.find(part), std::string::npos) << part << " in: " << r.message;
    }
    EXPECT_EQ(built.hierarchy->shadings_kept(), 1U);  // refused before it was built
    EXPECT_EQ(built.hierarchy->kept_shading(45.0), nullptr);
    EXPECT_EQ(store.total_bytes(), base + table);

    MeshStoreLimits all = MeshStoreLimits{};
    all.bytes_total = base + table + table / 2;
    MeshStore shared(all);
    const std::uint32_t other = upload(shared, 2);
    ASSERT_NE(other, 0U);
    ASSERT_TRUE(std::holds_alternative<const mesh::ShadingNormals*>(shared.shading(2, other, 0.0)));
    const auto beyond = shared.shading(2, other, 80.0);
    ASSERT_TRUE(std::holds_alternative<Refusal>(beyond));
    EXPECT_EQ(std::get<Refusal>(beyond).code, ErrorCode::Capacity);
    EXPECT_NE(std::get<Refusal>(beyond).message.find(std::to_string(all.bytes_total) + " bytes) of every session"),
              std::string::npos)
        << std::get<Refusal>(beyond).message;
    EXPECT_EQ(shared.total_bytes(), base + table);
}

// The same refusal as a commit sees it: the object resolution asks the store (as the server's lookup does) for the
// shading of a mesh object and returns its refusal; the angle kept is accepted, with the store's table.
TEST(MeshStoreShading, TheObjectResolutionRefusesAShadedMeshBeyondTheSessionsBytes) {
    MeshStoreLimits limits;
    const std::size_t base = hierarchy_bytes();
    limits.bytes_per_session = base + table_bytes() + table_bytes() / 2;
    MeshStore store(limits);
    const std::uint32_t id = upload(store, 1);
    ASSERT_NE(id, 0U);
    const MeshLookup lookup = [&](std::uint32_t mesh) {
        MeshLookupResult out;
        auto found = store.built(1, mesh);
        if (auto* r = std::get_if<Refusal>(&found)) {
            out.refusal = *r;
            return out;
        }
        out.hierarchy = std::get<MeshStore::Built>(found).hierarchy;
        out.shading = [&store, mesh](double crease) { return store.shading(1, mesh, crease); };
        return out;
    };
    const ServerConfig c = resolution_device::config(3);
    GainChecker checker(resolution_device::plant(3));
    ObjectResolver resolver(c, checker);
    auto resolve = [&](double crease, Resolved& out) {
        cl::Mesh m{.mesh = id, .gains = cl::Gains::by_criterion("CE2"), .shading_crease_angle_deg = crease};
        return resolver.resolve(cl::ObjectDescription{m}, out, &lookup);
    };
    Resolved out;
    const auto accepted = resolve(30.0, out);
    ASSERT_FALSE(accepted) << accepted->message;
    const auto built = std::get<MeshStore::Built>(store.built(1, id));
    EXPECT_EQ(out.params.shading, built.hierarchy->kept_shading(30.0));
    EXPECT_NE(out.params.shading, nullptr);
    const auto refused = resolve(45.0, out);
    ASSERT_TRUE(refused);
    EXPECT_EQ(refused->code, ErrorCode::SessionLimit);
    EXPECT_EQ(refused->message.rfind("mesh.shading.crease_angle_deg = 45: mesh ", 0), 0U) << refused->message;
    EXPECT_NE(refused->message.find(std::to_string(limits.bytes_per_session) + " bytes) per session"),
              std::string::npos)
        << refused->message;
    EXPECT_EQ(store.session_bytes(1), base + table_bytes());
}

// Two sessions shade their meshes (3 angles and 1); each session's bytes are its own mesh's and tables, and when
// they leave (one drops a mesh, then both sessions end) the store counts 0, though an object's reference (as a slot
// holds one) keeps the hierarchy and its tables alive until the object is gone. A fifth angle is capacity.
TEST(MeshStoreShading, TheTablesBytesReturnToZeroWhenTheSessionsLeave) {
    const std::size_t base = hierarchy_bytes();
    const std::size_t table = table_bytes();
    MeshStore store;
    const std::uint32_t a = upload(store, 1);
    const std::uint32_t b = upload(store, 1);
    const std::uint32_t c = upload(store, 2);
    ASSERT_NE(a, 0U);
    ASSERT_NE(b, 0U);
    ASSERT_NE(c, 0U);
    for (const double crease : {0.0, 30.0, 80.0, 45.0}) {
        ASSERT_TRUE(std::holds_alternative<const mesh::ShadingNormals*>(store.shading(1, a, crease)));
    }
    const auto fifth = store.shading(1, a, 20.0);
    ASSERT_TRUE(std::holds_alternative<Refusal>(fifth));
    EXPECT_EQ(std::get<Refusal>(fifth).code, ErrorCode::Capacity);
    EXPECT_NE(std::get<Refusal>(fifth).message.find("already keeps the normals of 4 other crease angles"),
              std::string::npos);
    ASSERT_TRUE(std::holds_alternative<const mesh::ShadingNormals*>(store.shading(1, b, 10.0)));
    ASSERT_TRUE(std::holds_alternative<const mesh::ShadingNormals*>(store.shading(2, c, 10.0)));
    const auto others = store.shading(2, a, 10.0);
    ASSERT_TRUE(std::holds_alternative<Refusal>(others));
    EXPECT_EQ(std::get<Refusal>(others).code, ErrorCode::UnknownObject);  // another session's mesh
    EXPECT_EQ(mesh_bytes(store, 1, a), base + 4 * table);
    EXPECT_EQ(store.session_bytes(1), 2 * base + 5 * table);
    EXPECT_EQ(store.session_bytes(2), base + table);
    EXPECT_EQ(store.total_bytes(), 3 * base + 6 * table);

    const auto rendered = std::get<MeshStore::Built>(store.built(1, a)).hierarchy;  // as an object's slot holds it
    ASSERT_FALSE(store.remove(1, a));
    EXPECT_EQ(store.session_bytes(1), base + table);
    EXPECT_EQ(store.total_bytes(), 2 * base + 2 * table);
    store.drop_session(1);
    EXPECT_EQ(store.session_bytes(1), 0U);
    EXPECT_EQ(store.total_bytes(), base + table);
    store.drop_session(2);
    EXPECT_EQ(store.total_bytes(), 0U);
    EXPECT_EQ(store.meshes(), 0U);
    EXPECT_EQ(rendered->memory_bytes(), base + 4 * table);  // alive (and its tables) while rendered
}

}  // namespace mesh_store_test
}  // namespace hapticd::server
