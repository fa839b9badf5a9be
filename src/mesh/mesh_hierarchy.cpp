// SPDX-License-Identifier: Apache-2.0
#include "mesh/mesh_hierarchy.hpp"

#include <Eigen/Geometry>

#include <algorithm>
#include <cmath>
#include <numeric>
#include <stdexcept>
#include <utility>

namespace hapticd::mesh {
namespace {

// Slab test of the segment p + s d, s in [0, 1], against the box [lower - grow, upper + grow]; inverse[k] is
// 1 / d[k] where flat[k] is false; where it is true (d[k] = 0) the slab holds p or not.
bool segment_meets_box(const Eigen::Vector3d& p, const Eigen::Vector3d& inverse, const std::array<bool, 3>& flat,
                       const MeshHierarchy::Node& node, double grow) noexcept {
    double enter = 0.0;
    double leave = 1.0;
    for (int k = 0; k < 3; ++k) {
        const double lower = node.lower[k] - grow;
        const double upper = node.upper[k] + grow;
        if (flat[k]) {
            if (p[k] < lower || p[k] > upper) return false;
            continue;
        }
        double s0 = (lower - p[k]) * inverse[k];
        double s1 = (upper - p[k]) * inverse[k];
        if (s0 > s1) std::swap(s0, s1);
        enter = std::max(enter, s0);
        leave = std::min(leave, s1);
        if (enter > leave) return false;
    }
    return true;
}

// x (on the triangle's plane) within `tolerance` of the triangle: on the inner side of each edge line, or less
// than `tolerance` outside it.
bool inside_triangle(const HierarchyTriangle& t, const Eigen::Vector3d& x, double tolerance) noexcept {
    const Eigen::Vector3d b = t.a + t.ab;
    const Eigen::Vector3d c = t.a + t.ac;
    const Eigen::Vector3d bc = c - b;
    if (t.ab.cross(x - t.a).dot(t.normal) < -tolerance * t.ab.norm()) return false;
    if (bc.cross(x - b).dot(t.normal) < -tolerance * bc.norm()) return false;
    if ((-t.ac).cross(x - c).dot(t.normal) < -tolerance * t.ac.norm()) return false;
    return true;
}

// A segment ending on the offset level (a proxy sliding on a constraint plane) does not meet the plane: its end
// must be kLevelTolerance below the level, 1e4 times the rounding of a point on a plane at 1 m.
constexpr double kLevelTolerance = 1e-12;

// The hit rule of MeshHierarchy::sweep for one triangle: the fraction the proxy may move, or a value > 1 when the
// segment does not meet the triangle's front.
double sweep_triangle(const HierarchyTriangle& t, const Eigen::Vector3d& p, const Eigen::Vector3d& d, double length,
                      double offset) noexcept {
    constexpr double kNever = 2.0;
    const double approach = t.normal.dot(d);
    if (!(approach < -1e-12 * length)) return kNever;
    const double sp = t.normal.dot(p - t.a);
    if (sp < -0.5 * offset) return kNever;
    const double st = sp + approach;
    if (!(st < offset - kLevelTolerance)) return kNever;
    Eigen::Vector3d x;
    if (sp < 0.0) {
        x = p - sp * t.normal;
    } else if (st < 0.0) {
        x = p + (sp / (sp - st)) * d;
    } else {
        x = p + d - st * t.normal;
    }
    if (!inside_triangle(t, x, MeshHierarchy::kEdgeTolerance)) return kNever;
    if (sp >= offset) return (sp - offset) / (sp - st);
    // The start is within the offset of the plane: resting on the triangle when the point met is within
    // kRestingReach of it (no motion toward it), else the proxy is only near the plane's extension and may move
    // until kRestingReach before the point met.
    const double reach = MeshHierarchy::kRestingReach;
    const double along = (x - p).norm();
    return along <= reach ? 0.0 : (along - reach) / length;
}

// Every triangle of every leaf whose box, grown by `grow`, the segment p + s d (s in [0, 1]) meets: visit(triangle),
// depth first with a fixed stack (build() refuses a tree deeper than kStackSize): no allocation.
template <class Visit>
void for_each_leaf_triangle(const std::vector<MeshHierarchy::Node>& nodes,
                            const std::vector<HierarchyTriangle>& triangles, const Eigen::Vector3d& p,
                            const Eigen::Vector3d& d, double grow, Visit&& visit) {
    if (nodes.empty() || triangles.empty()) return;
    Eigen::Vector3d inverse;
    std::array<bool, 3> flat{};
    for (int k = 0; k < 3; ++k) {
        flat[k] = std::abs(d[k]) < 1e-300;
        inverse[k] = flat[k] ? 0.0 : 1.0 / d[k];
    }
    std::array<std::uint32_t, MeshHierarchy::kStackSize> stack;
    std::size_t top = 0;
    stack[top++] = 0;
    while (top > 0) {
        const MeshHierarchy::Node& node = nodes[stack[--top]];
        if (!segment_meets_box(p, inverse, flat, node, grow)) continue;
        if (node.count > 0) {
            for (std::uint32_t i = node.first; i < node.first + node.count; ++i) visit(triangles[i]);
        } else if (top + 2 <= MeshHierarchy::kStackSize) {
            stack[top++] = node.first + 1;
            stack[top++] = node.first;
        }
    }
}

}  // namespace

std::shared_ptr<const MeshHierarchy> MeshHierarchy::build(TriangleMesh mesh, MeshMode mode) {
    std::shared_ptr<MeshHierarchy> h(new MeshHierarchy());
    h->mode_ = mode;
    h->mesh_ = std::move(mesh);
    const auto& vertices = h->mesh_.vertices;
    const auto& tris = h->mesh_.triangles;
    const std::size_t n = tris.size();
    std::vector<HierarchyTriangle> prepared(n);
    std::vector<Eigen::Vector3d> centroids(n);
    std::vector<Eigen::Vector3d> lowers(n);
    std::vector<Eigen::Vector3d> uppers(n);
    for (std::size_t i = 0; i < n; ++i) {
        const Eigen::Vector3d& a = vertices[tris[i][0]];
        const Eigen::Vector3d& b = vertices[tris[i][1]];
        const Eigen::Vector3d& c = vertices[tris[i][2]];
        HierarchyTriangle& t = prepared[i];
        t.a = a;
        t.ab = b - a;
        t.ac = c - a;
        t.normal = t.ab.cross(t.ac).normalized();
        t.index = static_cast<std::uint32_t>(i);
        centroids[i] = (a + b + c) / 3.0;
        lowers[i] = a.cwiseMin(b).cwiseMin(c);
        uppers[i] = a.cwiseMax(b).cwiseMax(c);
    }
    std::vector<std::uint32_t> order(n);
    std::iota(order.begin(), order.end(), 0u);
    h->nodes_.reserve(n == 0 ? 1 : 2 * n);

    struct Work {
        std::uint32_t node;
        std::uint32_t begin;
        std::uint32_t end;
        std::size_t depth;
    };
    std::vector<Work> work;
    h->nodes_.push_back(Node{});
    work.push_back({0, 0, static_cast<std::uint32_t>(n), 1});
    while (!work.empty()) {
        const Work w = work.back();
        work.pop_back();
        h->depth_ = std::max(h->depth_, w.depth);
        Eigen::Vector3d lower = Eigen::Vector3d::Constant(HUGE_VAL);
        Eigen::Vector3d upper = Eigen::Vector3d::Constant(-HUGE_VAL);
        Eigen::Vector3d clower = lower;
        Eigen::Vector3d cupper = upper;
        for (std::uint32_t i = w.begin; i < w.end; ++i) {
            lower = lower.cwiseMin(lowers[order[i]]);
            upper = upper.cwiseMax(uppers[order[i]]);
            clower = clower.cwiseMin(centroids[order[i]]);
            cupper = cupper.cwiseMax(centroids[order[i]]);
        }
        h->nodes_[w.node].lower = lower;
        h->nodes_[w.node].upper = upper;
        if (w.end - w.begin <= kLeafSize) {
            h->nodes_[w.node].first = w.begin;
            h->nodes_[w.node].count = w.end - w.begin;
            continue;
        }
        int axis = 0;
        (cupper - clower).maxCoeff(&axis);
        const std::uint32_t mid = w.begin + (w.end - w.begin) / 2;
        std::nth_element(order.begin() + w.begin, order.begin() + mid, order.begin() + w.end,
                         [&](std::uint32_t x, std::uint32_t y) { return centroids[x][axis] < centroids[y][axis]; });
        const auto first_child = static_cast<std::uint32_t>(h->nodes_.size());
        h->nodes_[w.node].first = first_child;
        h->nodes_[w.node].count = 0;
        h->nodes_.push_back(Node{});
        h->nodes_.push_back(Node{});
        work.push_back({first_child, w.begin, mid, w.depth + 1});
        work.push_back({first_child + 1, mid, w.end, w.depth + 1});
    }
    if (h->depth_ + 1 > kStackSize) throw std::length_error("MeshHierarchy: deeper than its traversal stack");
    h->triangles_.resize(n);
    for (std::size_t i = 0; i < n; ++i) h->triangles_[i] = prepared[order[i]];
    h->nodes_.shrink_to_fit();
    h->shadings_.reserve(kMaxShadings);  // counted in memory_bytes() from the start: a new table adds its own bytes
    return h;
}

SweepHit MeshHierarchy::sweep(const Eigen::Vector3d& p, const Eigen::Vector3d& q, double offset) const noexcept {
    SweepHit best;
    if (nodes_.empty() || triangles_.empty()) return best;
    const Eigen::Vector3d d = q - p;
    const double length = d.norm();
    if (!(length > 0.0)) return best;
    const double grow = offset + kEdgeTolerance;
    double fraction = HUGE_VAL;
    const HierarchyTriangle* met = nullptr;
    for_each_leaf_triangle(nodes_, triangles_, p, d, grow, [&](const HierarchyTriangle& t) noexcept {
        const double s = sweep_triangle(t, p, d, length, offset);
        if (s <= 1.0 && s < fraction) {
            fraction = s;
            met = &t;
        }
    });
    if (met != nullptr) {
        best.fraction = fraction;
        best.triangle = met->index;
        best.normal = met->normal;
        best.plane_offset = met->normal.dot(met->a);
        best.face = met;
    }
    return best;
}

const ShadingNormals* MeshHierarchy::shading(double crease_angle_deg) const {
    const std::lock_guard<std::mutex> lock(shading_mutex_);
    for (const auto& s : shadings_) {
        if (s->crease_angle_deg == crease_angle_deg) return s.get();
    }
    if (shadings_.size() >= kMaxShadings) return nullptr;
    shadings_.push_back(std::make_unique<const ShadingNormals>(shading_normals(mesh_, crease_angle_deg)));
    return shadings_.back().get();
}

const ShadingNormals* MeshHierarchy::kept_shading(double crease_angle_deg) const {
    const std::lock_guard<std::mutex> lock(shading_mutex_);
    for (const auto& s : shadings_) {
        if (s->crease_angle_deg == crease_angle_deg) return s.get();
    }
    return nullptr;
}

std::size_t MeshHierarchy::shadings_kept() const {
    const std::lock_guard<std::mutex> lock(shading_mutex_);
    return shadings_.size();
}

std::size_t MeshHierarchy::memory_bytes() const {
    std::size_t bytes = sizeof(*this) + nodes_.capacity() * sizeof(Node) +
                        triangles_.capacity() * sizeof(HierarchyTriangle) +
                        mesh_.vertices.capacity() * sizeof(Eigen::Vector3d) +
                        mesh_.triangles.capacity() * sizeof(std::array<std::uint32_t, 3>);
    const std::lock_guard<std::mutex> lock(shading_mutex_);
    bytes += shadings_.capacity() * sizeof(shadings_[0]);
    for (const auto& s : shadings_) bytes += s->memory_bytes();
    return bytes;
}

}  // namespace hapticd::mesh
