// SPDX-License-Identifier: Apache-2.0
// No pop-through: handles on straight paths through closed meshes at 1, 3 and 10 mm a tick (1, 3 and 10 m/s at
// 1 kHz), aimed at vertices, edge midpoints and face points, head-on and at grazing angles (1 to 5 degrees to the
// surface), with and without friction; after every step the proxy is not inside the mesh by an independent test
// (ray parity over every triangle, three generic rays).
#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <string>
#include <vector>

#include "mesh/god_object_proxy.hpp"
#include "mesh/procedural_meshes.hpp"
#include "mesh_reference.hpp"

namespace hapticd::mesh {
namespace {

namespace ref = reference;

struct Counts {
    int steps = 0;
    int contacts = 0;
};

// The handle from `from` along `direction` for `length` at `speed` m per tick; fails on any step whose proxy is
// inside.
void run_line(GodObjectProxy& proxy, const std::vector<ref::Face>& faces, const Eigen::Vector3d& from,
              const Eigen::Vector3d& direction, double length, double speed, Counts& counts, const std::string& what) {
    proxy.reset(from);
    const int steps = static_cast<int>(length / speed) + 1;
    for (int k = 1; k <= steps; ++k) {
        const Eigen::Vector3d handle = from + direction * (length * k / steps);
        const ProxyContact& c = proxy.step(handle);
        ++counts.steps;
        if (c.constraints > 0) ++counts.contacts;
        ASSERT_FALSE(ref::inside_by_ray_parity(faces, c.proxy))
            << what << ": step " << k << " proxy " << c.proxy.transpose() << " handle " << handle.transpose();
    }
}

// Targets on the surface: every vertex, every edge midpoint and every face centroid (a sample of at most `limit`
// of each).
std::vector<Eigen::Vector3d> targets(const TriangleMesh& m, std::size_t limit, std::mt19937_64& rng) {
    std::vector<Eigen::Vector3d> out;
    std::uniform_int_distribution<std::size_t> pick_t(0, m.triangles.size() - 1);
    for (std::size_t i = 0; i < limit; ++i) {
        const auto& t = m.triangles[pick_t(rng)];
        out.push_back(m.vertices[t[0]]);
        out.push_back(0.5 * (m.vertices[t[0]] + m.vertices[t[1]]));
        out.push_back((m.vertices[t[0]] + m.vertices[t[1]] + m.vertices[t[2]]) / 3.0);
    }
    return out;
}

void search_pop_through(const TriangleMesh& m, const Eigen::Vector3d& centre, MeshFriction friction,
                        const std::string& name) {
    ASSERT_FALSE(mesh_error(m, MeshMode::solid).has_value()) << name;
    const auto faces = ref::faces(m);
    GodObjectProxy proxy(MeshHierarchy::build(m, MeshMode::solid), friction);
    std::mt19937_64 rng(31);
    Counts counts;
    for (const Eigen::Vector3d& target : targets(m, 25, rng)) {
        // The outward direction at the target: from the centre (star-shaped meshes).
        const Eigen::Vector3d out = (target - centre).normalized();
        const Eigen::Vector3d tangent = out.unitOrthogonal();
        for (const double speed : {1e-3, 3e-3, 1e-2}) {
            // Head-on: from 2 cm outside through the target to 2 cm past it (into the mesh).
            run_line(proxy, faces, target + 0.02 * out, -out, 0.04, speed, counts, name + " head-on");
            // Grazing: 1 to 5 degrees below the tangent plane, through the target, 6 cm long.
            for (const double degrees : {1.0, 2.5, 5.0}) {
                const double a = degrees * std::acos(-1.0) / 180.0;
                const Eigen::Vector3d d = (std::cos(a) * tangent - std::sin(a) * out).normalized();
                run_line(proxy, faces, target - 0.03 * d, d, 0.06, speed, counts, name + " grazing");
            }
        }
    }
    EXPECT_GT(counts.contacts, counts.steps / 10) << name << ": the paths must press into the mesh";
    ::testing::Test::RecordProperty(name + "_steps", counts.steps);
}

TEST(ProxyPopThrough, NeverInsideAClosedSphere) { search_pop_through(icosphere(0.03, 3), {0, 0, 0}, {}, "sphere"); }

TEST(ProxyPopThrough, NeverInsideABox) { search_pop_through(box({0.03, 0.02, 0.025}, 3), {0, 0, 0}, {}, "box"); }

TEST(ProxyPopThrough, NeverInsideBumpySpheres) {
    std::mt19937_64 rng(3);
    for (int i = 0; i < 2; ++i) {
        search_pop_through(ref::bumpy_sphere(0.03, 3, 0.2, rng), {0, 0, 0}, {}, "bumpy" + std::to_string(i));
    }
}

TEST(ProxyPopThrough, NeverInsideWithFriction) {
    std::mt19937_64 rng(4);
    search_pop_through(ref::bumpy_sphere(0.03, 3, 0.2, rng), {0, 0, 0}, {0.8, 0.5}, "bumpy_friction");
    search_pop_through(box({0.03, 0.02, 0.025}, 2), {0, 0, 0}, {1.0, 0.6}, "box_friction");
}

TEST(ProxyPopThrough, NeverInsideATorusAcrossItsHole) {
    // The torus is not star-shaped: lines across the hole and along the ring at 1 and 10 mm a tick.
    const TriangleMesh m = torus(0.04, 0.015, 48, 24);
    const auto faces = ref::faces(m);
    GodObjectProxy proxy(MeshHierarchy::build(m, MeshMode::solid), {});
    std::mt19937_64 rng(9);
    std::uniform_real_distribution<double> u(-1.0, 1.0);
    Counts counts;
    for (int k = 0; k < 300; ++k) {
        const Eigen::Vector3d from = 0.08 * Eigen::Vector3d(u(rng), u(rng), 0.3 * u(rng)).normalized();
        const Eigen::Vector3d to(0.05 * u(rng), 0.05 * u(rng), 0.01 * u(rng));
        run_line(proxy, faces, from, (to - from).normalized(), (to - from).norm() * 1.5, k % 2 ? 1e-3 : 1e-2, counts,
                 "torus");
    }
    EXPECT_GT(counts.contacts, counts.steps / 10);
}

}  // namespace
}  // namespace hapticd::mesh
