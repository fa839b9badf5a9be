// SPDX-License-Identifier: Apache-2.0
// The procedural meshes: counts, closed and outward (mesh_error, solid mode), enclosed volume against the
// analytic solid's within the tessellation's error, vertices on the analytic surface.
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

#include "mesh/procedural_meshes.hpp"

namespace hapticd::mesh {
namespace {

double volume(const TriangleMesh& m) {
    double v = 0;
    for (const auto& t : m.triangles) v += m.vertices[t[0]].dot(m.vertices[t[1]].cross(m.vertices[t[2]])) / 6.0;
    return v;
}

TEST(ProceduralMeshes, IcosphereCountsVerticesAndVolume) {
    for (int s = 0; s <= 5; ++s) {
        const double r = 0.05;
        const TriangleMesh m = icosphere(r, s);
        EXPECT_EQ(m.triangles.size(), 20u << (2 * s));
        EXPECT_EQ(m.vertices.size(), 10u * (1u << (2 * s)) + 2u);
        EXPECT_FALSE(mesh_error(m, MeshMode::solid).has_value());
        for (const auto& v : m.vertices) EXPECT_NEAR(v.norm(), r, 1e-15);
        // The inscribed polyhedron's volume lies between the spheres of radius r - deviation and r.
        const double deviation = icosphere_max_deviation(r, s);
        const double sphere = 4.0 / 3.0 * std::numbers::pi;
        EXPECT_LT(volume(m), sphere * r * r * r);
        EXPECT_GT(volume(m), sphere * std::pow(r - deviation, 3));
    }
    // The sagitta shrinks about 4 times per subdivision.
    EXPECT_NEAR(icosphere_max_deviation(1, 5) / icosphere_max_deviation(1, 4), 0.25, 0.03);
}

TEST(ProceduralMeshes, BoxIsExact) {
    for (int cells : {1, 2, 5}) {
        const TriangleMesh m = box({0.03, 0.02, 0.01}, cells);
        EXPECT_EQ(m.triangles.size(), 12u * cells * cells);
        EXPECT_EQ(m.vertices.size(), 6u * cells * cells + 2u);  // Euler: V - E + F = 2, E = 3F/2
        EXPECT_FALSE(mesh_error(m, MeshMode::solid).has_value());
        EXPECT_NEAR(volume(m), 0.06 * 0.04 * 0.02, 1e-18);
    }
}

TEST(ProceduralMeshes, TorusVolume) {
    const double R = 0.05, r = 0.02;
    const TriangleMesh m = torus(R, r, 128, 64);
    EXPECT_EQ(m.triangles.size(), 2u * 128 * 64);
    EXPECT_FALSE(mesh_error(m, MeshMode::solid).has_value());
    // Pappus: 2 pi^2 R r^2; the inscribed polygons lose about (2 pi^2 / 3)(1/128^2 + 1/64^2) = 0.20 % of it.
    const double exact = 2.0 * std::numbers::pi * std::numbers::pi * R * r * r;
    EXPECT_LT(volume(m), exact);
    EXPECT_GT(volume(m), 0.997 * exact);
}

}  // namespace
}  // namespace hapticd::mesh
