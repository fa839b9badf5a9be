// SPDX-License-Identifier: Apache-2.0
// Force shading's corner normals (src/mesh/vertex_normals.hpp): radial on a procedural sphere within the bound the
// angle-weighted average implies, every shaded normal within the crease angle of its face's normal (the bound the
// stability argument uses, docs/mesh-rendering.md "Force shading"), a box's edges kept sharp, the crease rule.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <numbers>
#include <random>

#include "mesh/procedural_meshes.hpp"
#include "mesh/vertex_normals.hpp"

namespace hapticd::mesh {
namespace vertex_normals_test {

double angle_between(const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
    return std::atan2(a.cross(b).norm(), a.dot(b));
}

// Each corner normal is a non-negative sum of the unit normals of the faces around the vertex; each of those is within
// delta of the vertex's radius, delta the largest angle between a face's normal and its vertices' radii (measured
// here over the mesh), so the sum is too (the cone of half-angle delta < 90 deg is convex). The test requires that
// bound (+1e-12 for the normals' rounding) and prints the measured angle, far below it: around an icosphere's vertex
// the faces are nearly symmetric, their tilts cancel.
TEST(VertexNormals, AnIcospheresCornerNormalsPointRadiallyWithinTheFacesLargestTilt) {
    for (const int subdivisions : {2, 3, 4}) {
        const TriangleMesh m = icosphere(0.05, subdivisions);
        const ShadingNormals s = shading_normals(m, 30.0);
        double delta = 0.0, worst = 0.0;
        for (std::size_t f = 0; f < m.triangles.size(); ++f) {
            for (const std::uint32_t v : m.triangles[f])
                delta = std::max(delta, angle_between(s.face[f], m.vertices[v]));
        }
        for (std::size_t f = 0; f < m.triangles.size(); ++f) {
            EXPECT_EQ(s.smooth[f], 1) << f;
            for (std::size_t k = 0; k < 3; ++k) {
                const double a = angle_between(s.corners[f][k], m.vertices[m.triangles[f][k]]);
                EXPECT_LE(a, delta + 1e-12) << "triangle " << f << " corner " << k;
                EXPECT_NEAR(s.corners[f][k].norm(), 1.0, 1e-15);
                worst = std::max(worst, a);
            }
        }
        // Angle-weighted: a vertex's normal does not depend on which face asks (every face around it is within the
        // crease on a sphere this fine: the dihedral angles are < 30 deg), so shading is continuous across edges.
        std::printf(
            "[ icosphere s=%d ] %zu triangles: largest face tilt %.3e rad, largest corner-normal angle to the "
            "radius %.3e rad\n",
            subdivisions, m.triangles.size(), delta, worst);
        EXPECT_LT(worst, 0.5 * delta);
    }
}

// n_s . n_f >= cos theta_c at random points of every triangle (and slightly beyond its edges, where the proxy may
// rest): the interval of the gains' scale the server certifies. Meshes: a torus (curved in two directions, some
// neighbours beyond a small crease) and icospheres at crease angles 10 .. 80 deg.
TEST(VertexNormals, EveryShadedNormalLiesWithinTheCreaseAngleOfItsFacesNormal) {
    std::mt19937 rng(40);
    std::uniform_real_distribution<double> u(-0.1, 1.1);
    int samples = 0;
    for (const double crease : {10.0, 30.0, 60.0, 80.0}) {
        for (const TriangleMesh& m : {torus(0.06, 0.02, 24, 8), icosphere(0.05, 1), icosphere(0.05, 0)}) {
            const ShadingNormals s = shading_normals(m, crease);
            const double c = std::cos(crease * std::numbers::pi / 180.0);
            for (std::uint32_t f = 0; f < m.triangles.size(); ++f) {
                const Eigen::Vector3d& a = m.vertices[m.triangles[f][0]];
                const Eigen::Vector3d& b = m.vertices[m.triangles[f][1]];
                const Eigen::Vector3d& cc = m.vertices[m.triangles[f][2]];
                for (std::size_t k = 0; k < 3; ++k) EXPECT_GE(s.corners[f][k].dot(s.face[f]), c - 1e-12);
                for (int j = 0; j < 20; ++j) {
                    const Eigen::Vector3d x = a + u(rng) * (b - a) + u(rng) * (cc - a) + 1e-6 * s.face[f];
                    const Eigen::Vector3d n = shaded_normal(s, m, f, x);
                    EXPECT_NEAR(n.norm(), 1.0, 1e-15);
                    EXPECT_GE(n.dot(s.face[f]), c - 1e-12) << "crease " << crease << " triangle " << f;
                    ++samples;
                }
            }
        }
    }
    EXPECT_GT(samples, 10000);
}

// At a vertex the interpolated normal is that corner's normal; at the centroid the normalised mean of the three.
TEST(VertexNormals, TheShadedNormalInterpolatesTheCornersBarycentrically) {
    const TriangleMesh m = icosphere(0.05, 2);
    const ShadingNormals s = shading_normals(m, 30.0);
    for (std::uint32_t f = 0; f < m.triangles.size(); f += 7) {
        for (std::size_t k = 0; k < 3; ++k) {
            EXPECT_LT((shaded_normal(s, m, f, m.vertices[m.triangles[f][k]]) - s.corners[f][k]).norm(), 1e-12);
        }
        const Eigen::Vector3d centroid =
            (m.vertices[m.triangles[f][0]] + m.vertices[m.triangles[f][1]] + m.vertices[m.triangles[f][2]]) / 3.0;
        const Eigen::Vector3d mean = (s.corners[f][0] + s.corners[f][1] + s.corners[f][2]).normalized();
        EXPECT_LT((shaded_normal(s, m, f, centroid) - mean).norm(), 1e-12);
    }
}

// A box at crease 30 deg: faces meet at 90 deg, so every corner normal is its face's own (bitwise) and no triangle
// is smooth: the box renders exactly as without shading. At crease 80 deg the same (90 > 80). The icosahedron's
// neighbours' normals are 41.8 deg apart and the faces sharing only a vertex 70.5 deg: sharp at 30 deg; at 45 deg a
// corner blends the face with its two neighbours there (not radial: 0.39 rad off); at 75 deg all five (radial).
TEST(VertexNormals, ABoxKeepsItsEdgesAndTheCreaseAngleDecidesWhichFacesBlend) {
    for (const int cells : {1, 4}) {
        const TriangleMesh m = box({0.02, 0.03, 0.025}, cells);
        for (const double crease : {30.0, 80.0}) {
            const ShadingNormals s = shading_normals(m, crease);
            for (std::size_t f = 0; f < m.triangles.size(); ++f) {
                EXPECT_EQ(s.smooth[f], 0) << f;
                for (std::size_t k = 0; k < 3; ++k) EXPECT_EQ(s.corners[f][k], s.face[f]);
            }
        }
    }
    const TriangleMesh ico = icosphere(0.05, 0);
    const ShadingNormals sharp = shading_normals(ico, 30.0), partial = shading_normals(ico, 45.0),
                         smooth = shading_normals(ico, 75.0);
    for (std::size_t f = 0; f < ico.triangles.size(); ++f) {
        EXPECT_EQ(sharp.smooth[f], 0);
        EXPECT_EQ(partial.smooth[f], 1);
        EXPECT_EQ(smooth.smooth[f], 1);
        for (std::size_t k = 0; k < 3; ++k) {
            EXPECT_GT(angle_between(partial.corners[f][k], ico.vertices[ico.triangles[f][k]]), 0.3);
            EXPECT_LT(angle_between(smooth.corners[f][k], ico.vertices[ico.triangles[f][k]]), 1e-12);
        }
    }
}

}  // namespace vertex_normals_test
}  // namespace hapticd::mesh
