// SPDX-License-Identifier: Apache-2.0
// The bounding-volume hierarchy of a mesh (axis-aligned boxes, median split, up to 4 triangles a leaf): built once
// off the loop thread, then immutable (but for the shading normals kept per crease angle) and queried in the tick
// without allocation (a fixed-size traversal stack).
#pragma once

#include "mesh/triangle_mesh.hpp"
#include "mesh/vertex_normals.hpp"

#include <Eigen/Core>

#include <array>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <mutex>
#include <vector>

namespace hapticd::mesh {

// The proxy's clearance: a sweep stops the proxy kSurfaceOffset (1 µm) in front of the plane of the triangle it
// meets, and the proxy's constraint planes are the triangles' planes moved out by it. 1 µm is 60 times below the
// Falcon's resolution and shifts a K = 2000 N/m contact force by 2 mN; it is 1e8 times double rounding at 1 m.
inline constexpr double kSurfaceOffset = 1e-6;

// A triangle ready for queries: first vertex, two edges, unit front normal, the index in the mesh.
struct HierarchyTriangle {
    Eigen::Vector3d a;
    Eigen::Vector3d ab;
    Eigen::Vector3d ac;
    Eigen::Vector3d normal;
    std::uint32_t index = 0;
};

// The first front-face contact of a swept segment p -> q.
struct SweepHit {
    double fraction = 1.0;                // the proxy may move to p + fraction (q - p), fraction in [0, 1]
    std::uint32_t triangle = UINT32_MAX;  // index in the mesh; UINT32_MAX: the segment is free
    Eigen::Vector3d normal = Eigen::Vector3d::Zero();
    double plane_offset = 0.0;                // the triangle's plane: normal . x = plane_offset
    const HierarchyTriangle* face = nullptr;  // the triangle met, in the hierarchy
    bool hit() const { return triangle != UINT32_MAX; }
};

class MeshHierarchy {
  public:
    struct Node {
        Eigen::Vector3d lower;
        Eigen::Vector3d upper;
        std::uint32_t first = 0;  // leaf: first triangle; inner node: first child (the second is first + 1)
        std::uint32_t count = 0;  // leaf: triangles (1..kLeafSize); inner node: 0
    };
    static constexpr std::uint32_t kLeafSize = 4;
    // Depth bound of the median split: ceil(log2(200 000 / 1)) + 1 = 19 levels; the stack has room for more.
    static constexpr std::size_t kStackSize = 64;

    // pre: mesh_error(mesh, mode) is empty. Allocates; O(n log n). Throws std::bad_alloc only.
    static std::shared_ptr<const MeshHierarchy> build(TriangleMesh mesh, MeshMode mode);

    // The first triangle whose front the segment p -> q meets (docs/mesh-rendering.md): a triangle counts when
    // the segment approaches its plane (normal . (q - p) < -1e-12 |q - p|), starts no more than offset / 2 behind
    // it, ends less than offset - 1e-12 in front of it, and crosses the triangle (grown by kEdgeTolerance) there
    // (or, ending in front, the end's projection does). The fraction it allows: to `offset` in front of the plane
    // when the start is farther; else 0 when the point met is within kRestingReach of the start (the proxy rests
    // on the triangle), else up to kRestingReach before that point. The smallest over the triangles met.
    // No allocation, no lock, no exception; visits each node at most once.
    SweepHit sweep(const Eigen::Vector3d& p, const Eigen::Vector3d& q, double offset = kSurfaceOffset) const noexcept;

    // A point on the triangles' planes within kEdgeTolerance of a triangle's edge counts as inside it, so a
    // segment through a shared edge or vertex meets at least one of its triangles despite rounding.
    static constexpr double kEdgeTolerance = 1e-9;
    // A proxy within this distance of a triangle (and on its offset plane) rests on it: 10 offsets, as a proxy on
    // the offset planes of a convex edge lies up to offset x tan(half the bend) beyond either triangle.
    static constexpr double kRestingReach = 10 * kSurfaceOffset;

    const TriangleMesh& mesh() const { return mesh_; }
    MeshMode mode() const { return mode_; }
    const std::vector<Node>& nodes() const { return nodes_; }
    const std::vector<HierarchyTriangle>& triangles() const { return triangles_; }
    std::size_t depth() const { return depth_; }
    // What the hierarchy holds: the tree, the prepared triangles, its copy of the mesh and the shading tables kept
    // so far (each ShadingNormals::memory_bytes()). Takes the shading mutex.
    std::size_t memory_bytes() const;

    // Force shading: the mesh's corner normals for crease angle `crease_angle_deg` (vertex_normals.hpp), computed
    // on the first request for that angle (off the loop thread: allocates, O(n)) and kept, unmoved, for as long as
    // the hierarchy lives, so the pointer may be handed to the loop with the hierarchy. At most kMaxShadings angles
    // a mesh: nullptr beyond. Thread-safe (a mutex the loop never takes). Throws std::bad_alloc only.
    // A new angle adds new_shading_bytes() to memory_bytes().
    static constexpr std::size_t kMaxShadings = 4;
    const ShadingNormals* shading(double crease_angle_deg) const;
    // The table kept for `crease_angle_deg`, or nullptr (nothing is built). Thread-safe, no allocation.
    const ShadingNormals* kept_shading(double crease_angle_deg) const;
    // The crease angles kept (0 .. kMaxShadings). Thread-safe.
    std::size_t shadings_kept() const;
    // The bytes a new crease angle's table holds: shading_normals_bytes(triangles), before it is built.
    std::size_t new_shading_bytes() const noexcept { return shading_normals_bytes(mesh_.triangles.size()); }

  private:
    MeshHierarchy() = default;
    TriangleMesh mesh_;
    MeshMode mode_ = MeshMode::surface;
    std::vector<Node> nodes_;
    std::vector<HierarchyTriangle> triangles_;  // in leaf order
    std::size_t depth_ = 0;
    mutable std::mutex shading_mutex_;
    mutable std::vector<std::unique_ptr<const ShadingNormals>> shadings_;
};

}  // namespace hapticd::mesh
