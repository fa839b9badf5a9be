// SPDX-License-Identifier: Apache-2.0
// A mesh object's god-object proxy in the state (docs/protocol.md, section 6), against a real hapticd --serve on
// the 3-axis simulated device (free, no simulated hand) at its real 1 kHz: read through the client library's
// StateReader (shared memory) and its `subscribe` (the socket's state messages). A box mesh whose +z face carries
// the oblique plane n = (0, 0.6, 0.8) through the origin (as ServerMeshStep in test_server_meshes.cpp) and a field
// of -1 N n press the handle into that face: the published proxy lies on the face's plane moved out by the proxy's
// 1 um offset, it is the handle's projection there (no friction), and the handle is behind it; a scene without
// a mesh publishes none, and the proxy goes with its object.
#include <cmath>

#include "common/test_paths.hpp"
#include "server_fixture.hpp"

namespace hapticd::server_test::mesh_proxy_test {

// The daemon without config walls (a mesh is checked as a spring of K in every direction: beside the fixture's CE2
// wall along x it would be refused) and without the watchdog (a loaded machine must not end the daemon).
std::vector<std::string> proxy_daemon_args(const Names& n) {
    std::vector<std::string> a = daemon_args(n, {"--scenario", "step", "--step-force", "0"});
    const auto wall = std::find(a.begin(), a.end(), "--wall");
    if (wall != a.end()) a.erase(wall, wall + 2);
    a.insert(a.end(), {"--no-walls", "--watchdog-overruns", "1000000000", "--watchdog-stall-periods", "1000000000"});
    return a;
}

// The box [-a, a]^3: 8 vertices, 12 triangles wound outward; triangles 2 and 3 are the +z face.
void proxy_box(double a, std::vector<cl::Vec3>& vertices, std::vector<std::array<std::uint32_t, 3>>& triangles) {
    for (int i = 0; i < 8; ++i) vertices.push_back({(i & 1) ? a : -a, (i & 2) ? a : -a, (i & 4) ? a : -a});
    triangles = {{0, 2, 1}, {1, 2, 3}, {4, 5, 6}, {5, 7, 6}, {0, 1, 4}, {1, 5, 4},
                 {2, 6, 3}, {3, 6, 7}, {0, 4, 2}, {2, 4, 6}, {1, 3, 5}, {3, 7, 5}};
}

double dot3(const cl::Vec3& u, const cl::Vec3& v) { return u[0] * v[0] + u[1] * v[1] + u[2] * v[2]; }

TEST(ServerMeshProxy, AMeshPressedOnTheSimulatedDevicePublishesItsProxyOnTheFaceWithTheHandleBehind) {
    const Names n = names("mesh_proxy");
    Child daemon(HAPTICD_BINARY, proxy_daemon_args(n), "mesh_proxy_daemon");
    ASSERT_TRUE(wait_for_socket(n.socket)) << daemon.err();
    {
        cl::Client c = cl::Client::connect({.socket_path = n.socket, .client_name = "mesh-proxy-test"});
        const cl::StateReader reader = cl::StateReader::open(n.shm);
        EXPECT_EQ(reader.mesh_proxy_capacity(), kStateMeshProxyCapacity);

        // A plane alone (far from the handle): a scene without a mesh publishes no mesh slot and no proxy. Soft
        // (10 N/m): the sums with the CE2 mesh below stay in the stability region (docs/protocol.md, section 5).
        const std::uint32_t plane =
            c.commit(cl::Batch().add(cl::Plane{
                         .normal = {0.0, 0.0, 1.0}, .offset = -0.04, .gains = cl::Gains::explicit_gains(10.0, 0.1)}))
                .object_ids.at(0);
        auto s = wait_state(
            reader, [&](const cl::StateSample& x) { return x.slot_object_id[0] == plane; }, 5.0);
        ASSERT_TRUE(s.has_value());
        EXPECT_EQ(s->mesh_slot_mask, 0U);
        EXPECT_EQ(s->mesh_proxies, 0U);

        const double a = 0.02, delta = 1e-6;  // delta: kSurfaceOffset, the proxy's clearance
        std::vector<cl::Vec3> vertices;
        std::vector<std::array<std::uint32_t, 3>> triangles;
        proxy_box(a, vertices, triangles);
        const std::uint32_t mesh = c.upload_mesh(vertices, triangles, true);
        // R_x(theta) e_z = (0, -sin theta, cos theta) = n; the +z face's plane n.x = -delta, its offset plane n.x = 0.
        const double theta = std::atan2(-0.6, 0.8);
        const cl::Vec3 normal{0.0, 0.6, 0.8};
        cl::Mesh object{.mesh = mesh,
                        .position = {0.0, -0.6 * (a + delta), -0.8 * (a + delta)},
                        .orientation = {std::cos(theta / 2), std::sin(theta / 2), 0.0, 0.0}};
        cl::Field push{.center = {0.0, 0.0, 0.0}, .radius = 1.0, .force = {0.0, -0.6, -0.8}};
        const std::uint32_t id = c.commit(cl::Batch().add(object).add(push)).object_ids.at(0);

        // Pressed: the handle rests 1 N / K behind the face (13.5 um for CE2 on 0.30 kg at 1 kHz); wait for it.
        s = wait_state(
            reader,
            [&](const cl::StateSample& x) {
                return x.mesh_proxies == 1 && x.mesh_proxy[0].constraints == 1 && dot3(normal, x.position) < -5e-6;
            },
            5.0);
        ASSERT_TRUE(s.has_value()) << daemon.err();
        int checked = 0;
        for (int k = 0; k < 200; ++k) {  // 200 samples over ~0.2 s of the loop
            cl::StateSample x;
            ASSERT_TRUE(reader.read(x));
            std::this_thread::sleep_for(std::chrono::milliseconds(1));
            ASSERT_EQ(x.mesh_proxies, 1U);
            const cl::MeshProxySample& p = x.mesh_proxy[0];
            const std::size_t slot = p.slot;
            EXPECT_EQ(p.object_id, id);
            EXPECT_EQ(x.slot_object_id[slot], id);
            EXPECT_EQ(x.mesh_slot_mask, std::uint64_t{1} << slot);
            EXPECT_EQ(p.constraints == 1,
                      ((x.contact_mask >> slot) & 1U) != 0U);  // in contact exactly when constrained
            if (p.constraints != 1) continue;
            ++checked;
            EXPECT_TRUE(p.triangle == 2U || p.triangle == 3U) << p.triangle;
            EXPECT_TRUE(p.converged);
            EXPECT_FALSE(p.sliding);
            // On the face's plane moved out by delta: n.proxy = 0. The proxy's geometry works to 1e-12 m
            // (src/mesh/mesh_hierarchy.hpp) and the pose adds rounding of ~1e-17 m; ten times the former allowed.
            const double proxy_n = dot3(normal, p.proxy);
            EXPECT_NEAR(proxy_n, 0.0, 1e-11);
            // The handle behind the face (n.x < -delta) and behind the proxy.
            EXPECT_LT(dot3(normal, x.position), -delta);
            EXPECT_LT(dot3(normal, x.position), proxy_n);
            // Frictionless: proxy - handle is along n (tangential part within the geometry's 1e-12 m, ten times).
            const cl::Vec3 d{p.proxy[0] - x.position[0], p.proxy[1] - x.position[1], p.proxy[2] - x.position[2]};
            const double along = dot3(normal, d);
            for (std::size_t i = 0; i < 3; ++i) EXPECT_NEAR(d[i] - along * normal[i], 0.0, 1e-11) << i;
            // On the face (within its square of side 2a centred on the origin's projection, the face's centre).
            EXPECT_LT(std::abs(p.proxy[0]), a);
            // The active face's outward normal in the device frame (float: 6e-8 per component).
            for (std::size_t i = 0; i < 3; ++i) EXPECT_NEAR(p.normals[0][i], normal[i], 1e-6) << i;
        }
        EXPECT_GT(checked, 150) << "samples in contact of 200";

        // The socket's state messages carry the same proxies.
        c.subscribe(200.0);
        const auto m = c.next_state(2.0);
        ASSERT_TRUE(m.has_value());
        ASSERT_EQ(m->mesh_proxies, 1U);
        EXPECT_EQ(m->mesh_proxy[0].object_id, id);
        EXPECT_EQ(m->mesh_slot_mask, s->mesh_slot_mask);
        EXPECT_EQ(m->mesh_proxy[0].constraints, 1);
        EXPECT_NEAR(dot3(normal, m->mesh_proxy[0].proxy), 0.0, 1e-11);
        for (std::size_t i = 0; i < 3; ++i) EXPECT_NEAR(m->mesh_proxy[0].normals[0][i], normal[i], 1e-6) << i;
        c.unsubscribe();

        // The mesh removed: once its ramp-out frees the slot, no mesh slot and no proxy (the plane and field stay).
        c.commit(cl::Batch().remove(id));
        s = wait_state(
            reader, [&](const cl::StateSample& x) { return x.objects == 2; }, 5.0);
        ASSERT_TRUE(s.has_value());
        EXPECT_EQ(s->mesh_slot_mask, 0U);
        EXPECT_EQ(s->mesh_proxies, 0U);
        c.bye();
    }
    daemon.signal(SIGTERM);
    EXPECT_EQ(daemon.wait(), 0) << daemon.err();
}

}  // namespace hapticd::server_test::mesh_proxy_test
