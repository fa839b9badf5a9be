// SPDX-License-Identifier: Apache-2.0
// Force shading (Morgenbesser & Srinivasan, "Force shading for haptic shape perception", ASME DSC 1996; Ruspini,
// Kolarov & Khatib, SIGGRAPH 1997, "force shading"): per-corner vertex normals of a mesh, built off the loop thread,
// and the normal interpolated barycentrically at a point of a triangle, evaluated in the tick. docs/mesh-rendering.md,
// "Force shading", states the weighting, the crease rule and the stability argument.
#pragma once

#include "mesh/triangle_mesh.hpp"

#include <Eigen/Core>

#include <array>
#include <cstdint>
#include <vector>

namespace hapticd::mesh {

// The largest crease angle accepted (degrees): every shaded normal then lies within 80 degrees of its face's normal,
// so the wall law along the face normal keeps at least cos(80 deg) = 0.17 of its gains (the stability argument).
inline constexpr double kMaxCreaseAngleDeg = 80.0;

// The corner normals of every triangle (indexed as mesh.triangles) for one crease angle theta_c: triangle f's normal
// at its vertex v is the angle-weighted sum (Thuermer & Wuethrich 1998) of the unit normals n_g of the triangles g
// around v with n_g . n_f >= cos theta_c, normalised. Each is therefore within theta_c of n_f (a non-negative sum of
// unit vectors in the cone of half-angle theta_c < 90 deg around n_f stays in it), and so is any normalised
// non-negative combination of the three. `smooth[f]` is 0 when all three corner normals equal n_f within 1e-12
// (a flat neighbourhood, or every neighbour beyond the crease: the triangle renders unshaded, bit for bit).
struct ShadingNormals {
    double crease_angle_deg = 0.0;
    std::vector<std::array<Eigen::Vector3d, 3>> corners;
    std::vector<Eigen::Vector3d> face;  // the unit front normal n_f of each triangle ((b - a) x (c - a), normalised)
    std::vector<std::uint8_t> smooth;
    std::size_t memory_bytes() const;
};

// The bytes ShadingNormals::memory_bytes() reports for the table shading_normals builds for a mesh of `triangles`
// triangles, known before building it: the struct and, a triangle, 3 corner normals (72), its face normal (24) and
// its flag (1), 97 bytes (9.7 MB for 100 000 triangles). shading_normals sizes each vector once to the triangle count.
// The scratch arrays of the build (36 bytes a triangle and 8 a vertex) are freed before it returns: not counted.
std::size_t shading_normals_bytes(std::size_t triangles) noexcept;

// pre: mesh_error(mesh, mode) is empty; 0 <= crease_angle_deg <= kMaxCreaseAngleDeg. Allocates; O(n) (each
// triangle's corners over the triangles around its vertices). Throws std::bad_alloc only.
ShadingNormals shading_normals(const TriangleMesh& mesh, double crease_angle_deg);

// The shaded unit normal at x on triangle `triangle`: the corner normals weighted by the barycentric coordinates of
// x's projection on the triangle's plane, each clamped to >= 0 and the three renormalised to sum 1 (the proxy rests
// up to MeshHierarchy::kRestingReach beyond an edge), the sum normalised. No allocation, lock or exception.
Eigen::Vector3d shaded_normal(const ShadingNormals& normals, const TriangleMesh& mesh, std::uint32_t triangle,
                              const Eigen::Vector3d& x) noexcept;

}  // namespace hapticd::mesh
