// SPDX-License-Identifier: Apache-2.0
// Closed, outward-wound meshes for tests, examples and clients (each passes mesh_error in solid mode).
#pragma once

#include "mesh/triangle_mesh.hpp"

#include <Eigen/Core>

namespace hapticd::mesh {

// The icosahedron inscribed in the sphere, each face split in 4 `subdivisions` times, vertices on the sphere:
// 20 * 4^subdivisions triangles, 10 * 4^subdivisions + 2 vertices. pre: radius > 0, subdivisions <= 8.
TriangleMesh icosphere(double radius, int subdivisions);

// The box [-half_extents, half_extents], each face a grid of cells x cells squares (2 triangles each):
// 12 cells^2 triangles. pre: half_extents > 0, 1 <= cells <= 256.
TriangleMesh box(const Eigen::Vector3d& half_extents, int cells = 1);

// The torus around z: tube of radius minor_radius around the circle of radius major_radius, major_segments x
// minor_segments quads (2 triangles each). pre: 0 < minor_radius < major_radius, segments >= 3.
TriangleMesh torus(double major_radius, double minor_radius, int major_segments, int minor_segments);

// The largest distance between a triangle of icosphere(radius, subdivisions) and the sphere (the sagitta bound
// radius * (1 - cos(theta)), theta the largest angle between a triangle's centroid direction and its vertices).
double icosphere_max_deviation(double radius, int subdivisions);

}  // namespace hapticd::mesh
