// SPDX-License-Identifier: Apache-2.0
#include "mesh/procedural_meshes.hpp"

#include <Eigen/Geometry>

#include <algorithm>
#include <cmath>
#include <map>
#include <numbers>
#include <utility>

namespace hapticd::mesh {
namespace {

using Triangle = std::array<std::uint32_t, 3>;

// The regular icosahedron on the unit sphere, outward wound.
TriangleMesh unit_icosahedron() {
    const double g = (1.0 + std::sqrt(5.0)) / 2.0;
    TriangleMesh m;
    m.vertices = {{-1, g, 0},  {1, g, 0},  {-1, -g, 0}, {1, -g, 0}, {0, -1, g},  {0, 1, g},
                  {0, -1, -g}, {0, 1, -g}, {g, 0, -1},  {g, 0, 1},  {-g, 0, -1}, {-g, 0, 1}};
    for (auto& v : m.vertices) v.normalize();
    m.triangles = {{0, 11, 5},  {0, 5, 1},  {0, 1, 7},  {0, 7, 10}, {0, 10, 11}, {1, 5, 9}, {5, 11, 4},
                   {11, 10, 2}, {10, 7, 6}, {7, 1, 8},  {3, 9, 4},  {3, 4, 2},   {3, 2, 6}, {3, 6, 8},
                   {3, 8, 9},   {4, 9, 5},  {2, 4, 11}, {6, 2, 10}, {8, 6, 7},   {9, 8, 1}};
    return m;
}

}  // namespace

TriangleMesh icosphere(double radius, int subdivisions) {
    TriangleMesh m = unit_icosahedron();
    for (int level = 0; level < std::clamp(subdivisions, 0, 8); ++level) {
        std::map<std::pair<std::uint32_t, std::uint32_t>, std::uint32_t> midpoints;
        const auto midpoint = [&](std::uint32_t a, std::uint32_t b) {
            const auto key = std::minmax(a, b);
            const auto it = midpoints.find(key);
            if (it != midpoints.end()) return it->second;
            const auto index = static_cast<std::uint32_t>(m.vertices.size());
            m.vertices.push_back((m.vertices[a] + m.vertices[b]).normalized());
            midpoints.emplace(key, index);
            return index;
        };
        std::vector<Triangle> finer;
        finer.reserve(m.triangles.size() * 4);
        for (const auto& t : m.triangles) {
            const std::uint32_t ab = midpoint(t[0], t[1]);
            const std::uint32_t bc = midpoint(t[1], t[2]);
            const std::uint32_t ca = midpoint(t[2], t[0]);
            finer.push_back({t[0], ab, ca});
            finer.push_back({t[1], bc, ab});
            finer.push_back({t[2], ca, bc});
            finer.push_back({ab, bc, ca});
        }
        m.triangles = std::move(finer);
    }
    for (auto& v : m.vertices) v *= radius;
    return m;
}

double icosphere_max_deviation(double radius, int subdivisions) {
    // Each triangle is acute, so the sphere's centre projects inside it and the triangle's nearest point to the
    // centre is on its plane: the deviation is radius - (distance of the plane from the centre).
    const TriangleMesh m = icosphere(radius, subdivisions);
    double deviation = 0.0;
    for (const auto& t : m.triangles) {
        const Eigen::Vector3d& a = m.vertices[t[0]];
        const Eigen::Vector3d n = (m.vertices[t[1]] - a).cross(m.vertices[t[2]] - a).normalized();
        deviation = std::max(deviation, radius - n.dot(a));
    }
    return deviation;
}

TriangleMesh box(const Eigen::Vector3d& half_extents, int cells) {
    const int c = std::clamp(cells, 1, 256);
    const auto n = static_cast<std::uint32_t>(c + 1);
    TriangleMesh m;
    std::map<std::uint32_t, std::uint32_t> index_of;  // lattice point (i, j, k) in [0, c]^3 -> vertex
    const auto vertex = [&](std::array<std::uint32_t, 3> lattice) {
        const std::uint32_t key = (lattice[0] * n + lattice[1]) * n + lattice[2];
        const auto it = index_of.find(key);
        if (it != index_of.end()) return it->second;
        const auto index = static_cast<std::uint32_t>(m.vertices.size());
        Eigen::Vector3d x;
        for (int k = 0; k < 3; ++k) x[k] = half_extents[k] * (2.0 * lattice[k] / c - 1.0);
        m.vertices.push_back(x);
        index_of.emplace(key, index);
        return index;
    };
    for (int axis = 0; axis < 3; ++axis) {
        const int u = (axis + 1) % 3;
        const int v = (axis + 2) % 3;
        for (int side = 0; side < 2; ++side) {
            for (std::uint32_t i = 0; i < static_cast<std::uint32_t>(c); ++i) {
                for (std::uint32_t j = 0; j < static_cast<std::uint32_t>(c); ++j) {
                    const auto at = [&](std::uint32_t di, std::uint32_t dj) {
                        std::array<std::uint32_t, 3> lattice{};
                        lattice[axis] = side == 0 ? 0u : static_cast<std::uint32_t>(c);
                        lattice[u] = i + di;
                        lattice[v] = j + dj;
                        return vertex(lattice);
                    };
                    const std::uint32_t p00 = at(0, 0), p10 = at(1, 0), p11 = at(1, 1), p01 = at(0, 1);
                    // e_u x e_v = e_axis: (p00, p10, p11) faces +axis; the side at -1 is wound the other way.
                    if (side == 1) {
                        m.triangles.push_back({p00, p10, p11});
                        m.triangles.push_back({p00, p11, p01});
                    } else {
                        m.triangles.push_back({p00, p11, p10});
                        m.triangles.push_back({p00, p01, p11});
                    }
                }
            }
        }
    }
    return m;
}

TriangleMesh torus(double major_radius, double minor_radius, int major_segments, int minor_segments) {
    const auto nu = static_cast<std::uint32_t>(std::max(major_segments, 3));
    const auto nv = static_cast<std::uint32_t>(std::max(minor_segments, 3));
    TriangleMesh m;
    m.vertices.reserve(nu * nv);
    for (std::uint32_t i = 0; i < nu; ++i) {
        const double theta = 2.0 * std::numbers::pi * i / nu;
        for (std::uint32_t j = 0; j < nv; ++j) {
            const double phi = 2.0 * std::numbers::pi * j / nv;
            const double ring = major_radius + minor_radius * std::cos(phi);
            m.vertices.emplace_back(ring * std::cos(theta), ring * std::sin(theta), minor_radius * std::sin(phi));
        }
    }
    // d/dtheta x d/dphi points outward: (i, j) -> (i+1, j) -> (i+1, j+1) is outward wound.
    const auto at = [&](std::uint32_t i, std::uint32_t j) { return (i % nu) * nv + (j % nv); };
    for (std::uint32_t i = 0; i < nu; ++i) {
        for (std::uint32_t j = 0; j < nv; ++j) {
            m.triangles.push_back({at(i, j), at(i + 1, j), at(i + 1, j + 1)});
            m.triangles.push_back({at(i, j), at(i + 1, j + 1), at(i, j + 1)});
        }
    }
    return m;
}

}  // namespace hapticd::mesh
