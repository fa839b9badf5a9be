// SPDX-License-Identifier: Apache-2.0
// A torus to touch (docs/clients.md): the example builds a torus as a triangle mesh (the tube of --minor radius
// around the circle of --major radius in the x-y plane, --segments around it), uploads it (Client::upload_mesh,
// docs/protocol.md section 4a) and adds it as a `mesh` object at --position with the gains of --criterion, rendered
// by the daemon through a god-object proxy. It prints each contact's begin and end from the shared-memory state.
//   touch_torus [--socket PATH] [--position 0,0,0] [--major 0.03] [--minor 0.01] [--segments 48]
//               [--criterion CE2] [--friction 0.3] [--duration 10]
// --duration 0: until SIGINT/SIGTERM.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <numbers>
#include <thread>
#include <vector>

#include "example_options.hpp"

namespace hc = hapticd::client;

namespace {

// Vertex (i, j): angle 2 pi i / n around the z axis, 2 pi j / m around the tube; two triangles per quad, wound so
// that (b - a) x (c - a) points out of the tube.
void torus(double major, double minor, int n, int m, std::vector<hc::Vec3>& vertices,
           std::vector<std::array<std::uint32_t, 3>>& triangles) {
    for (int i = 0; i < n; ++i) {
        const double u = 2.0 * std::numbers::pi * i / n;
        for (int j = 0; j < m; ++j) {
            const double v = 2.0 * std::numbers::pi * j / m;
            const double r = major + minor * std::cos(v);
            vertices.push_back({r * std::cos(u), r * std::sin(u), minor * std::sin(v)});
        }
    }
    const auto at = [&](int i, int j) { return static_cast<std::uint32_t>((i % n) * m + (j % m)); };
    for (int i = 0; i < n; ++i) {
        for (int j = 0; j < m; ++j) {
            triangles.push_back({at(i, j), at(i + 1, j), at(i + 1, j + 1)});
            triangles.push_back({at(i, j), at(i + 1, j + 1), at(i, j + 1)});
        }
    }
}

}  // namespace

int main(int argc, char** argv) {
    const examples::Options o(argc, argv,
                              {{"socket", ""},
                               {"position", "0,0,0"},
                               {"major", "0.03"},
                               {"minor", "0.01"},
                               {"segments", "48"},
                               {"criterion", "CE2"},
                               {"friction", "0.3"},
                               {"duration", "10"}});
    const double major = o.number("major"), minor = o.number("minor"), segments = o.number("segments");
    const double friction = o.number("friction"), duration = o.number("duration");
    if (!(major > minor && minor > 0.0 && segments >= 3 && segments <= 400 && friction >= 0.0)) {
        std::fprintf(stderr, "touch_torus: need --major > --minor > 0 (m), 3 <= --segments <= 400, --friction >= 0\n");
        return 2;
    }
    examples::install_stop_handlers();
    bool connected = false;
    try {
        hc::ConnectOptions co;
        co.socket_path = o.text("socket");
        co.client_name = "touch_torus";
        co.lease_s = 0.5;
        hc::Client client = hc::Client::connect(co);
        connected = true;
        std::vector<hc::Vec3> vertices;
        std::vector<std::array<std::uint32_t, 3>> triangles;
        const int n = static_cast<int>(segments);
        torus(major, minor, n, std::max(3, n / 3), vertices, triangles);
        hc::Mesh shape;
        shape.mesh = client.upload_mesh(vertices, triangles, true);
        shape.position = o.vec3("position");
        shape.gains = hc::Gains::by_criterion(o.text("criterion"));
        shape.static_friction = friction;
        shape.dynamic_friction = 0.8 * friction;
        const std::uint32_t id = client.commit(hc::Batch().add(shape)).object_ids.front();
        for (const hc::ObjectInfo& info : client.list()) {
            if (info.id == id) {
                std::printf("touch_torus: torus %u ready (%zu triangles, K = %g N/m, B = %g N s/m)\n", id,
                            triangles.size(), info.K, info.B);
            }
        }
        std::fflush(stdout);
        const hc::StateReader state = hc::StateReader::open(client.welcome().state_shm);
        const auto start = std::chrono::steady_clock::now();
        auto last_heartbeat = start;
        bool touching = false;
        while (!examples::g_stop) {
            std::this_thread::sleep_for(std::chrono::milliseconds(1));
            const auto now = std::chrono::steady_clock::now();
            if (duration > 0.0 && std::chrono::duration<double>(now - start).count() >= duration) break;
            hc::StateSample s;
            if (state.read(s)) {
                const auto ids = s.contacts();
                const bool now_touching = std::find(ids.begin(), ids.end(), id) != ids.end();
                if (now_touching != touching) {
                    touching = now_touching;
                    const double f =
                        std::sqrt(s.force[0] * s.force[0] + s.force[1] * s.force[1] + s.force[2] * s.force[2]);
                    std::printf("%s at (%.1f, %.1f, %.1f) mm, |f| %.3f N\n", touching ? "touching" : "free",
                                s.position[0] * 1e3, s.position[1] * 1e3, s.position[2] * 1e3, f);
                    std::fflush(stdout);
                }
            }
            if (now - last_heartbeat > std::chrono::milliseconds(150)) {  // a third of the lease
                client.heartbeat();
                last_heartbeat = now;
            }
        }
        client.bye();
        return 0;
    } catch (const hc::Error& e) {
        std::fprintf(stderr, "touch_torus: %s\n", e.what());
        return examples::exit_code(e, connected);
    }
}
