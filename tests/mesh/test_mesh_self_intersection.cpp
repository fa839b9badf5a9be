// SPDX-License-Identifier: Apache-2.0
// mesh_error's self-intersection rules in solid mode (docs/mesh-rendering.md, "The mesh"): two triangles sharing
// one vertex whose interiors cross, coplanar overlaps (disjoint triangles, a face folded back onto its neighbour
// across their shared edge, a face twice) are refused naming the rule and both triangles; meshes that only touch
// (a shared vertex, a vertex on a face, a thin wedge, faces a nanometre apart) and the procedural meshes up to a
// 100 000-triangle torus are accepted. Each construct is a closed, outward-wound mesh (it passes the edge and volume
// rules), so only the self-intersection rules can refuse it.
#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <string>

#include "mesh/procedural_meshes.hpp"
#include "mesh/triangle_mesh.hpp"

namespace hapticd::mesh::self_intersection_test {

using Vec = Eigen::Vector3d;

std::string solid_error(const TriangleMesh& m) {
    const auto e = mesh_error(m, MeshMode::solid);
    return e ? *e : std::string();
}

std::uint32_t add_vertex(TriangleMesh& m, const Vec& p) {
    m.vertices.push_back(p);
    return static_cast<std::uint32_t>(m.vertices.size() - 1);
}

// The tetrahedron on vertices v (indices), its four faces wound outward; the first face is on v0, v1, v2.
void add_tetrahedron(TriangleMesh& m, const std::array<std::uint32_t, 4>& v) {
    const Vec& p0 = m.vertices[v[0]];
    const double volume = (m.vertices[v[1]] - p0).dot((m.vertices[v[2]] - p0).cross(m.vertices[v[3]] - p0));
    if (volume > 0) {
        m.triangles.insert(m.triangles.end(),
                           {{v[0], v[2], v[1]}, {v[0], v[1], v[3]}, {v[0], v[3], v[2]}, {v[1], v[2], v[3]}});
    } else {
        m.triangles.insert(m.triangles.end(),
                           {{v[0], v[1], v[2]}, {v[0], v[2], v[3]}, {v[0], v[3], v[1]}, {v[2], v[1], v[3]}});
    }
}

std::array<std::uint32_t, 4> add_points(TriangleMesh& m, const Vec& a, const Vec& b, const Vec& c, const Vec& d) {
    return {add_vertex(m, a), add_vertex(m, b), add_vertex(m, c), add_vertex(m, d)};
}

// Two tetrahedra on one vertex (index 0): tet A on (0, 1, 2, 3), tet B on (0, 4, 5, 6); triangle 0 is A's face
// (0, 1, 2), triangle 4 B's face (0, 4, 5).
TriangleMesh two_tetrahedra_on_a_vertex(const std::array<Vec, 7>& p) {
    TriangleMesh m;
    for (const auto& x : p) add_vertex(m, x);
    add_tetrahedron(m, {0, 1, 2, 3});
    add_tetrahedron(m, {0, 4, 5, 6});
    return m;
}

TEST(MeshSelfIntersection, TrianglesSharingAVertexThatCrossAreRefused) {
    // Faces (0, 1, 2) in the plane x = y and (0, 4, 5) in x = -y: an X through the shared vertex, crossing along
    // the segment from it to (0, 0, 1), where their opposite edges cross each other (no edge crosses the other
    // triangle's interior: the edge rule alone misses it).
    const TriangleMesh x = two_tetrahedra_on_a_vertex({Vec(0, 0, 0), Vec(-1, -1, 1), Vec(1, 1, 1), Vec(0.5, -0.5, 2),
                                                       Vec(-1, 1, 1), Vec(1, -1, 1), Vec(0.5, 0.5, 2)});
    const std::string e = solid_error(x);
    EXPECT_NE(e.find("mode solid: the mesh intersects itself: triangles 0 and 4, sharing vertex 0, cross"),
              std::string::npos)
        << e;
    EXPECT_EQ(mesh_error(x, MeshMode::surface), std::nullopt);
    // A fin folded through its neighbour: the same tetrahedron twice on vertex 0, the second turned by 0.3 rad
    // about an axis off its symmetry: their faces through vertex 0 cross along segments from it (here an edge
    // opposite vertex 0 also crosses the other face's interior; the shared-vertex rule is tested first and names
    // the pair).
    const Vec a1(1, 0, 0.1), a2(0, 1, 0.1), a3(0.3, 0.3, 1);
    const Eigen::Matrix3d turn = Eigen::AngleAxisd(0.3, Vec(1, 2, 3).normalized()).toRotationMatrix();
    const TriangleMesh fin = two_tetrahedra_on_a_vertex({Vec(0, 0, 0), a1, a2, a3, turn * a1, turn * a2, turn * a3});
    const std::string f = solid_error(fin);
    EXPECT_NE(f.find("intersects itself: triangles 0 and"), std::string::npos) << f;
    EXPECT_NE(f.find("sharing vertex 0, cross"), std::string::npos) << f;
    // Back to back on the shared vertex (B is A through the origin): they touch at the vertex only.
    const TriangleMesh bow_tie = two_tetrahedra_on_a_vertex({Vec(0, 0, 0), a1, a2, a3, -a1, -a2, -a3});
    EXPECT_EQ(solid_error(bow_tie), "");
    // Turned by 2 rad about z instead: the second tetrahedron beside the first, sharing the vertex only.
    const Eigen::Matrix3d beside = Eigen::AngleAxisd(2.0, Vec::UnitZ()).toRotationMatrix();
    EXPECT_EQ(
        solid_error(two_tetrahedra_on_a_vertex({Vec(0, 0, 0), a1, a2, a3, beside * a1, beside * a2, beside * a3})), "");
}

TEST(MeshSelfIntersection, CoplanarOverlapsAreRefused) {
    // Tet A below z = 0 and tet B above it, their bases (triangles 0 and 4) both on z = 0 and overlapping in part:
    // only the bases meet (the sides of A are below the plane, those of B above).
    TriangleMesh m;
    add_tetrahedron(m, add_points(m, Vec(0, 0, 0), Vec(1, 0, 0), Vec(0, 1, 0), Vec(0.2, 0.3, -1)));
    add_tetrahedron(m, add_points(m, Vec(0.3, 0.2, 0), Vec(1.3, 0.4, 0), Vec(0.5, 1.1, 0), Vec(0.6, 0.5, 1)));
    const std::string e = solid_error(m);
    EXPECT_NE(e.find("mode solid: the mesh overlaps itself: triangles 0 and 4, lie in one plane and their interiors "
                     "overlap"),
              std::string::npos)
        << e;
    // B moved off A's base in the plane (its nearest corner 0.05 beyond A's edge x + y = 1): touching nothing.
    for (std::size_t i = 4; i < 8; ++i) m.vertices[i] += Vec(0.55, 0.55, 0);
    EXPECT_EQ(solid_error(m), "");
}

TEST(MeshSelfIntersection, DuplicatedFacesAreRefusedAndFacesANanometreApartAccepted) {
    // Two unit tetrahedra glued by a face on their own vertices (unwelded): the face twice, wound oppositely.
    const auto glued = [](double gap) {
        TriangleMesh m;
        add_tetrahedron(m, add_points(m, Vec(0, 0, 0), Vec(1, 0, 0), Vec(0, 1, 0), Vec(0.2, 0.3, 1)));
        add_tetrahedron(m, add_points(m, Vec(0, 0, -gap), Vec(1, 0, -gap), Vec(0, 1, -gap), Vec(0.3, 0.2, -1)));
        return m;
    };
    const std::string e = solid_error(glued(0.0));
    EXPECT_NE(e.find("overlaps itself: triangles 0 and 4, lie in one plane"), std::string::npos) << e;
    // 1e-9 apart, 400 times the plane tolerance (1e-12 of the diagonal, 2.4e-12 m here): two solids, accepted.
    EXPECT_EQ(solid_error(glued(1e-9)), "");
    // The procedural boxes, each face a grid of coplanar triangles: face to face refused, 1 nm apart accepted.
    const auto two_boxes = [](double gap) {
        TriangleMesh a = box({0.01, 0.01, 0.01}, 3);
        const TriangleMesh b = box({0.01, 0.01, 0.01}, 3);
        const auto base = static_cast<std::uint32_t>(a.vertices.size());
        for (const auto& v : b.vertices) a.vertices.push_back(v + Vec(0.02 + gap, 0.0, 0.0));
        for (const auto& t : b.triangles) a.triangles.push_back({t[0] + base, t[1] + base, t[2] + base});
        return a;
    };
    EXPECT_NE(solid_error(two_boxes(0.0)).find("overlaps itself: triangles"), std::string::npos);
    EXPECT_EQ(solid_error(two_boxes(1e-9)), "");
    // The same vertex triple twice, wound oppositely: the two triangles alone are closed (zero volume, refused by
    // the volume rule); beside a tetrahedron the volume is positive and the overlap names the shared vertices.
    TriangleMesh same;
    add_tetrahedron(same, add_points(same, Vec(0, 0, 0), Vec(1, 0, 0), Vec(0, 1, 0), Vec(0, 0, 1)));
    const auto p = add_points(same, Vec(3, 0, 0), Vec(4, 0, 0), Vec(3, 1, 0), Vec(0, 0, 0));
    same.triangles.push_back({p[0], p[1], p[2]});
    same.triangles.push_back({p[0], p[2], p[1]});
    same.vertices.pop_back();
    const std::string s = solid_error(same);
    EXPECT_NE(s.find("overlaps itself: triangles 4 and 5, on the same vertices, lie in one plane"), std::string::npos)
        << s;
}

TEST(MeshSelfIntersection, AFaceFoldedBackOntoItsNeighbourIsRefusedAThinWedgeAccepted) {
    // A tetrahedron whose apex is `height` above a point inside its base (triangle 4, beside a unit tetrahedron
    // that makes the volume positive when the height is 0). Height 0: each side face lies on the base, folded back
    // across their shared edge.
    const auto sliver = [](double height) {
        TriangleMesh m;
        add_tetrahedron(m, add_points(m, Vec(0, 0, 0), Vec(1, 0, 0), Vec(0, 1, 0), Vec(0, 0, 1)));
        add_tetrahedron(m, add_points(m, Vec(3, 0, 0), Vec(4, 0, 0), Vec(3, 1, 0), Vec(3.3, 0.3, height)));
        return m;
    };
    const std::string e = solid_error(sliver(0.0));
    EXPECT_NE(e.find("overlaps itself: triangles 4 and 5, sharing edge"), std::string::npos) << e;
    // Dihedral angles of about 3e-6 rad (the apex 1e-6 m above a point 0.3 m inside the base's edges; the plane
    // tolerance is 1e-12 of the diagonal, 4.2e-12 m): thin but valid.
    EXPECT_EQ(solid_error(sliver(1e-6)), "");
    // Below the tolerance the wedge is flat: 1e-13 m (0.02 of the tolerance) is refused like 0.
    EXPECT_NE(solid_error(sliver(1e-13)).find("sharing edge"), std::string::npos);
}

TEST(MeshSelfIntersection, TouchingAtAVertexIsAccepted) {
    // A vertex of B exactly on the interior of A's top face (its own index, not shared): the solids touch at a
    // point, nothing crosses.
    TriangleMesh m;
    add_tetrahedron(m, add_points(m, Vec(0, 0, 0), Vec(1, 0, 0), Vec(0, 1, 0), Vec(0, 0, 1)));
    add_tetrahedron(m, add_points(m, Vec(0.25, 0.25, 0.5), Vec(1, 1, 1), Vec(1.2, 0.5, 1.1), Vec(0.6, 1.3, 0.9)));
    EXPECT_EQ(solid_error(m), "");
    // 1e-3 further in: B's corner pokes through A's face (the edge rule names an edge and both triangles).
    m.vertices[4] -= Vec(1e-3, 1e-3, 1e-3);
    const std::string e = solid_error(m);
    EXPECT_NE(e.find("intersects itself: edge"), std::string::npos) << e;
    EXPECT_NE(e.find("crosses triangle"), std::string::npos) << e;
}

TEST(MeshSelfIntersection, ProceduralMeshesStayAccepted) {
    for (const TriangleMesh& m : {icosphere(0.05, 4), icosphere(1.0, 1), box({0.03, 0.02, 0.01}, 16), box({1, 1, 1}, 1),
                                  torus(0.05, 0.02, 24, 12), torus(0.06, 0.02, 7, 3), torus(0.06, 0.02, 500, 100)}) {
        EXPECT_EQ(solid_error(m), "") << m.triangles.size() << " triangles";
    }
}

TEST(MeshSelfIntersection, RotatedAndMovedMeshesKeepTheirVerdicts) {
    // Turned about an axis off the coordinate axes and moved: a flat face's neighbours are coplanar only to rounding
    // (about 1e-16 m here, against 1e-12 of the diagonal, 7e-14 m), and stay accepted; two boxes face to face
    // stay refused.
    const Eigen::Matrix3d turn = Eigen::AngleAxisd(0.7, Vec(1, 2, 3).normalized()).toRotationMatrix();
    const auto moved = [&](TriangleMesh m) {
        for (auto& v : m.vertices) v = turn * v + Vec(0.3, -0.2, 0.1);
        return m;
    };
    EXPECT_EQ(solid_error(moved(box({0.03, 0.02, 0.01}, 8))), "");
    EXPECT_EQ(solid_error(moved(torus(0.05, 0.02, 48, 24))), "");
    EXPECT_EQ(solid_error(moved(icosphere(0.05, 3))), "");
    TriangleMesh two = box({0.01, 0.01, 0.01}, 2);
    const TriangleMesh second = box({0.01, 0.01, 0.01}, 2);
    const auto base = static_cast<std::uint32_t>(two.vertices.size());
    for (const auto& v : second.vertices) two.vertices.push_back(v + Vec(0.02, 0.0, 0.0));
    for (const auto& t : second.triangles) two.triangles.push_back({t[0] + base, t[1] + base, t[2] + base});
    EXPECT_NE(solid_error(moved(two)).find("overlaps itself"), std::string::npos);
}

}  // namespace hapticd::mesh::self_intersection_test
