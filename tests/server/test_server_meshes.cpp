// SPDX-License-Identifier: Apache-2.0
// Mesh uploads and mesh objects against a running hapticd --serve (docs/protocol.md, sections 4 and 4a): the
// upload's order, limits and errors (unknown ids, out-of-order chunks, NaN and out-of-range vertices, oversized
// counts; degenerate, out-of-range-index, open-in-solid-mode and self-overlapping meshes failed by the worker's
// validation), an upload that never finishes (timed out), a client that dies mid-upload (its bytes freed, seen in
// `status`), and a box mesh rendered like the plane it has as a face: the step response of the analysis, in
// lockstep.
#include <cmath>
#include <cstdio>

#include <hapticopt/hapticopt.hpp>

#include "common/test_paths.hpp"
#include "server_fixture.hpp"

namespace hapticd::server_test {
namespace {

constexpr double kBoxMass = 0.30, kBoxPeriod = 1e-3;

struct MeshData {
    std::vector<double> vertices;  // x y z per vertex
    std::vector<std::uint32_t> triangles;
};

// The box [-a, a]^3, 8 vertices, 12 triangles wound with outward normals (b - a) x (c - a).
MeshData box(double a) {
    MeshData m;
    for (int i = 0; i < 8; ++i) {
        m.vertices.insert(m.vertices.end(), {(i & 1) ? a : -a, (i & 2) ? a : -a, (i & 4) ? a : -a});
    }
    m.triangles = {0, 2, 1, 1, 2, 3,   // z = -a
                   4, 5, 6, 5, 7, 6,   // z = +a
                   0, 1, 4, 1, 5, 4,   // y = -a
                   2, 6, 3, 3, 6, 7,   // y = +a
                   0, 4, 2, 2, 4, 6,   // x = -a
                   1, 3, 5, 3, 7, 5};  // x = +a
    return m;
}

json request(const RawConnection& c, json message) {
    static std::uint64_t id = 1000;
    message["id"] = ++id;
    c.send(message.dump());
    for (int i = 0; i < 100; ++i) {  // skip events without an id
        json r = c.receive_json();
        if (r.contains("timeout") || r.contains("eof") || r.contains("id")) return r;
    }
    return json{{"timeout", true}};
}

// mesh_begin, the chunks (at most `per_chunk` values each), mesh_end; returns the mesh id or 0 (`error` the reply).
std::uint32_t upload(const RawConnection& c, const MeshData& m, const std::string& mode, json& error,
                     std::size_t per_chunk = 300) {
    json r = request(c, {{"type", "mesh_begin"},
                         {"vertices", m.vertices.size() / 3},
                         {"triangles", m.triangles.size() / 3},
                         {"mode", mode}});
    if (r.value("type", "") != "ok") {
        error = r;
        return 0;
    }
    const std::uint32_t id = r["mesh"].get<std::uint32_t>();
    for (std::size_t at = 0; at < m.vertices.size(); at += per_chunk) {
        const std::size_t end = std::min(m.vertices.size(), at + per_chunk);
        r = request(c, {{"type", "mesh_chunk"},
                        {"mesh", id},
                        {"first", at / 3},
                        {"vertices", std::vector<double>(m.vertices.begin() + static_cast<long>(at),
                                                         m.vertices.begin() + static_cast<long>(end))}});
        if (r.value("type", "") != "ok") {
            error = r;
            return 0;
        }
    }
    for (std::size_t at = 0; at < m.triangles.size(); at += per_chunk) {
        const std::size_t end = std::min(m.triangles.size(), at + per_chunk);
        r = request(c, {{"type", "mesh_chunk"},
                        {"mesh", id},
                        {"first", at / 3},
                        {"triangles", std::vector<std::uint32_t>(m.triangles.begin() + static_cast<long>(at),
                                                                 m.triangles.begin() + static_cast<long>(end))}});
        if (r.value("type", "") != "ok") {
            error = r;
            return 0;
        }
    }
    r = request(c, {{"type", "mesh_end"}, {"mesh", id}});
    if (r.value("type", "") != "ok") {
        error = r;
        return 0;
    }
    return id;
}

// Polls mesh_status until the mesh is no longer building (10 s at most); its last reply.
json wait_built(const RawConnection& c, std::uint32_t id) {
    json r;
    const double end = monotonic_s() + 10.0;
    do {
        r = request(c, {{"type", "mesh_status"}, {"mesh", id}});
        if (r.value("state", "") != "building") return r;
        std::this_thread::sleep_for(std::chrono::milliseconds(5));
    } while (monotonic_s() < end);
    return r;
}

json status(const RawConnection& c) { return request(c, {{"type", "status"}}); }

// Uploads and waits for the worker: the last mesh_status (state ready or failed), or the refusal of a request.
json upload_and_build(const RawConnection& c, const MeshData& m, const std::string& mode) {
    json error;
    const std::uint32_t id = upload(c, m, mode, error);
    return id == 0 ? error : wait_built(c, id);
}

// The fixture's daemon without its config wall: a mesh is checked in the sums as a spring of K in every direction
// (docs/protocol.md, section 5), so a CE2 mesh beside the CE2 wall along x would be refused (unstable_sum), and the
// step response below is the mesh's alone. These daemons check the protocol, not the loop's timing: the watchdog's
// thresholds are raised so that a machine loaded by other builds (a load of 14 on 2 cores was seen) does not stop
// the loop (and the daemon) under a test.
std::vector<std::string> mesh_daemon_args(const Names& n, const std::vector<std::string>& extra) {
    std::vector<std::string> a = daemon_args(n, extra);
    const auto wall = std::find(a.begin(), a.end(), "--wall");
    if (wall != a.end()) a.erase(wall, wall + 2);
    a.insert(a.end(), {"--no-walls", "--watchdog-overruns", "1000000000", "--watchdog-stall-periods", "1000000000"});
    return a;
}

json mesh_object(std::uint32_t id, const std::array<double, 3>& position, const std::array<double, 4>& q,
                 const json& gains) {
    return json{{"kind", "mesh"}, {"mesh", id}, {"position", position}, {"orientation", q}, {"gains", gains}};
}

// The shared daemon without config walls (a mesh alone on the scene) and without the watchdog.
std::vector<std::string> mesh_step_daemon_args(const Names& n) {
    return mesh_daemon_args(n, {"--scenario", "step", "--step-force", "0"});
}

constexpr char kMeshTag[] = "meshes";
class ServerMeshes : public SharedDaemonTest<kMeshTag, mesh_step_daemon_args> {};

TEST_F(ServerMeshes, ABoxUploadsBuildsAndIsAddedListedAndRemoved) {
    RawConnection c(n_->socket);
    c.hello();
    json error;
    const std::uint32_t id = upload(c, box(0.01), "solid", error, 9);  // 3 vertices / triangles per chunk
    ASSERT_NE(id, 0U) << error.dump();
    const json built = wait_built(c, id);
    ASSERT_EQ(built.value("state", ""), "ready") << built.dump();
    EXPECT_EQ(built.value("vertices", 0), 8);
    EXPECT_EQ(built.value("triangles", 0), 12);
    EXPECT_GT(built.value("bytes", 0), 0);
    json r = request(
        c, {{"type", "commit"},
            {"ops",
             {{{"op", "add"}, {"object", mesh_object(id, {0.0, 0.0, -0.03}, {1, 0, 0, 0}, {{"criterion", "CE2"}})}}}}});
    ASSERT_EQ(r.value("type", ""), "ok") << r.dump();
    const std::uint32_t object = r["object_ids"][0].get<std::uint32_t>();
    r = request(c, {{"type", "list"}});
    bool listed = false;
    for (const json& o : r["objects"]) {
        if (o.value("id", 0U) != object) continue;
        listed = true;
        EXPECT_EQ(o.value("kind", ""), "mesh") << o.dump();
        EXPECT_GT(o.value("K", 0.0), 0.0) << o.dump();
    }
    EXPECT_TRUE(listed) << r.dump();
    // The mesh is deleted while the object renders it: the object stays, and is removed normally.
    r = request(c, {{"type", "mesh_delete"}, {"mesh", id}});
    EXPECT_EQ(r.value("type", ""), "ok") << r.dump();
    r = request(c, {{"type", "commit"}, {"ops", {{{"op", "remove"}, {"object_id", object}}}}});
    EXPECT_EQ(r.value("type", ""), "ok") << r.dump();
    r = request(c, {{"type", "mesh_status"}, {"mesh", id}});
    EXPECT_EQ(r.value("code", ""), "unknown_object") << r.dump();
}

TEST_F(ServerMeshes, BadUploadsGetErrorsNamingTheFieldAndTheSessionGoesOn) {
    RawConnection c(n_->socket);
    c.hello();
    auto expect = [&](const json& message, const std::string& code, const std::string& names) {
        const json r = request(c, message);
        EXPECT_EQ(r.value("code", ""), code) << message.dump() << " -> " << r.dump();
        EXPECT_NE(r.value("message", "").find(names), std::string::npos) << message.dump() << " -> " << r.dump();
    };
    expect({{"type", "mesh_begin"}, {"vertices", 8}, {"triangles", 0}, {"mode", "solid"}}, "bad_message", "triangles");
    expect({{"type", "mesh_begin"}, {"vertices", 8}, {"triangles", 200001}, {"mode", "solid"}}, "bad_message",
           "1 .. 200000");
    expect({{"type", "mesh_begin"}, {"vertices", 200001}, {"triangles", 2}, {"mode", "solid"}}, "bad_message",
           "3 .. 200000");
    expect({{"type", "mesh_begin"}, {"vertices", 8}, {"triangles", 2}, {"mode", "closed"}}, "bad_message", "mode");
    expect({{"type", "mesh_chunk"}, {"mesh", 999999}, {"first", 0}, {"vertices", {0, 0, 0}}}, "unknown_object",
           "mesh 999999");
    expect({{"type", "mesh_end"}, {"mesh", 999999}}, "unknown_object", "mesh 999999");
    json r = request(c, {{"type", "mesh_begin"}, {"vertices", 3}, {"triangles", 1}, {"mode", "surface"}});
    ASSERT_EQ(r.value("type", ""), "ok") << r.dump();
    const std::uint32_t id = r["mesh"].get<std::uint32_t>();
    expect({{"type", "mesh_chunk"}, {"mesh", id}, {"first", 1}, {"vertices", {0, 0, 0}}}, "bad_message", "expected 0");
    expect({{"type", "mesh_chunk"}, {"mesh", id}, {"first", 0}, {"vertices", {0, 0, 0, 1, 0, 0, 0, 1, 0, 1, 1, 1}}},
           "bad_message", "exceed the 3 announced");
    expect({{"type", "mesh_chunk"}, {"mesh", id}, {"first", 0}, {"vertices", {0, 0}}}, "bad_message", "3k");
    expect({{"type", "mesh_chunk"}, {"mesh", id}, {"first", 0}, {"vertices", {0, 0, 11}}}, "bad_message",
           "vertices[2]");
    expect({{"type", "mesh_chunk"}, {"mesh", id}, {"first", 0}, {"vertices", {0, 0, 0}}, {"triangles", {0, 1, 2}}},
           "bad_message", "exactly one");
    // NaN and infinity cannot be written in JSON: the message is not JSON.
    c.send(R"({"type":"mesh_chunk","id":5,"mesh":)" + std::to_string(id) + R"(,"first":0,"vertices":[NaN,0,0]})");
    EXPECT_EQ(c.receive_json().value("code", ""), "bad_json");
    c.send(R"({"type":"mesh_chunk","id":6,"mesh":)" + std::to_string(id) + R"(,"first":0,"vertices":[1e400,0,0]})");
    EXPECT_EQ(c.receive_json().value("code", ""), "bad_json");
    expect({{"type", "mesh_end"}, {"mesh", id}}, "bad_message", "0 of 3 vertices");
    // Nothing was appended by the refused chunks: the right ones still start at 0.
    r = request(c, {{"type", "mesh_chunk"}, {"mesh", id}, {"first", 0}, {"vertices", {0, 0, 0, 0.01, 0, 0}}});
    EXPECT_EQ(r.value("vertices", 0), 2) << r.dump();
    r = request(c, {{"type", "mesh_chunk"}, {"mesh", id}, {"first", 2}, {"vertices", {0, 0.01, 0}}});
    EXPECT_EQ(r.value("vertices", 0), 3) << r.dump();
    r = request(c, {{"type", "mesh_chunk"}, {"mesh", id}, {"first", 0}, {"triangles", {0, 1, 3}}});
    EXPECT_EQ(r.value("type", ""), "ok") << r.dump();
    // An index out of range is found by the worker's validation: the mesh is failed, naming it.
    r = request(c, {{"type", "mesh_end"}, {"mesh", id}});
    EXPECT_EQ(r.value("state", ""), "building") << r.dump();
    r = wait_built(c, id);
    EXPECT_EQ(r.value("state", ""), "failed") << r.dump();
    EXPECT_NE(r.value("message", "").find("triangle 0"), std::string::npos) << r.dump();
    expect({{"type", "commit"},
            {"ops", {{{"op", "add"}, {"object", mesh_object(id, {0, 0, 0}, {1, 0, 0, 0}, {{"criterion", "CE2"}})}}}}},
           "bad_message", "failed");
    EXPECT_EQ(request(c, {{"type", "mesh_delete"}, {"mesh", id}}).value("type", ""), "ok");
    // A mesh object naming a mesh that does not exist.
    expect({{"type", "commit"},
            {"ops", {{{"op", "add"}, {"object", mesh_object(4242, {0, 0, 0}, {1, 0, 0, 0}, {{"criterion", "CE2"}})}}}}},
           "unknown_object", "mesh 4242");
    EXPECT_EQ(request(c, {{"type", "heartbeat"}}).value("type", ""), "ok");  // still served
}

// Force shading (docs/protocol.md, section 4: "shading": {"crease_angle_deg": ...}): accepted at 0 .. 80 deg on this
// one-mass, free-mass profile; out of range, of the wrong type, or a fifth crease angle on one mesh refused naming
// the parameter and the accepted range; the session goes on.
TEST_F(ServerMeshes, ShadingIsAcceptedInItsRangeAndBadCreaseAnglesAreRefusedNamingTheParameter) {
    RawConnection c(n_->socket);
    c.hello();
    json error;
    const std::uint32_t id = upload(c, box(0.01), "solid", error);
    ASSERT_NE(id, 0U) << error.dump();
    ASSERT_EQ(wait_built(c, id).value("state", ""), "ready");
    // Soft gains (K 10 N/m, B 1 N s/m): several meshes on one spot stay a stable sum.
    auto shaded = [&](const json& shading) {
        json object = mesh_object(id, {0.0, 0.0, -0.03}, {1, 0, 0, 0}, {{"K", 10.0}, {"B", 1.0}});
        object["shading"] = shading;
        return object;
    };
    auto add = [&](const json& shading) {
        return request(c, {{"type", "commit"}, {"ops", {{{"op", "add"}, {"object", shaded(shading)}}}}});
    };
    // One batch (the daemon's loop is in lockstep here: each batch stays in flight): four angles, the mesh keeps the
    // normals of each, and counts them in its bytes (97 a triangle and angle, and each table's struct).
    const auto bytes = [&] { return request(c, {{"type", "mesh_status"}, {"mesh", id}}).value("bytes", 0.0); };
    const double unshaded = bytes();
    json ops = json::array();
    for (const double crease : {0.0, 30.0, 80.0, 45.0})
        ops.push_back({{"op", "add"}, {"object", shaded({{"crease_angle_deg", crease}})}});
    json r = request(c, {{"type", "commit"}, {"ops", ops}});
    ASSERT_EQ(r.value("type", ""), "ok") << r.dump();
    ASSERT_EQ(r["object_ids"].size(), 4U);
    EXPECT_GE(bytes() - unshaded, 4 * 12 * 97) << unshaded;
    const auto expect = [&](const json& shading, const std::string& code, const std::string& names) {
        const json e = add(shading);
        EXPECT_EQ(e.value("type", ""), "error") << e.dump();
        EXPECT_EQ(e.value("code", ""), code) << e.dump();
        EXPECT_NE(e.value("message", "").find(names), std::string::npos) << e.dump();
    };
    expect({{"crease_angle_deg", 80.5}}, "bad_message", "mesh.shading.crease_angle_deg = 80.5; accepted: 0 .. 80");
    expect({{"crease_angle_deg", -1}}, "bad_message", "mesh.shading.crease_angle_deg = -1; accepted: 0 .. 80");
    expect({{"crease_angle_deg", "thirty"}}, "bad_message", "shading.crease_angle_deg: expected a finite number");
    expect(json::object(), "bad_message", "shading.crease_angle_deg: missing");
    expect(30, "bad_message", "object.shading: expected {\"crease_angle_deg\": number}");
    expect({{"crease_angle_deg", 20.0}}, "capacity", "already keeps the normals of 4 other crease angles");
    // A kept angle is accepted again; the session goes on.
    r = add({{"crease_angle_deg", 30.0}});
    EXPECT_EQ(r.value("type", ""), "ok") << r.dump();
}

TEST_F(ServerMeshes, DegenerateAndOpenSolidMeshesFailNamingTheRule) {
    RawConnection c(n_->socket);
    c.hello();
    MeshData degenerate = box(0.01);
    degenerate.triangles[2] = degenerate.triangles[1];  // triangle 0 has two equal indices
    json r = upload_and_build(c, degenerate, "surface");
    EXPECT_EQ(r.value("state", ""), "failed") << r.dump();
    MeshData open = box(0.01);
    open.triangles.resize(open.triangles.size() - 3);  // one face triangle missing: open
    r = upload_and_build(c, open, "solid");
    EXPECT_EQ(r.value("state", ""), "failed") << r.dump();
    EXPECT_NE(r.value("message", "").find("solid"), std::string::npos) << r.dump();
    // The same open mesh is a valid one-sided surface.
    r = upload_and_build(c, open, "surface");
    EXPECT_EQ(r.value("state", ""), "ready") << r.dump();
    MeshData flat{{0, 0, 0, 0.01, 0, 0, 0.02, 0, 0}, {0, 1, 2}};  // collinear: zero area
    r = upload_and_build(c, flat, "surface");
    EXPECT_EQ(r.value("state", ""), "failed") << r.dump();
    // Two boxes face to face on their own vertices: closed and outward wound, but the face x = +a of the first and
    // x = -a of the second are the same triangles twice (coplanar overlap).
    MeshData twice = box(0.01);
    const MeshData second = box(0.01);
    for (std::size_t i = 0; i < second.vertices.size(); ++i)
        twice.vertices.push_back(second.vertices[i] + (i % 3 == 0 ? 0.02 : 0.0));  // x + 2a
    for (const std::uint32_t t : second.triangles) twice.triangles.push_back(t + 8);
    r = upload_and_build(c, twice, "solid");
    EXPECT_EQ(r.value("state", ""), "failed") << r.dump();
    EXPECT_NE(r.value("message", "").find("overlaps itself: triangles 10 and 20"), std::string::npos) << r.dump();
}

TEST_F(ServerMeshes, ASessionHoldsAtMostEightMeshes) {
    RawConnection c(n_->socket);
    c.hello();
    for (int i = 0; i < 8; ++i) {
        const json r =
            request(c, {{"type", "mesh_begin"}, {"vertices", 200000}, {"triangles", 200000}, {"mode", "surface"}});
        ASSERT_EQ(r.value("type", ""), "ok") << r.dump();
    }
    const json r = request(c, {{"type", "mesh_begin"}, {"vertices", 3}, {"triangles", 1}, {"mode", "surface"}});
    EXPECT_EQ(r.value("code", ""), "session_limit") << r.dump();
    EXPECT_NE(r.value("message", "").find("at most 8"), std::string::npos) << r.dump();
    const json st = status(c);
    EXPECT_EQ(st.value("meshes", 0), 8) << st.dump();
    EXPECT_EQ(st.value("mesh_bytes", 0), 8 * (24 * 200000 + 12 * 200000)) << st.dump();
}

// A daemon of its own with --mesh-upload-timeout 1: silent uploads are dropped and their bytes freed; one that
// keeps sending chunks stays.
TEST(ServerMeshTimeout, AnUploadThatNeverFinishesTimesOut) {
    const Names n = names("mesh_timeout");
    Child daemon(HAPTICD_BINARY,
                 mesh_daemon_args(n, {"--scenario", "step", "--step-force", "0", "--mesh-upload-timeout", "1"}),
                 "mesh_timeout_daemon");
    ASSERT_TRUE(wait_for_socket(n.socket)) << daemon.err();
    {
        RawConnection c(n.socket);
        c.hello();
        json r = request(c, {{"type", "mesh_begin"}, {"vertices", 200000}, {"triangles", 200000}, {"mode", "surface"}});
        ASSERT_EQ(r.value("type", ""), "ok") << r.dump();
        const std::uint32_t silent = r["mesh"].get<std::uint32_t>();
        r = request(c, {{"type", "mesh_begin"}, {"vertices", 1000}, {"triangles", 10}, {"mode", "surface"}});
        ASSERT_EQ(r.value("type", ""), "ok") << r.dump();
        const std::uint32_t busy = r["mesh"].get<std::uint32_t>();
        for (int k = 0; k < 40; ++k) {  // > 2 s: a chunk every 50 ms keeps `busy` alive (1 s allows a loaded machine)
            std::this_thread::sleep_for(std::chrono::milliseconds(50));
            r = request(c, {{"type", "mesh_chunk"}, {"mesh", busy}, {"first", k}, {"vertices", {0, 0, 0}}});
            ASSERT_EQ(r.value("type", ""), "ok") << "chunk " << k << ": " << r.dump();
        }
        r = request(c, {{"type", "mesh_chunk"}, {"mesh", silent}, {"first", 0}, {"vertices", {0, 0, 0}}});
        EXPECT_EQ(r.value("code", ""), "unknown_object") << r.dump();
        EXPECT_NE(r.value("message", "").find("timed out"), std::string::npos) << r.dump();
        r = status(c);
        EXPECT_EQ(r.value("meshes", -1), 1) << r.dump();
        EXPECT_EQ(r.value("mesh_bytes", -1), 24 * 1000 + 12 * 10) << r.dump();
    }
    daemon.signal(SIGTERM);
    EXPECT_EQ(daemon.wait(), 0) << daemon.err();
}

TEST_F(ServerMeshes, EverySessionTogetherIsBoundedAndAClientThatDiesMidUploadLeavesNothing) {
    RawConnection watcher(n_->socket);
    watcher.hello();
    std::vector<std::unique_ptr<RawConnection>> clients;
    std::size_t accepted = 0;
    json refused;
    for (int k = 0; k < 6 && refused.is_null(); ++k) {
        clients.push_back(std::make_unique<RawConnection>(n_->socket));
        clients.back()->hello();
        for (int i = 0; i < 8; ++i) {
            const json r =
                request(*clients.back(),
                        {{"type", "mesh_begin"}, {"vertices", 200000}, {"triangles", 200000}, {"mode", "surface"}});
            if (r.value("type", "") != "ok") {
                refused = r;
                break;
            }
            ++accepted;
        }
    }
    // 256 MiB / 7.2 MB: 37 uploads fit, the 38th is refused.
    EXPECT_EQ(accepted, (std::size_t{256} << 20) / (24 * 200000 + 12 * 200000));
    EXPECT_EQ(refused.value("code", ""), "capacity") << refused.dump();
    EXPECT_EQ(status(watcher).value("meshes", 0), accepted);
    // The clients die with their uploads begun and not finished: everything of them is freed when the server sees
    // them gone.
    clients.clear();
    const double end = monotonic_s() + 5.0;
    json r;
    do {
        r = status(watcher);
        if (r.value("mesh_bytes", -1) == 0) break;
        std::this_thread::sleep_for(std::chrono::milliseconds(10));
    } while (monotonic_s() < end);
    EXPECT_EQ(r.value("mesh_bytes", -1), 0) << r.dump();
    EXPECT_EQ(r.value("meshes", -1), 0) << r.dump();
}

// A box mesh whose face carries the oblique plane of ServerProcess.ObliquePlaneGivesTheAnalysedStepResponse
// (normal n = (0, 0.6, 0.8) through the handle's start at the origin): the box [-a, a]^3 rotated about x so that
// its +z face's outward normal is n, centred at -(a + delta) n with delta = 1 um, the proxy's clearance in front of a
// face (kSurfaceOffset, src/mesh/mesh_hierarchy.hpp): the proxy's constraint plane then passes through the handle's
// start, the face's centre, as the plane's surface does. The client field
// -1 N n pushes the handle into it (lockstep, no ramp): the penetration p_j = -y_j / 0.6 is the analysed step
// response of CE2, as for the plane (the proxy stays on the face, f = K (c - h) - B P v along n).
TEST(ServerMeshStep, ABoxMeshFaceGivesThePlanesAnalysedStepResponse) {
    const Names n = names("mesh_step");
    const std::string trace = (scratch() / "mesh_step.csv").string();
    Child daemon(HAPTICD_BINARY,
                 mesh_daemon_args(n, {"--lockstep", "--serve-wait-commit", "--scenario", "step", "--step-force", "0",
                                      "--ramp-time", "0", "--duration", "0.3", "--trace", trace, "--trace-axis", "1"}),
                 "mesh_step_daemon");
    ASSERT_TRUE(wait_for_socket(n.socket)) << daemon.err();
    RawConnection c(n.socket);
    c.hello();
    const double a = 0.02, delta = 1e-6;
    json error;
    const std::uint32_t id = upload(c, box(a), "solid", error);
    ASSERT_NE(id, 0U) << error.dump();
    ASSERT_EQ(wait_built(c, id).value("state", ""), "ready");
    // R_x(theta) e_z = (0, -sin theta, cos theta) = (0, 0.6, 0.8): theta = atan2(-0.6, 0.8).
    const double theta = std::atan2(-0.6, 0.8);
    const std::array<double, 4> q{std::cos(theta / 2), std::sin(theta / 2), 0.0, 0.0};
    const json ops = json::array({
        {{"op", "add"},
         {"object", mesh_object(id, {0.0, -0.6 * (a + delta), -0.8 * (a + delta)}, q, {{"criterion", "CE2"}})}},
        {{"op", "add"},
         {"object",
          {{"kind", "field"},
           {"center", {0, 0, 0}},
           {"radius", 1.0},
           {"force", {0.0, -0.6, -0.8}},
           {"jacobian", {{0, 0, 0}, {0, 0, 0}, {0, 0, 0}}}}}},
    });
    const json r = request(c, {{"type", "commit"}, {"ops", ops}});
    ASSERT_EQ(r.value("type", ""), "ok") << r.dump();
    ASSERT_EQ(daemon.wait(), 0) << daemon.err();

    const hapticopt::WallTuning t = hapticopt::optimal_wall(
        hapticopt::Criterion::CE2, hapticopt::PhysicalPlant{kBoxMass, 0.0, 0.0, kBoxPeriod, 0.0});
    std::vector<double> y;
    {
        std::ifstream in(trace);
        std::string line;
        std::getline(in, line);
        while (std::getline(in, line)) {
            unsigned long long tick = 0;
            double time = 0, pos = 0;
            if (std::sscanf(line.c_str(), "%llu,%lf,%lf", &tick, &time, &pos) < 3) break;
            y.push_back(pos);
        }
    }
    ASSERT_EQ(y.size(), 300U);
    const auto x = hapticopt::sampled_step_response(hapticopt::NormalizedPlant{0.0, 0.0, 0.0},
                                                    hapticopt::NormalizedGains{t.alpha, t.beta}, y.size());
    const double x_inf = 1.0 / t.K;
    double worst = 0.0;
    for (std::size_t j = 0; j < y.size(); ++j) {
        worst = std::max(worst, std::abs(-y[j] / 0.6 - x[j] * kBoxPeriod * kBoxPeriod / kBoxMass) / x_inf);
    }
    std::printf("[ mesh step ] K %.6g B %.6g: max |p_daemon - p_analysis| / x_inf = %.3g (%.3g m) over %zu ticks\n",
                t.K, t.B, worst, worst * x_inf, y.size());
    // The proxy's geometry works to 1e-12 m (a sweep ending within 1e-12 m of the offset level counts as on it;
    // src/mesh/mesh_hierarchy.hpp): ten times that bounds the penetration's deviation (x_inf = 13.5 um here).
    EXPECT_LE(worst * x_inf, 1e-11);
    EXPECT_GT(-y[100] / 0.6, 0.5 * x_inf);  // it did move into the face
}

}  // namespace
}  // namespace hapticd::server_test
