// SPDX-License-Identifier: Apache-2.0
#include "mesh/triangle_mesh.hpp"

#include "mesh/self_intersection.hpp"

#include <Eigen/Geometry>

#include <algorithm>
#include <cmath>
#include <sstream>
#include <utility>

namespace hapticd::mesh {
namespace {

std::string text(double v) {
    std::ostringstream s;
    s.precision(17);
    s << v;
    return s.str();
}

// Directed edge (from, to) as one key; its reverse is (to, from).
std::uint64_t edge_key(std::uint32_t from, std::uint32_t to) {
    return (static_cast<std::uint64_t>(from) << 32) | static_cast<std::uint64_t>(to);
}

std::optional<std::string> solid_error(const TriangleMesh& mesh) {
    // Every directed edge once, and its reverse once: closed, edge-manifold and consistently wound.
    std::vector<std::pair<std::uint64_t, std::uint32_t>> edges;  // (directed edge, triangle)
    edges.reserve(mesh.triangles.size() * 3);
    for (std::uint32_t t = 0; t < mesh.triangles.size(); ++t) {
        const auto& tri = mesh.triangles[t];
        for (int k = 0; k < 3; ++k) edges.emplace_back(edge_key(tri[k], tri[(k + 1) % 3]), t);
    }
    std::sort(edges.begin(), edges.end());
    const auto describe = [](std::uint64_t key) {
        return "(" + std::to_string(key >> 32) + ", " + std::to_string(key & 0xffffffffu) + ")";
    };
    for (std::size_t i = 0; i + 1 < edges.size(); ++i) {
        if (edges[i].first == edges[i + 1].first) {
            return "mesh: mode solid: edge " + describe(edges[i].first) +
                   " is used in the same direction by triangles " + std::to_string(edges[i].second) + " and " +
                   std::to_string(edges[i + 1].second) +
                   " (a solid's triangles are wound consistently: each edge once in each direction; or the edge is "
                   "shared by more than two triangles)";
        }
    }
    for (const auto& [key, t] : edges) {
        const std::uint64_t reverse =
            edge_key(static_cast<std::uint32_t>(key & 0xffffffffu), static_cast<std::uint32_t>(key >> 32));
        const auto it = std::lower_bound(edges.begin(), edges.end(), std::make_pair(reverse, std::uint32_t{0}));
        if (it == edges.end() || it->first != reverse) {
            return "mesh: mode solid: edge " + describe(key) + " of triangle " + std::to_string(t) +
                   " has no neighbour using it in the opposite direction: the mesh is open or inconsistently "
                   "wound (a solid shares every edge between exactly two triangles; weld duplicate vertices first)";
        }
    }
    // Enclosed volume (divergence theorem): positive when the normals point outward.
    double volume = 0.0;
    const Eigen::Vector3d origin = mesh.vertices[mesh.triangles[0][0]];
    for (const auto& tri : mesh.triangles) {
        const Eigen::Vector3d a = mesh.vertices[tri[0]] - origin;
        const Eigen::Vector3d b = mesh.vertices[tri[1]] - origin;
        const Eigen::Vector3d c = mesh.vertices[tri[2]] - origin;
        volume += a.dot(b.cross(c)) / 6.0;
    }
    if (!(volume > 0.0)) {
        return "mesh: mode solid: the enclosed volume is " + text(volume) +
               " m^3, accepted > 0 (the triangles wind inward: the outward normal is (b - a) x (c - a))";
    }
    return std::nullopt;
}

}  // namespace

std::optional<std::string> mesh_error(const TriangleMesh& mesh, MeshMode mode, const MeshLimits& limits) {
    if (mesh.triangles.empty()) return "mesh: triangles: none, accepted 1.." + std::to_string(limits.max_triangles);
    if (mesh.triangles.size() > limits.max_triangles) {
        return "mesh: triangles: " + std::to_string(mesh.triangles.size()) + ", accepted 1.." +
               std::to_string(limits.max_triangles);
    }
    if (mesh.vertices.size() < 3 || mesh.vertices.size() > limits.max_vertices) {
        return "mesh: vertices: " + std::to_string(mesh.vertices.size()) + ", accepted 3.." +
               std::to_string(limits.max_vertices);
    }
    for (std::size_t v = 0; v < mesh.vertices.size(); ++v) {
        for (int k = 0; k < 3; ++k) {
            const double x = mesh.vertices[v][k];
            if (!std::isfinite(x) || std::abs(x) > limits.max_coordinate) {
                return "mesh: vertex " + std::to_string(v) + " coordinate " + "xyz"[k] + " = " + text(x) +
                       ", accepted a finite number in [-" + text(limits.max_coordinate) + ", " +
                       text(limits.max_coordinate) + "] m";
            }
        }
    }
    const std::size_t n = mesh.vertices.size();
    for (std::size_t t = 0; t < mesh.triangles.size(); ++t) {
        const auto& tri = mesh.triangles[t];
        for (int k = 0; k < 3; ++k) {
            if (tri[k] >= n) {
                return "mesh: triangle " + std::to_string(t) + " vertex index " + std::to_string(k) + " = " +
                       std::to_string(tri[k]) + ", accepted 0.." + std::to_string(n - 1);
            }
        }
        const Eigen::Vector3d& a = mesh.vertices[tri[0]];
        const Eigen::Vector3d& b = mesh.vertices[tri[1]];
        const Eigen::Vector3d& c = mesh.vertices[tri[2]];
        const double longest = std::max({(b - a).squaredNorm(), (c - b).squaredNorm(), (a - c).squaredNorm()});
        const double twice_area = (b - a).cross(c - a).norm();
        // Zero area: repeated indices, coincident or collinear vertices; 1e-10 of the longest edge's square is
        // an angle of about 1e-10 rad, far below any real mesh and far above double rounding (1e-16).
        if (tri[0] == tri[1] || tri[1] == tri[2] || tri[0] == tri[2] || !(twice_area > 1e-10 * longest) ||
            !(longest > 0.0)) {
            return "mesh: triangle " + std::to_string(t) + " (" + std::to_string(tri[0]) + ", " +
                   std::to_string(tri[1]) + ", " + std::to_string(tri[2]) +
                   ") is degenerate (zero area): accepted three distinct, non-collinear vertices";
        }
    }
    if (mode == MeshMode::solid) {
        if (auto e = solid_error(mesh)) return e;
        return detail::self_intersection_error(mesh);
    }
    return std::nullopt;
}

}  // namespace hapticd::mesh
