// SPDX-License-Identifier: Apache-2.0
#include "mesh/god_object_proxy.hpp"

#include <Eigen/Geometry>

#include <algorithm>
#include <bit>
#include <cmath>
#include <utility>

namespace hapticd::mesh {
namespace {

// A constraint: the proxy stays on the front side of normal . x >= offset (a triangle's plane moved out by
// kSurfaceOffset).
struct Plane {
    Eigen::Vector3d normal;
    double offset;
    std::uint32_t triangle;
};

struct ClosestPoint {
    Eigen::Vector3d point;
    unsigned subset = 0;  // bit i: plane i is tight at `point`
    bool found = false;
};

// Below this Gram determinant the subset's planes are (nearly) dependent: 1e-10 is an angle of 1e-5 rad between
// two normals; such a subset's point is also reached through a smaller subset.
constexpr double kDependent = 1e-10;
constexpr double kFeasible = 1e-12;  // m: rounding allowance of a point on a plane (coordinates up to 100 m)

// The point on the planes of `subset` closest to h (h + N^T lambda, (N N^T) lambda = c - N h), if they are
// independent.
bool project_on_subset(const std::array<Plane, GodObjectProxy::kMaxPlanes>& planes, unsigned subset,
                       const Eigen::Vector3d& h, Eigen::Vector3d& x) noexcept {
    std::array<int, 3> index{};
    int k = 0;
    for (int i = 0; i < GodObjectProxy::kMaxPlanes; ++i) {
        if ((subset >> i) & 1u) index[k++] = i;
    }
    if (k == 1) {
        const Plane& a = planes[index[0]];
        x = h + (a.offset - a.normal.dot(h)) * a.normal;
        return true;
    }
    if (k == 2) {
        const Plane& a = planes[index[0]];
        const Plane& b = planes[index[1]];
        const double g = a.normal.dot(b.normal);
        const double det = 1.0 - g * g;
        if (!(det > kDependent)) return false;
        const double ra = a.offset - a.normal.dot(h);
        const double rb = b.offset - b.normal.dot(h);
        const double la = (ra - g * rb) / det;
        const double lb = (rb - g * ra) / det;
        x = h + la * a.normal + lb * b.normal;
        return true;
    }
    // Three planes: their one common point, x = (c0 (n1 x n2) + c1 (n2 x n0) + c2 (n0 x n1)) / det(n0, n1, n2).
    const Plane& a = planes[index[0]];
    const Plane& b = planes[index[1]];
    const Plane& c = planes[index[2]];
    const Eigen::Vector3d bc = b.normal.cross(c.normal);
    const double det = a.normal.dot(bc);
    if (!(det * det > kDependent)) return false;
    x = (a.offset * bc + b.offset * c.normal.cross(a.normal) + c.offset * a.normal.cross(b.normal)) / det;
    return true;
}

// The point closest to h on the front of every plane (a QP over at most kMaxPlanes half-spaces): the minimiser
// lies on the relative interior of a face of the feasible polyhedron, i.e. it is the projection of h on the
// planes of some subset of at most three, and it is the feasible projection nearest h. Enumerates the 14
// subsets of at most three of 4 planes (and h itself).
ClosestPoint closest_point(const std::array<Plane, GodObjectProxy::kMaxPlanes>& planes, int count,
                           const Eigen::Vector3d& h) noexcept {
    ClosestPoint best;
    double best_distance = HUGE_VAL;
    const unsigned all = (1u << count) - 1u;
    for (unsigned subset = 0; subset <= all; ++subset) {
        const int size = std::popcount(subset);
        if (size > 3) continue;
        Eigen::Vector3d x = h;
        if (size > 0 && !project_on_subset(planes, subset, h, x)) continue;
        bool feasible = true;
        for (int i = 0; i < count && feasible; ++i) {
            feasible = planes[i].normal.dot(x) >= planes[i].offset - kFeasible;
        }
        if (!feasible) continue;
        const double distance = (x - h).squaredNorm();
        if (distance < best_distance) {
            best_distance = distance;
            best.point = x;
            best.subset = subset;
            best.found = true;
        }
    }
    return best;
}

}  // namespace

GodObjectProxy::GodObjectProxy(std::shared_ptr<const MeshHierarchy> hierarchy, MeshFriction friction)
    : hierarchy_(std::move(hierarchy)) {
    const auto sane = [](double mu) { return std::isfinite(mu) && mu > 0.0 ? mu : 0.0; };
    friction_.static_coefficient = sane(friction.static_coefficient);
    friction_.dynamic_coefficient = std::min(sane(friction.dynamic_coefficient), friction_.static_coefficient);
}

void GodObjectProxy::reset(const Eigen::Vector3d& handle) noexcept {
    contact_ = ProxyContact{};
    if (handle.allFinite()) contact_.proxy = handle;
}

const ProxyContact& GodObjectProxy::step(const Eigen::Vector3d& handle) noexcept {
    if (!handle.allFinite()) return contact_;
    const MeshHierarchy& mesh = *hierarchy_;
    const double mu_static = friction_.static_coefficient;
    const double mu_dynamic = friction_.dynamic_coefficient;
    Eigen::Vector3d p = contact_.proxy;
    std::array<Plane, kMaxPlanes> planes{};
    int count = 0;
    ClosestPoint solution;
    bool first_friction_check = true;
    bool slid = false;
    int sweeps = 0;
    int kept = 0;  // the planes before the last restart (reported when the sweeps run out after it)
    bool converged = false;
    while (sweeps < kMaxSweeps) {
        Eigen::Vector3d goal = handle;
        if (count > 0) {
            solution = closest_point(planes, count, handle);
            if (!solution.found) break;  // dependent planes: not converged
            goal = solution.point;
            if (mu_static > 0.0) {
                // Friction cone around the frictionless proxy `goal`: penetration |h - goal| (along the active
                // normals), tangential offset |p - goal| (within the active planes).
                const double penetration = (handle - goal).norm();
                const double offset = (p - goal).norm();
                const double mu = first_friction_check && !contact_.sliding ? mu_static : mu_dynamic;
                first_friction_check = false;
                if (offset <= mu * penetration) {  // sticks
                    converged = true;
                    break;
                }
                goal += (mu_dynamic * penetration / offset) * (p - goal);
                slid = true;
            }
        }
        if ((goal - p).squaredNorm() <= 1e-24) {
            converged = true;
            break;
        }
        const SweepHit hit = mesh.sweep(p, goal);
        ++sweeps;
        if (!hit.hit()) {
            p = goal;
            if (count == 0) {
                converged = true;
                break;
            }
            // On the target of these planes: sweep toward the handle again (it may reach past a convex edge).
            kept = count;
            count = 0;
            continue;
        }
        p += hit.fraction * (goal - p);
        bool known = false;
        for (int i = 0; i < count; ++i) known = known || planes[i].triangle == hit.triangle;
        if (known || count == kMaxPlanes) break;
        planes[count++] = Plane{hit.normal, hit.plane_offset + kSurfaceOffset, hit.triangle};
    }
    contact_.proxy = p;
    contact_.sweeps = sweeps;
    contact_.sliding = slid;
    contact_.converged = converged;
    contact_.constraints = 0;
    contact_.triangle = UINT32_MAX;
    if (count == 0 && (p - handle).squaredNorm() > 1e-24) count = kept;
    if (count > 0) {
        solution = closest_point(planes, count, handle);
        if (solution.found) {
            for (int i = 0; i < count; ++i) {
                if (((solution.subset >> i) & 1u) && contact_.constraints < 3) {
                    contact_.normals[contact_.constraints++] = planes[i].normal;
                    contact_.triangle = planes[i].triangle;
                }
            }
        }
    }
    return contact_;
}

}  // namespace hapticd::mesh
