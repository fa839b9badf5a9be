// SPDX-License-Identifier: Apache-2.0
// SceneObjects' meshes as observed from outside the loop (scene_objects.hpp: mesh_slot_mask, mesh_proxy): the proxy
// each mesh entry's god-object (mesh/god_object_proxy.hpp) holds after the last add_forces(), taken back to the
// device frame with the pose that tick rendered, x = p + R c (scene_objects_meshes.cpp takes the handle the other
// way, h = R^T (x - p)). Called by the state publisher on the loop thread after add_forces(): no allocation, lock or
// exception.
#include "scene/scene_objects.hpp"
#include "scene/scene_objects_detail.hpp"

namespace hapticd {

using scene_objects_detail::dot;
using scene_objects_detail::rotation_of;

std::uint64_t SceneObjects::mesh_slot_mask() const noexcept {
    std::uint64_t mask = 0;
    for (std::size_t i = 0; i < meshes_.count; ++i) {
        const std::size_t k = meshes_.entry[i];
        const std::size_t s = k / 2;
        const Entry& e = (k % 2 == 0) ? slots_[s].current : slots_[s].fading;
        const MeshProxy& m = mesh_proxies_[proxy_of_[k]];
        if (e.active && e.params.kind == ObjectKind::Mesh && m.proxy && !m.fresh) mask |= std::uint64_t{1} << s;
    }
    return mask;
}

bool SceneObjects::mesh_proxy(std::size_t slot, MeshProxyView& out) const noexcept {
    if (slot >= kSceneObjectCapacity) return false;
    for (std::size_t which = 0; which < 2; ++which) {  // the current entry first, then the one fading out
        const std::size_t k = 2 * slot + which;
        const Entry& e = which == 0 ? slots_[slot].current : slots_[slot].fading;
        const MeshProxy& m = mesh_proxies_[proxy_of_[k]];
        if (!e.active || e.params.kind != ObjectKind::Mesh || !m.proxy || m.fresh) continue;
        const ObjectParams& p = e.params;
        const std::array<AxisVector, 3> R = rotation_of(p.orientation);
        const mesh::ProxyContact& c = m.proxy->contact();
        const AxisVector cm{c.proxy[0], c.proxy[1], c.proxy[2]};
        for (std::size_t a = 0; a < 3; ++a) out.proxy[a] = p.point[a] + dot(R[a], cm);
        out.constraints = c.constraints < 0 ? 0 : (c.constraints > 3 ? 3 : c.constraints);
        for (std::size_t i = 0; i < 3; ++i) {
            const AxisVector n{c.normals[i][0], c.normals[i][1], c.normals[i][2]};
            for (std::size_t a = 0; a < 3; ++a) {
                out.normals[i][a] = static_cast<int>(i) < out.constraints ? dot(R[a], n) : 0.0;
            }
        }
        out.triangle = out.constraints > 0 ? c.triangle : UINT32_MAX;
        out.object_id = p.id;
        out.sliding = c.sliding;
        out.converged = c.converged;
        return true;
    }
    return false;
}

}  // namespace hapticd
