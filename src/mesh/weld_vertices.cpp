// SPDX-License-Identifier: Apache-2.0
#include "mesh/weld_vertices.hpp"

#include <array>
#include <map>

namespace hapticd::mesh {

TriangleMesh weld_vertices(const TriangleMesh& mesh) {
    TriangleMesh out;
    out.triangles.reserve(mesh.triangles.size());
    std::map<std::array<double, 3>, std::uint32_t> index_of;
    const auto n = static_cast<std::uint32_t>(mesh.vertices.size());
    for (const auto& t : mesh.triangles) {
        std::array<std::uint32_t, 3> renumbered{};
        for (int k = 0; k < 3; ++k) {
            if (t[k] >= n) {
                renumbered[k] = UINT32_MAX;  // out of range stays out of range
                continue;
            }
            const Eigen::Vector3d& v = mesh.vertices[t[k]];
            // + 0.0 turns -0 into +0 so both weld.
            const std::array<double, 3> key{v.x() + 0.0, v.y() + 0.0, v.z() + 0.0};
            const auto [it, inserted] = index_of.emplace(key, static_cast<std::uint32_t>(out.vertices.size()));
            if (inserted) out.vertices.push_back(v);
            renumbered[k] = it->second;
        }
        out.triangles.push_back(renumbered);
    }
    return out;
}

}  // namespace hapticd::mesh
