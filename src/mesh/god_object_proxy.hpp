// SPDX-License-Identifier: Apache-2.0
// The god-object proxy (Zilles & Salisbury 1995; Ruspini, Kolarov & Khatib 1997) on a mesh: the proxy moves toward
// the handle, stopped by the mesh's front faces, to the point closest to the handle on up to three active constraint
// planes, with static and dynamic friction. docs/mesh-rendering.md states the algorithm, its bounds and sources.
#pragma once

#include "mesh/mesh_hierarchy.hpp"

#include <Eigen/Core>

#include <array>
#include <cstdint>
#include <memory>

namespace hapticd::mesh {

// Coulomb friction on the proxy: it sticks while its offset from the frictionless proxy is at most
// static_coefficient x the penetration, and slides keeping it at dynamic_coefficient x the penetration.
// 0 <= dynamic_coefficient <= static_coefficient (the caller checks; the proxy clamps dynamic to static).
struct MeshFriction {
    double static_coefficient = 0.0;
    double dynamic_coefficient = 0.0;
};

struct ProxyContact {
    Eigen::Vector3d proxy = Eigen::Vector3d::Zero();  // the god-object: on or outside the surface
    int constraints = 0;                              // active faces, 0..3
    std::array<Eigen::Vector3d, 3> normals{};         // unit normals of the active constraints (first `constraints`)
    std::uint32_t triangle = UINT32_MAX;              // one active face, UINT32_MAX when free
    int sweeps = 0;                                   // sweeps the last step used (at most kMaxSweeps)
    bool sliding = false;                             // friction: the proxy slid in the last step
    // The last step ended on the constrained closest point (or stuck by friction) within its bounds; false when it
    // ran out of sweeps or planes (the proxy is then left where its last sweep stopped: outside, and it goes on
    // at the next step).
    bool converged = true;
};

class GodObjectProxy {
  public:
    // Bounds of one step: at most kMaxSweeps segment sweeps of the hierarchy and kMaxPlanes candidate planes (the
    // closest point solved over every subset of at most three of them: 14 small solves).
    static constexpr int kMaxSweeps = 16;
    static constexpr int kMaxPlanes = 4;

    GodObjectProxy(std::shared_ptr<const MeshHierarchy> hierarchy, MeshFriction friction);

    // proxy := handle, free (call when the handle is known to be outside or in front of the mesh).
    void reset(const Eigen::Vector3d& handle) noexcept;
    // handle in the mesh frame; moves the proxy. No allocation, no lock, no exception; at most kMaxSweeps sweeps.
    const ProxyContact& step(const Eigen::Vector3d& handle) noexcept;

    const ProxyContact& contact() const { return contact_; }
    const MeshHierarchy& hierarchy() const { return *hierarchy_; }

  private:
    std::shared_ptr<const MeshHierarchy> hierarchy_;
    MeshFriction friction_;
    ProxyContact contact_;
};

}  // namespace hapticd::mesh
