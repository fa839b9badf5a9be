// SPDX-License-Identifier: Apache-2.0
#include "mesh/vertex_normals.hpp"

#include <Eigen/Geometry>

#include <algorithm>
#include <cmath>
#include <numbers>

namespace hapticd::mesh {

std::size_t ShadingNormals::memory_bytes() const {
    return sizeof(*this) + corners.capacity() * sizeof(corners[0]) + face.capacity() * sizeof(face[0]) +
           smooth.capacity();
}

std::size_t shading_normals_bytes(std::size_t triangles) noexcept {
    using Corners = decltype(ShadingNormals::corners)::value_type;
    using Face = decltype(ShadingNormals::face)::value_type;
    using Smooth = decltype(ShadingNormals::smooth)::value_type;
    return sizeof(ShadingNormals) + triangles * (sizeof(Corners) + sizeof(Face) + sizeof(Smooth));
}

ShadingNormals shading_normals(const TriangleMesh& mesh, double crease_angle_deg) {
    const std::size_t n = mesh.triangles.size();
    const std::size_t nv = mesh.vertices.size();
    ShadingNormals out;
    out.crease_angle_deg = crease_angle_deg;
    out.face.resize(n);
    out.corners.resize(n);
    out.smooth.assign(n, 0);
    // Each triangle's unit normal and its interior angle at each corner (atan2(|e1 x e2|, e1 . e2): accurate at every
    // angle, unlike acos of the dot product near 0 and pi).
    std::vector<std::array<double, 3>> angle(n);
    for (std::size_t f = 0; f < n; ++f) {
        const auto& t = mesh.triangles[f];
        const Eigen::Vector3d& a = mesh.vertices[t[0]];
        const Eigen::Vector3d& b = mesh.vertices[t[1]];
        const Eigen::Vector3d& c = mesh.vertices[t[2]];
        out.face[f] = (b - a).cross(c - a).normalized();
        for (int k = 0; k < 3; ++k) {
            const Eigen::Vector3d& p = mesh.vertices[t[k]];
            const Eigen::Vector3d e1 = mesh.vertices[t[(k + 1) % 3]] - p;
            const Eigen::Vector3d e2 = mesh.vertices[t[(k + 2) % 3]] - p;
            angle[f][static_cast<std::size_t>(k)] = std::atan2(e1.cross(e2).norm(), e1.dot(e2));
        }
    }
    // The triangles around each vertex (compressed rows: first[v] .. first[v + 1]).
    std::vector<std::uint32_t> first(nv + 1, 0);
    for (const auto& t : mesh.triangles) {
        for (std::uint32_t v : t) ++first[v + 1];
    }
    for (std::size_t v = 0; v < nv; ++v) first[v + 1] += first[v];
    std::vector<std::uint32_t> around(first[nv]);
    std::vector<std::uint32_t> fill(first.begin(), first.end() - 1);
    for (std::size_t f = 0; f < n; ++f) {
        for (std::uint32_t v : mesh.triangles[f]) around[fill[v]++] = static_cast<std::uint32_t>(f);
    }
    const double cos_crease = std::cos(crease_angle_deg * std::numbers::pi / 180.0);
    for (std::size_t f = 0; f < n; ++f) {
        const Eigen::Vector3d& nf = out.face[f];
        bool smooth = false;
        for (int k = 0; k < 3; ++k) {
            const std::uint32_t v = mesh.triangles[f][static_cast<std::size_t>(k)];
            Eigen::Vector3d sum = Eigen::Vector3d::Zero();
            for (std::uint32_t i = first[v]; i < first[v + 1]; ++i) {
                const std::uint32_t g = around[i];
                if (out.face[g].dot(nf) < cos_crease) continue;  // beyond the crease: the edge stays sharp
                const auto& tg = mesh.triangles[g];
                const std::size_t corner = tg[0] == v ? 0 : tg[1] == v ? 1 : 2;
                sum += angle[g][corner] * out.face[g];
            }
            // f itself is always in the sum (n_f . n_f = 1 >= cos theta_c, its angle > 0): the sum is not zero.
            Eigen::Vector3d normal = sum.normalized();
            if ((normal - nf).norm() <= 1e-12) normal = nf;
            out.corners[f][static_cast<std::size_t>(k)] = normal;
            smooth = smooth || normal != nf;
        }
        out.smooth[f] = smooth ? 1 : 0;
    }
    return out;
}

Eigen::Vector3d shaded_normal(const ShadingNormals& normals, const TriangleMesh& mesh, std::uint32_t triangle,
                              const Eigen::Vector3d& x) noexcept {
    const auto& t = mesh.triangles[triangle];
    const Eigen::Vector3d& a = mesh.vertices[t[0]];
    const Eigen::Vector3d ab = mesh.vertices[t[1]] - a;
    const Eigen::Vector3d ac = mesh.vertices[t[2]] - a;
    // Barycentric coordinates of x's projection on the plane (Ericson, Real-Time Collision Detection, 3.4): the
    // normal equations of min |a + v ab + w ac - x|.
    const Eigen::Vector3d d = x - a;
    const double d00 = ab.dot(ab), d01 = ab.dot(ac), d11 = ac.dot(ac), d20 = d.dot(ab), d21 = d.dot(ac);
    const double den = d00 * d11 - d01 * d01;  // > 0: validated triangles are not degenerate
    double v = (d11 * d20 - d01 * d21) / den;
    double w = (d00 * d21 - d01 * d20) / den;
    double u = 1.0 - v - w;
    u = std::max(u, 0.0);
    v = std::max(v, 0.0);
    w = std::max(w, 0.0);
    const double s = u + v + w;  // >= 1 after the clamp of coordinates summing to 1
    const auto& c = normals.corners[triangle];
    const Eigen::Vector3d sum = (u / s) * c[0] + (v / s) * c[1] + (w / s) * c[2];
    return sum / sum.norm();  // |sum| >= cos(theta_c) > 0: each corner lies in the cone around n_f
}

}  // namespace hapticd::mesh
