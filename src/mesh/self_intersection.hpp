// SPDX-License-Identifier: Apache-2.0
// mesh_error's self-intersection rules for solid meshes (docs/mesh-rendering.md, "The mesh"): internal to
// hapticd_mesh.
#pragma once

#include "mesh/triangle_mesh.hpp"

#include <optional>
#include <string>

namespace hapticd::mesh::detail {

// pre: the mesh passed mesh_error's per-triangle checks (indices in range, no degenerate triangle). Empty when no
// two triangles cross or overlap, else the message of the first pair (t, o), t < o, in index order, naming the rule
// and both triangles. Builds the mesh's hierarchy to find the candidate pairs (boxes that overlap).
std::optional<std::string> self_intersection_error(const TriangleMesh& mesh);

}  // namespace hapticd::mesh::detail
