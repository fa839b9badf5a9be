// SPDX-License-Identifier: Apache-2.0
// The god-object proxy against references built here: the constrained closest point by brute force (the faces the
// proxy rests on found over every triangle, the closest point on their half-spaces by enumerating subsets) on
// random paths over random meshes, with and without friction; the analytic sphere (direction and magnitude within
// the tessellation's sagitta); a box against its six planes; friction on a plane against the Coulomb cone in
// closed form; one-sided surfaces.
#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <vector>

#include "mesh/god_object_proxy.hpp"
#include "mesh/procedural_meshes.hpp"
#include "mesh_reference.hpp"

namespace hapticd::mesh {
namespace {

namespace ref = reference;

// Faces within 10 offsets (a proxy on two offset planes of a convex edge lies up to offset x tan(half the bend)
// beyond either face).
constexpr double kReach = 10 * kSurfaceOffset;
// The reference's and the proxy's closest points agree to the surface offset: where more than three triangles share
// a vertex, their offset planes do not meet in one point; the proxy rests on three and the others pass within
// O(offset) of it (measured: up to 2.2e-7 m), so the closest points of the two sets differ by O(offset).
constexpr double kSamePoint = kSurfaceOffset;

struct PathStats {
    int steps = 0;
    int converged = 0;
    int in_contact = 0;
    int checked = 0;
};

// The handle walks between random waypoints (0.5 mm a step) around and into the mesh; after every converged step
// the proxy is checked against the reference. Friction: the proxy stays inside the static cone around the
// reference's frictionless point.
PathStats run_random_path(const TriangleMesh& m, MeshMode mode, MeshFriction friction, std::mt19937_64& rng,
                          const Eigen::Vector3d& start, double waypoint_min, double waypoint_max, bool height_field) {
    const auto faces = ref::faces(m);
    GodObjectProxy proxy(MeshHierarchy::build(m, mode), friction);
    proxy.reset(start);
    PathStats stats;
    std::uniform_real_distribution<double> radius(waypoint_min, waypoint_max), u(-1.0, 1.0);
    Eigen::Vector3d handle = start;
    for (int leg = 0; leg < 40; ++leg) {
        Eigen::Vector3d waypoint = radius(rng) * Eigen::Vector3d(u(rng), u(rng), u(rng)).normalized();
        if (height_field) waypoint = Eigen::Vector3d(0.6 * waypoint.x(), 0.6 * waypoint.y(), 0.3 * waypoint.z());
        const int steps = static_cast<int>((waypoint - handle).norm() / 5e-4) + 1;
        const Eigen::Vector3d from = handle;
        for (int k = 1; k <= steps; ++k) {
            handle = from + (waypoint - from) * (static_cast<double>(k) / steps);
            const ProxyContact& c = proxy.step(handle);
            ++stats.steps;
            if (c.constraints > 0) ++stats.in_contact;
            if (!c.converged) continue;
            ++stats.converged;
            // Frictionless: the planes the proxy is on (1e-9 m: 1e3 times the rounding of a point put there); with
            // friction also those up to half an offset below (where it may stick).
            const bool frictionless = friction.static_coefficient == 0.0;
            const auto planes = ref::resting_planes(faces, c.proxy, kSurfaceOffset, kReach,
                                                    frictionless ? kSurfaceOffset - 1e-9 : 0.5 * kSurfaceOffset);
            const Eigen::Vector3d closest = planes.empty() ? handle : ref::closest_feasible_point(planes, handle);
            if (frictionless) {
                EXPECT_LT((c.proxy - closest).norm(), kSamePoint)
                    << "step " << stats.steps << ": proxy " << c.proxy.transpose() << ", reference "
                    << closest.transpose() << ", handle " << handle.transpose() << ", " << planes.size()
                    << " resting planes, " << c.constraints << " constraints, " << c.sweeps << " sweeps";
            } else {
                // Inside the static cone around the frictionless point of some subset of the resting planes (at
                // a convex edge the proxy rests on both planes but only one of them constrains its way on).
                double margin = HUGE_VAL;
                for (unsigned subset = 1; subset < (1u << planes.size()); ++subset) {
                    std::vector<ref::HalfSpace> some;
                    for (std::size_t i = 0; i < planes.size(); ++i)
                        if ((subset >> i) & 1u) some.push_back(planes[i]);
                    const Eigen::Vector3d t = ref::closest_feasible_point(some, handle);
                    margin = std::min(margin, (c.proxy - t).norm() -
                                                  friction.static_coefficient * (handle - t).norm());
                }
                if (planes.empty()) margin = (c.proxy - handle).norm();
                EXPECT_LE(margin, kSamePoint) << "step " << stats.steps << ": outside the static friction cone, "
                                              << planes.size() << " resting planes, " << c.constraints
                                              << " constraints, sliding " << c.sliding << ", " << c.sweeps
                                              << " sweeps, proxy " << c.proxy.transpose() << ", handle "
                                              << handle.transpose();
            }
            if (height_field) {
                EXPECT_GE(c.proxy.z(), ref::surface_height(faces, c.proxy.x(), c.proxy.y()) - 1e-12)
                    << "step " << stats.steps << ": the proxy went below the height field";
            }
            ++stats.checked;
        }
    }
    return stats;
}

void expect_mostly_converged(const PathStats& s) {
    EXPECT_GT(s.in_contact, s.steps / 5) << "the paths must spend time in contact";
    // Bounded work per step: the proxy may leave a step unfinished (and finish it at the next); it does so rarely.
    EXPECT_GE(s.converged, s.steps * 99 / 100) << s.converged << " of " << s.steps << " steps converged";
}

TEST(GodObjectProxy, FrictionlessProxyIsTheConstrainedClosestPointOnClosedMeshes) {
    std::mt19937_64 rng(2024);
    for (int i = 0; i < 4; ++i) {
        const TriangleMesh m = ref::bumpy_sphere(0.05, 2 + i % 2, 0.2, rng);
        ASSERT_FALSE(mesh_error(m, MeshMode::solid).has_value());
        const PathStats s = run_random_path(m, MeshMode::solid, {}, rng, {0, 0, 0.1}, 0.03, 0.07, false);
        expect_mostly_converged(s);
        RecordProperty("mesh" + std::to_string(i) + "_checked", s.checked);
    }
}

TEST(GodObjectProxy, FrictionlessProxyIsTheConstrainedClosestPointOnSurfaces) {
    std::mt19937_64 rng(77);
    for (int i = 0; i < 3; ++i) {
        const TriangleMesh m = ref::height_field(0.05, 16, 0.006, rng);
        const PathStats s = run_random_path(m, MeshMode::surface, {}, rng, {0, 0, 0.03}, 0.0, 0.05, true);
        expect_mostly_converged(s);
    }
}

TEST(GodObjectProxy, FrictionKeepsTheProxyInTheStaticConeOnRandomMeshes) {
    std::mt19937_64 rng(99);
    for (int i = 0; i < 3; ++i) {
        const TriangleMesh m = ref::bumpy_sphere(0.05, 3, 0.15, rng);
        const PathStats s =
            run_random_path(m, MeshMode::solid, {0.6, 0.4}, rng, {0, 0.1, 0}, 0.03, 0.07, false);
        expect_mostly_converged(s);
    }
    for (int i = 0; i < 2; ++i) {
        const TriangleMesh m = ref::height_field(0.05, 16, 0.006, rng);
        const PathStats s = run_random_path(m, MeshMode::surface, {0.8, 0.5}, rng, {0, 0, 0.03}, 0.0, 0.05, true);
        expect_mostly_converged(s);
    }
}

TEST(GodObjectProxy, FrictionOnAPlaneFollowsTheCoulombCone) {
    // The top face of a large box (z = 0.05): pressed 2 mm deep, the handle moves along x. Sticking while
    // |x_proxy - x_handle| <= mu_s * 2 mm, then sliding with the proxy mu_d * 2 mm behind the handle.
    const double mu_s = 0.5, mu_d = 0.3, depth = 2e-3, top = 0.05;
    GodObjectProxy proxy(MeshHierarchy::build(box({0.2, 0.2, top}, 4), MeshMode::solid), {mu_s, mu_d});
    proxy.reset({0.01, 0.003, top + 0.01});
    proxy.step({0.01, 0.003, top + 0.005});
    const ProxyContact& pressed = proxy.step({0.01, 0.003, top - depth});
    EXPECT_EQ(pressed.constraints, 1);
    EXPECT_NEAR(pressed.proxy.z(), top + kSurfaceOffset, 1e-15);
    const double contact_x = pressed.proxy.x();
    EXPECT_NEAR(contact_x, 0.01, 1e-12);
    const double penetration = depth + kSurfaceOffset;
    bool slid = false;
    for (int k = 1; k <= 400; ++k) {
        const double x = 0.01 + 1e-5 * k;  // 10 mm/s
        const ProxyContact& c = proxy.step({x, 0.003, top - depth});
        ASSERT_TRUE(c.converged);
        EXPECT_NEAR(c.proxy.z(), top + kSurfaceOffset, 1e-15);
        EXPECT_NEAR(c.proxy.y(), 0.003, 1e-15);
        if (x - contact_x <= mu_s * penetration - 1e-12 && !slid) {
            EXPECT_EQ(c.proxy.x(), contact_x) << "stuck while inside the static cone, step " << k;
            EXPECT_FALSE(c.sliding);
        } else if (x - contact_x > mu_s * penetration + 1e-12) {
            slid = true;
            EXPECT_NEAR(x - c.proxy.x(), mu_d * penetration, 1e-12) << "sliding on the dynamic cone, step " << k;
            EXPECT_TRUE(c.sliding);
        }
    }
    EXPECT_TRUE(slid);
    // Stopping the handle: the proxy stays (mu_d * penetration <= mu_d * penetration), no creep.
    const Eigen::Vector3d rest = proxy.contact().proxy;
    for (int k = 0; k < 10; ++k) EXPECT_EQ(proxy.step({0.014, 0.003, top - depth}).proxy, rest);
}

TEST(GodObjectProxy, SphereMeshMatchesTheAnalyticSphere) {
    // Icosphere of radius 5 cm, 5120 triangles: the mesh lies between the spheres of radius R - s and R, s its
    // largest deviation (sagitta). Pressed radially d = 3 mm deep at random directions, the proxy's offset from the
    // handle is the analytic sphere's (R - |h|) along the radius within s + offset in magnitude, and its direction
    // within the largest angle between a triangle's normal and the radius through any of its points.
    const double R = 0.05, d = 3e-3;
    const int subdivisions = 4;
    const TriangleMesh m = icosphere(R, subdivisions);
    const double sagitta = icosphere_max_deviation(R, subdivisions);
    double max_angle = 0.0;  // the largest angle between a triangle's normal and its vertices' radii
    for (const auto& t : m.triangles) {
        const Eigen::Vector3d n =
            (m.vertices[t[1]] - m.vertices[t[0]]).cross(m.vertices[t[2]] - m.vertices[t[0]]).normalized();
        for (const auto v : t) max_angle = std::max(max_angle, std::acos(std::min(1.0, n.dot(m.vertices[v]) / R)));
    }
    GodObjectProxy proxy(MeshHierarchy::build(m, MeshMode::solid), {});
    std::mt19937_64 rng(5);
    std::normal_distribution<double> g;
    double worst_magnitude = 0.0, worst_angle = 0.0;
    for (int k = 0; k < 300; ++k) {
        const Eigen::Vector3d radial = Eigen::Vector3d(g(rng), g(rng), g(rng)).normalized();
        proxy.reset(1.1 * R * radial);
        for (int j = 1; j <= 20; ++j) proxy.step(R * radial * (1.1 - (0.1 + d / R) * j / 20.0));
        const Eigen::Vector3d handle = (R - d) * radial;
        const ProxyContact& c = proxy.step(handle);
        ASSERT_TRUE(c.converged);
        ASSERT_GE(c.constraints, 1);
        const Eigen::Vector3d offset = c.proxy - handle;
        worst_magnitude = std::max(worst_magnitude, std::abs(offset.norm() - d));
        worst_angle = std::max(worst_angle, std::acos(std::min(1.0, offset.normalized().dot(radial))));
    }
    EXPECT_LE(worst_magnitude, sagitta + kSurfaceOffset + 1e-12) << "sagitta " << sagitta;
    EXPECT_LE(worst_angle, max_angle + 1e-12) << "largest normal-radius angle " << max_angle;
    RecordProperty("worst_magnitude_error_m", std::to_string(worst_magnitude));
    RecordProperty("worst_angle_rad", std::to_string(worst_angle));
}

TEST(GodObjectProxy, BoxMatchesItsSixPlanes) {
    // Pressed into each face away from its edges, the proxy is the handle projected on that face's plane (moved
    // out by the offset), as a unilateral wall on the plane renders: force K (proxy - handle) along the normal.
    const Eigen::Vector3d half(0.03, 0.02, 0.04);
    GodObjectProxy proxy(MeshHierarchy::build(box(half, 3), MeshMode::solid), {});
    std::mt19937_64 rng(8);
    std::uniform_real_distribution<double> u(-0.7, 0.7), depth(1e-4, 5e-3);
    int checked = 0;
    for (int axis = 0; axis < 3; ++axis) {
        for (const double side : {-1.0, 1.0}) {
            for (int k = 0; k < 30; ++k) {
                Eigen::Vector3d handle(u(rng) * half.x(), u(rng) * half.y(), u(rng) * half.z());
                handle[axis] = side * (half[axis] + 0.01);
                proxy.reset(handle);
                const double dd = depth(rng);
                for (int j = 1; j <= 10; ++j) {
                    handle[axis] = side * (half[axis] + 0.01 - (0.01 + dd) * j / 10.0);
                    proxy.step(handle);
                }
                // Tangential moves inside the face's inner part.
                for (int j = 0; j < 10; ++j) {
                    handle[(axis + 1) % 3] *= 0.95;
                    handle[(axis + 2) % 3] *= 0.9;
                    const ProxyContact& c = proxy.step(handle);
                    Eigen::Vector3d plane_point = handle;
                    plane_point[axis] = side * (half[axis] + kSurfaceOffset);
                    EXPECT_LT((c.proxy - plane_point).norm(), 1e-12);
                    ASSERT_EQ(c.constraints, 1);
                    EXPECT_EQ(c.normals[0], side * Eigen::Vector3d::Unit(axis));
                    ++checked;
                }
            }
        }
    }
    EXPECT_EQ(checked, 1800);
}

TEST(GodObjectProxy, ConcaveCornerHoldsThreeConstraints) {
    // The inside of a box (a one-sided surface facing inward): the handle pushed past a corner leaves the proxy in
    // the corner of the three offset planes, with their three normals; pushed past an edge, on the edge's line.
    const Eigen::Vector3d half(0.02, 0.02, 0.02);
    TriangleMesh inside = box(half, 2);
    for (auto& t : inside.triangles) std::swap(t[1], t[2]);
    GodObjectProxy proxy(MeshHierarchy::build(inside, MeshMode::surface), {});
    proxy.reset({0, 0, 0});
    const Eigen::Vector3d corner_handle(0.023, 0.0215, 0.025);
    for (int j = 1; j <= 30; ++j) proxy.step(corner_handle * (j / 30.0));
    const ProxyContact& c = proxy.step(corner_handle);
    ASSERT_TRUE(c.converged);
    EXPECT_EQ(c.constraints, 3);
    EXPECT_LT((c.proxy - Eigen::Vector3d::Constant(0.02 - kSurfaceOffset)).norm(), 1e-12) << c.proxy.transpose();
    const Eigen::Vector3d edge_handle(0.023, 0.0215, 0.01);
    for (int j = 1; j <= 30; ++j) proxy.step(corner_handle + (edge_handle - corner_handle) * (j / 30.0));
    const ProxyContact& e = proxy.step(edge_handle);
    EXPECT_EQ(e.constraints, 2);
    EXPECT_LT((e.proxy - Eigen::Vector3d(0.02 - kSurfaceOffset, 0.02 - kSurfaceOffset, 0.01)).norm(), 1e-12)
        << e.proxy.transpose();
}

TEST(GodObjectProxy, OneSidedSurfaceStopsFromTheFrontOnly) {
    // A square at z = 0 facing +z.
    TriangleMesh m;
    m.vertices = {{-0.05, -0.05, 0}, {0.05, -0.05, 0}, {0.05, 0.05, 0}, {-0.05, 0.05, 0}};
    m.triangles = {{0, 1, 2}, {0, 2, 3}};
    GodObjectProxy proxy(MeshHierarchy::build(m, MeshMode::surface), {});
    proxy.reset({0.01, 0.01, 0.01});
    const ProxyContact& front = proxy.step({0.01, 0.01, -0.002});
    EXPECT_NEAR(front.proxy.z(), kSurfaceOffset, 1e-15);
    EXPECT_EQ(front.constraints, 1);
    // From behind the proxy passes through and is free.
    proxy.reset({0.01, 0.01, -0.01});
    const ProxyContact& back = proxy.step({0.01, 0.01, 0.002});
    EXPECT_EQ(back.proxy, Eigen::Vector3d(0.01, 0.01, 0.002));
    EXPECT_EQ(back.constraints, 0);
    EXPECT_EQ(back.triangle, UINT32_MAX);
}

TEST(GodObjectProxy, NonFiniteHandleLeavesTheProxy) {
    GodObjectProxy proxy(MeshHierarchy::build(icosphere(0.05, 2), MeshMode::solid), {});
    proxy.reset({0, 0, 0.06});
    const Eigen::Vector3d before = proxy.step({0, 0, 0.049}).proxy;
    EXPECT_EQ(proxy.step({NAN, 0, 0}).proxy, before);
    EXPECT_EQ(proxy.step({0, INFINITY, 0}).proxy, before);
}

}  // namespace
}  // namespace hapticd::mesh
