// SPDX-License-Identifier: Apache-2.0
// Merging a mesh's equal vertices (STL files store every triangle with its own three vertices; a solid needs them
// shared for mesh_error's closed, edge-manifold check).
#pragma once

#include "mesh/triangle_mesh.hpp"

namespace hapticd::mesh {

// The mesh with each set of vertices of equal coordinates (bit for bit, -0 == +0) replaced by its first, the
// triangles renumbered and the unused vertices dropped; order of first use kept. Indices out of range are kept
// out of range (mesh_error reports them). O(n log n); allocates.
TriangleMesh weld_vertices(const TriangleMesh& mesh);

}  // namespace hapticd::mesh
