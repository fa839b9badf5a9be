// SPDX-License-Identifier: Apache-2.0
// A triangle mesh in its own frame (metres), its rendering mode and its validation (docs/mesh-rendering.md).
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>

#include <array>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

namespace hapticd::mesh {

// Vertices and triangles; a triangle's front (outward) normal is (b - a) x (c - a) for its vertices (a, b, c).
struct TriangleMesh {
    std::vector<Eigen::Vector3d> vertices;
    std::vector<std::array<std::uint32_t, 3>> triangles;
};

// surface: one-sided, the proxy is stopped on the front side only (it passes through from behind);
// solid: a closed, edge-manifold, outward-wound mesh (every edge shared by exactly two triangles that use it in
// opposite directions, positive enclosed volume).
enum class MeshMode { surface, solid };

// What mesh_error accepts. 200 000 triangles and vertices: the hierarchy of 100 000 triangles builds in well under
// 1 s and a proxy step stays within the tick's budget (docs/mesh-rendering.md, figures). Coordinates within
// +-max_coordinate metres keep the proxy's 1 µm offset far above double rounding (1e-14 m at 100 m).
struct MeshLimits {
    std::size_t max_vertices = 200'000;
    std::size_t max_triangles = 200'000;
    double max_coordinate = 100.0;
};

// Empty when the mesh is valid for the mode, else one message naming the parameter and the accepted range: no
// triangles, too many vertices or triangles, a non-finite or too large coordinate, an index out of range, a
// degenerate (zero-area) triangle; in solid mode an open edge, an edge shared by more than two triangles, two
// triangles using an edge in the same direction, inward winding, or a surface that crosses or overlaps itself (an
// edge crossing a triangle it shares no vertex with, two triangles sharing one vertex whose interiors cross, two
// coplanar triangles whose interiors overlap; tolerances in docs/mesh-rendering.md). Never throws for bad input
// (it may throw std::bad_alloc). Cost O(n log n) in the triangles (solid mode builds a hierarchy to find the pairs
// of triangles whose boxes meet).
std::optional<std::string> mesh_error(const TriangleMesh& mesh, MeshMode mode, const MeshLimits& limits = {});

}  // namespace hapticd::mesh
