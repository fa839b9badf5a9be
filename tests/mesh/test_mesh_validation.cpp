// SPDX-License-Identifier: Apache-2.0
// mesh_error: every rejected input named with its parameter and accepted range; the procedural meshes accepted
// in both modes; an open, non-manifold, inconsistently or inward wound mesh refused in solid mode only.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <string>

#include "mesh/procedural_meshes.hpp"
#include "mesh/triangle_mesh.hpp"
#include "mesh/weld_vertices.hpp"

namespace hapticd::mesh {
namespace {

TriangleMesh tetrahedron() {
    TriangleMesh m;
    m.vertices = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
    // Outward: the face on z = 0 faces -z, so it is wound (0, 2, 1).
    m.triangles = {{0, 2, 1}, {0, 1, 3}, {0, 3, 2}, {1, 2, 3}};
    return m;
}

std::string error_of(const TriangleMesh& m, MeshMode mode, const MeshLimits& limits = {}) {
    const auto e = mesh_error(m, mode, limits);
    return e ? *e : std::string();
}

TEST(MeshValidation, ClosedMeshesAreValidInBothModes) {
    for (const TriangleMesh& m :
         {tetrahedron(), icosphere(0.05, 3), box({0.03, 0.02, 0.01}, 3), torus(0.05, 0.02, 24, 12)}) {
        EXPECT_EQ(error_of(m, MeshMode::solid), "");
        EXPECT_EQ(error_of(m, MeshMode::surface), "");
    }
}

TEST(MeshValidation, EmptyAndTooLargeMeshesNameTheLimit) {
    TriangleMesh empty;
    empty.vertices = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
    EXPECT_NE(error_of(empty, MeshMode::surface).find("triangles: none, accepted 1..200000"), std::string::npos);
    const TriangleMesh sphere = icosphere(0.05, 3);  // 1280 triangles, 642 vertices
    EXPECT_NE(error_of(sphere, MeshMode::solid, {.max_vertices = 1000, .max_triangles = 1000})
                  .find("triangles: 1280, accepted 1..1000"),
              std::string::npos);
    EXPECT_NE(error_of(sphere, MeshMode::solid, {.max_vertices = 600, .max_triangles = 2000})
                  .find("vertices: 642, accepted 3..600"),
              std::string::npos);
    EXPECT_EQ(error_of(sphere, MeshMode::solid, {.max_vertices = 642, .max_triangles = 1280}), "");
}

TEST(MeshValidation, NonFiniteAndFarVerticesAreNamed) {
    for (const double bad : {std::numeric_limits<double>::quiet_NaN(), std::numeric_limits<double>::infinity(),
                             -std::numeric_limits<double>::infinity(), 100.5}) {
        TriangleMesh m = tetrahedron();
        m.vertices[2].y() = bad;
        const std::string e = error_of(m, MeshMode::surface);
        EXPECT_NE(e.find("vertex 2 coordinate y"), std::string::npos) << e;
        EXPECT_NE(e.find("accepted a finite number in [-100, 100] m"), std::string::npos) << e;
    }
}

TEST(MeshValidation, IndexOutOfRangeIsNamed) {
    TriangleMesh m = tetrahedron();
    m.triangles[3][1] = 4;
    const std::string e = error_of(m, MeshMode::surface);
    EXPECT_NE(e.find("triangle 3 vertex index 1 = 4, accepted 0..3"), std::string::npos) << e;
}

TEST(MeshValidation, DegenerateTrianglesAreRefused) {
    TriangleMesh repeated = tetrahedron();
    repeated.triangles[1] = {0, 1, 1};
    EXPECT_NE(error_of(repeated, MeshMode::surface).find("triangle 1 (0, 1, 1) is degenerate"), std::string::npos);
    TriangleMesh collinear = tetrahedron();
    collinear.vertices.push_back({2, 0, 0});  // on the line of vertices 0 and 1
    collinear.triangles.push_back({0, 1, 4});
    EXPECT_NE(error_of(collinear, MeshMode::surface).find("triangle 4 (0, 1, 4) is degenerate"), std::string::npos);
    TriangleMesh coincident = tetrahedron();
    coincident.vertices.push_back({1, 0, 0});  // the same point as vertex 1
    coincident.triangles.push_back({0, 1, 4});
    EXPECT_NE(error_of(coincident, MeshMode::surface).find("is degenerate"), std::string::npos);
    // A thin but real triangle (1e-6 m high on a 1 m base: 1e-6 rad) is accepted.
    TriangleMesh thin;
    thin.vertices = {{0, 0, 0}, {1, 0, 0}, {0.5, 1e-6, 0}};
    thin.triangles = {{0, 1, 2}};
    EXPECT_EQ(error_of(thin, MeshMode::surface), "");
}

TEST(MeshValidation, SolidModeRefusesOpenMeshes) {
    TriangleMesh open = tetrahedron();
    open.triangles.pop_back();
    EXPECT_EQ(error_of(open, MeshMode::surface), "");
    const std::string e = error_of(open, MeshMode::solid);
    EXPECT_NE(e.find("mode solid"), std::string::npos) << e;
    EXPECT_NE(e.find("open"), std::string::npos) << e;
}

TEST(MeshValidation, SolidModeRefusesUnweldedMeshes) {
    // The tetrahedron with its last face on its own copies of the vertices (as an STL file stores it).
    TriangleMesh m = tetrahedron();
    m.vertices.push_back(m.vertices[1]);
    m.vertices.push_back(m.vertices[2]);
    m.vertices.push_back(m.vertices[3]);
    m.triangles[3] = {4, 5, 6};
    EXPECT_EQ(error_of(m, MeshMode::surface), "");
    EXPECT_NE(error_of(m, MeshMode::solid).find("weld duplicate vertices"), std::string::npos);
}

TEST(MeshValidation, SolidModeRefusesInconsistentWinding) {
    TriangleMesh m = tetrahedron();
    std::swap(m.triangles[2][1], m.triangles[2][2]);  // one face flipped
    const std::string e = error_of(m, MeshMode::solid);
    EXPECT_NE(e.find("same direction"), std::string::npos) << e;
}

TEST(MeshValidation, SolidModeRefusesNonManifoldEdges) {
    // Two tetrahedra sharing the edge (0, 1) and nothing else: four triangles on that edge.
    TriangleMesh m = tetrahedron();
    m.vertices.push_back({0.5, -1, 0.2});
    m.vertices.push_back({0.5, -1, -0.8});
    const TriangleMesh other = [] {
        TriangleMesh t;
        t.vertices = {{0, 0, 0}, {1, 0, 0}, {0.5, -1, 0.2}, {0.5, -1, -0.8}};
        t.triangles = {{0, 2, 1}, {0, 1, 3}, {0, 3, 2}, {1, 2, 3}};
        return t;
    }();
    const auto solid_volume_sign = [](const TriangleMesh& t) {
        double v = 0;
        for (const auto& tri : t.triangles) v += t.vertices[tri[0]].dot(t.vertices[tri[1]].cross(t.vertices[tri[2]]));
        return v;
    };
    ASSERT_NE(solid_volume_sign(other), 0.0);
    for (auto tri : other.triangles) {
        for (auto& i : tri) i = i < 2 ? i : i + 2;
        if (solid_volume_sign(other) < 0) std::swap(tri[1], tri[2]);
        m.triangles.push_back(tri);
    }
    const std::string e = error_of(m, MeshMode::solid);
    EXPECT_NE(e.find("mode solid"), std::string::npos) << e;
    EXPECT_TRUE(e.find("same direction") != std::string::npos || e.find("no neighbour") != std::string::npos) << e;
}

TEST(MeshValidation, SolidModeRefusesInwardWinding) {
    TriangleMesh m = icosphere(0.05, 2);
    for (auto& t : m.triangles) std::swap(t[1], t[2]);
    EXPECT_EQ(error_of(m, MeshMode::surface), "");
    const std::string e = error_of(m, MeshMode::solid);
    EXPECT_NE(e.find("enclosed volume is -"), std::string::npos) << e;
    EXPECT_NE(e.find("accepted > 0"), std::string::npos) << e;
}

TEST(MeshValidation, SolidModeRefusesSelfIntersection) {
    // Two closed spheres in one mesh: apart they are a valid solid; overlapping, their surfaces cross. The offset is
    // not along an axis of symmetry (mirror-image meshes would cross exactly on their edges).
    const auto two_spheres = [](double gap) {
        TriangleMesh a = icosphere(0.02, 2);
        const TriangleMesh b = icosphere(0.02, 2);
        const auto base = static_cast<std::uint32_t>(a.vertices.size());
        for (const auto& v : b.vertices) a.vertices.push_back(v + Eigen::Vector3d(0.04 + gap, 0.0037, 0.0021));
        for (auto t : b.triangles) a.triangles.push_back({t[0] + base, t[1] + base, t[2] + base});
        return a;
    };
    EXPECT_EQ(error_of(two_spheres(0.001), MeshMode::solid), "");
    const std::string e = error_of(two_spheres(-0.01), MeshMode::solid);
    EXPECT_NE(e.find("intersects itself"), std::string::npos) << e;
    EXPECT_EQ(error_of(two_spheres(-0.01), MeshMode::surface), "");  // surfaces may cross
    // A torus is no self-intersection (its inner faces come close across the hole but do not cross).
    EXPECT_EQ(error_of(torus(0.05, 0.02, 33, 16), MeshMode::solid), "");
}

TEST(MeshValidation, WeldingMakesAnUnweldedSolidValid) {
    // Every triangle of a box on its own three vertices (as in an STL file), one of them written as -0.
    const TriangleMesh welded = box({0.03, 0.02, 0.01}, 2);
    TriangleMesh soup;
    for (const auto& t : welded.triangles) {
        const auto base = static_cast<std::uint32_t>(soup.vertices.size());
        for (const auto v : t) soup.vertices.push_back(welded.vertices[v]);
        soup.triangles.push_back({base, base + 1, base + 2});
    }
    for (auto& v : soup.vertices)
        if (v.x() == 0.0) v.x() = -0.0;
    EXPECT_NE(error_of(soup, MeshMode::solid).find("weld duplicate vertices"), std::string::npos);
    const TriangleMesh rewelded = weld_vertices(soup);
    EXPECT_EQ(rewelded.vertices.size(), welded.vertices.size());
    EXPECT_EQ(rewelded.triangles.size(), welded.triangles.size());
    EXPECT_EQ(error_of(rewelded, MeshMode::solid), "");
    // Same triangles, same corners' positions.
    for (std::size_t i = 0; i < soup.triangles.size(); ++i)
        for (int k = 0; k < 3; ++k)
            EXPECT_EQ(rewelded.vertices[rewelded.triangles[i][k]], soup.vertices[soup.triangles[i][k]]);
    // An index out of range stays out of range.
    soup.triangles[0][1] = 999999;
    EXPECT_NE(error_of(weld_vertices(soup), MeshMode::surface).find("vertex index 1"), std::string::npos);
}

}  // namespace
}  // namespace hapticd::mesh
