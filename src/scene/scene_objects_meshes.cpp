// SPDX-License-Identifier: Apache-2.0
// SceneObjects' meshes (scene_objects.hpp; docs/protocol.md, section 4, kind `mesh`): each mesh entry's god-object
// proxy (mesh/god_object_proxy.hpp) stepped once per tick with the handle in the mesh's frame, and its force
//   h = R^T (x - p),  c = proxy.step(h),  f = R (r^2 K (c - h) - r B P R^T (v - p_rate))
// with R the rotation of the entry's orientation, p its position, r its ramp factor and P the projector on the span
// of the active constraints' normals (0 when the proxy is free; I with friction, whose stuck proxy is a spring of
// K in every direction: damped in every direction too). This is the law the server certifies: for every P it is
// a spring of at most K and a damper of at most B (docs/protocol.md, section 5). With force shading and exactly one
// active face (normal n_f) the mesh-frame force is S fm with S = I + (n_s - n_f) n_f^T, n_s the shaded normal at the
// proxy: along n_f the wall law scaled by n_s . n_f in [cos theta_c, 1], certified as the unscaled law with the mass
// divided by it (docs/mesh-rendering.md, "Force shading"). No allocation, lock or exception.
#include <cmath>
#include <memory>

#include "scene/scene_objects.hpp"
#include "scene/scene_objects_detail.hpp"

namespace hapticd {

using scene_objects_detail::dot;
using scene_objects_detail::rotation_of;

namespace {

// P v for P the orthogonal projector on the span of the first n unit normals (Gram-Schmidt; a normal within
// 1e-9 of the span of the previous ones adds nothing).
AxisVector project_on_normals(const std::array<Eigen::Vector3d, 3>& normals, int n, const AxisVector& v) noexcept {
    AxisVector basis[3];
    int m = 0;
    for (int i = 0; i < n && i < 3; ++i) {
        AxisVector u{normals[i][0], normals[i][1], normals[i][2]};
        for (int j = 0; j < m; ++j) {
            const double c = dot(u, basis[j]);
            for (std::size_t a = 0; a < 3; ++a) u[a] -= c * basis[j][a];
        }
        const double len = std::sqrt(dot(u, u));
        if (!(len > 1e-9)) continue;
        for (double& c : u) c /= len;
        basis[m++] = u;
    }
    AxisVector out{};
    for (int j = 0; j < m; ++j) {
        const double c = dot(v, basis[j]);
        for (std::size_t a = 0; a < 3; ++a) out[a] += c * basis[j][a];
    }
    return out;
}

}  // namespace

// The proxy of `entry` bound to the entry's hierarchy (a non-owning shared_ptr: the aliasing constructor with an
// empty owner allocates nothing; the server's slot table owns the hierarchy while the loop may read it).
void SceneObjects::bind_mesh(std::size_t entry, const ObjectParams& p) noexcept {
    MeshProxy& m = mesh_proxies_[proxy_of_[entry]];
    m.proxy.reset();
    m.fresh = true;
    if (p.mesh == nullptr) return;
    m.proxy.emplace(std::shared_ptr<const mesh::MeshHierarchy>(std::shared_ptr<const mesh::MeshHierarchy>(), p.mesh),
                    mesh::MeshFriction{p.static_friction, p.dynamic_friction});
}

void SceneObjects::add_meshes(const AxisVector& x, const AxisVector& v, double (&f)[3], std::uint64_t& mask) noexcept {
    for (std::size_t i = 0; i < meshes_.count; ++i) {
        const std::size_t k = meshes_.entry[i];
        const std::size_t s = k / 2;
        const Entry& e = (k % 2 == 0) ? slots_[s].current : slots_[s].fading;
        MeshProxy& m = mesh_proxies_[proxy_of_[k]];
        if (!e.active || !m.proxy) continue;
        const ObjectParams& p = e.params;
        const std::array<AxisVector, 3> R = rotation_of(p.orientation);
        // Into the mesh frame: R^T (x - p) and R^T (v - p_rate).
        const AxisVector dx{x[0] - p.point[0], x[1] - p.point[1], x[2] - p.point[2]};
        const AxisVector dv{v[0] - p.point_rate[0], v[1] - p.point_rate[1], v[2] - p.point_rate[2]};
        Eigen::Vector3d h;
        AxisVector vm{};
        for (std::size_t a = 0; a < 3; ++a) {
            h[static_cast<Eigen::Index>(a)] = R[0][a] * dx[0] + R[1][a] * dx[1] + R[2][a] * dx[2];
            vm[a] = R[0][a] * dv[0] + R[1][a] * dv[1] + R[2][a] * dv[2];
        }
        if (m.fresh) {
            m.proxy->reset(h);
            m.fresh = false;
        }
        const mesh::ProxyContact& c = m.proxy->step(h);
        if (c.constraints <= 0) continue;
        mask |= std::uint64_t{1} << s;
        const double wk = e.ramp * e.ramp * p.K, wb = e.ramp * p.B;
        const AxisVector pv = p.static_friction > 0.0 ? vm : project_on_normals(c.normals, c.constraints, vm);
        AxisVector fm{};
        for (std::size_t a = 0; a < 3; ++a) {
            fm[a] = wk * (c.proxy[static_cast<Eigen::Index>(a)] - h[static_cast<Eigen::Index>(a)]) - wb * pv[a];
        }
        if (p.shading != nullptr && c.constraints == 1 && p.shading->smooth[c.triangle] != 0) {
            // Force shading on one face: fm + (n_s - n_f)(n_f . fm), the component along the face normal n_f turned
            // onto the shaded normal n_s, the rest as is (docs/mesh-rendering.md, "Force shading").
            const Eigen::Vector3d ns = mesh::shaded_normal(*p.shading, p.mesh->mesh(), c.triangle, c.proxy);
            const Eigen::Vector3d& nf = c.normals[0];
            const double along = nf[0] * fm[0] + nf[1] * fm[1] + nf[2] * fm[2];
            for (std::size_t a = 0; a < 3; ++a) {
                const auto i = static_cast<Eigen::Index>(a);
                fm[a] += (ns[i] - nf[i]) * along;
            }
        }
        for (std::size_t a = 0; a < 3; ++a) f[a] += dot(R[a], fm);  // back to the device frame
    }
}

}  // namespace hapticd
