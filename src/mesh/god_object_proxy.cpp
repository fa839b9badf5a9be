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
    const HierarchyTriangle* face;
};

// Distance from x to the closed triangle (Ericson, Real-Time Collision Detection, 5.1.5: the Voronoi region of
// x among the vertices, edges and face).
double distance_to_triangle(const HierarchyTriangle& t, const Eigen::Vector3d& x) noexcept {
    const Eigen::Vector3d& ab = t.ab;
    const Eigen::Vector3d& ac = t.ac;
    const Eigen::Vector3d ap = x - t.a;
    const double d1 = ab.dot(ap), d2 = ac.dot(ap);
    if (d1 <= 0.0 && d2 <= 0.0) return ap.norm();
    const Eigen::Vector3d bp = ap - ab;
    const double d3 = ab.dot(bp), d4 = ac.dot(bp);
    if (d3 >= 0.0 && d4 <= d3) return bp.norm();
    const double vc = d1 * d4 - d3 * d2;
    if (vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0) return (ap - (d1 / (d1 - d3)) * ab).norm();
    const Eigen::Vector3d cp = ap - ac;
    const double d5 = ab.dot(cp), d6 = ac.dot(cp);
    if (d6 >= 0.0 && d5 <= d6) return cp.norm();
    const double vb = d5 * d2 - d1 * d6;
    if (vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0) return (ap - (d2 / (d2 - d6)) * ac).norm();
    const double va = d3 * d6 - d5 * d4;
    if (va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0) {
        return (bp - ((d4 - d3) / ((d4 - d3) + (d5 - d6))) * (ac - ab)).norm();
    }
    return std::abs(t.normal.dot(ap));
}

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
    bool first_friction_check = true;
    bool slid = false;
    bool converged = false;
    int sweeps = 0;
    // Drops the planes whose triangle the proxy does not rest on: farther than kSurfaceOffset + kRestingReach from
    // the triangle, or above the plane's offset level (by more than 1e-9 m). A plane constrains the proxy only
    // where it touches it. True when one was dropped.
    const auto prune = [&]() noexcept {
        int kept = 0;
        for (int i = 0; i < count; ++i) {
            if (planes[i].normal.dot(p) <= planes[i].offset + 1e-9 &&
                distance_to_triangle(*planes[i].face, p) <= kSurfaceOffset + MeshHierarchy::kRestingReach) {
                planes[kept++] = planes[i];
            }
        }
        const bool dropped = kept < count;
        count = kept;
        return dropped;
    };
    // Each pass sweeps once or drops a plane (at most kMaxPlanes drops between sweeps).
    for (int pass = 0; pass < kMaxSweeps * (kMaxPlanes + 1) && sweeps < kMaxSweeps; ++pass) {
        Eigen::Vector3d goal = handle;
        if (count > 0) {
            if (mu_static > 0.0 && prune()) continue;  // friction acts on the planes the proxy touches
            const ClosestPoint solution = closest_point(planes, count, handle);
            if (!solution.found) break;  // dependent planes: not converged
            goal = solution.point;
            if (mu_static > 0.0) {
                // The frictionless proxy `goal` must be reachable on these planes: a plane the proxy rests on and
                // would meet at once on its way there joins them first.
                if ((goal - p).squaredNorm() > 1e-24) {
                    const SweepHit toward = mesh.sweep(p, goal);
                    ++sweeps;
                    if (toward.hit() && toward.fraction <= 0.0) {
                        bool known = false;
                        for (int i = 0; i < count; ++i) known = known || planes[i].triangle == toward.triangle;
                        if (!known && count < kMaxPlanes) {
                            planes[count++] = Plane{toward.normal, toward.plane_offset + kSurfaceOffset,
                                                    toward.triangle, toward.face};
                            continue;
                        }
                    }
                }
                // Friction cone around the frictionless proxy `goal`: penetration |h - goal| (along the active
                // normals), tangential offset |lifted - goal| (within the active planes), `lifted` the proxy put
                // back on the planes' front if it is below one (friction holds tangential motion only).
                const ClosestPoint lift = closest_point(planes, count, p);
                const Eigen::Vector3d lifted = lift.found ? lift.point : p;
                const double penetration = (handle - goal).norm();
                const double offset = (lifted - goal).norm();
                const double mu = first_friction_check && !contact_.sliding ? mu_static : mu_dynamic;
                if (offset <= mu * penetration) {  // sticks
                    if ((lifted - p).squaredNorm() > 1e-24) {
                        goal = lifted;
                    } else {
                        if (prune()) continue;
                        converged = true;
                        break;
                    }
                } else {
                    first_friction_check = false;
                    goal += (mu_dynamic * penetration / offset) * (lifted - goal);
                    slid = true;
                }
            }
        }
        if ((goal - p).squaredNorm() <= 1e-24) {
            if (prune()) continue;
            converged = true;
            break;
        }
        const SweepHit hit = mesh.sweep(p, goal);
        ++sweeps;
        if (!hit.hit()) {
            p = goal;
            // On the closest point of planes it rests on: done; else without the planes left behind.
            if (count == 0 || !prune()) {
                converged = true;
                break;
            }
            continue;
        }
        p += hit.fraction * (goal - p);
        bool known = false;
        for (int i = 0; i < count; ++i) known = known || planes[i].triangle == hit.triangle;
        if (known) break;
        if (count == kMaxPlanes) {
            // Full (a vertex shared by more than three triangles): keep the planes the closest point lies on.
            const ClosestPoint solution = closest_point(planes, count, handle);
            int kept = 0;
            for (int i = 0; i < count; ++i) {
                if (solution.found && ((solution.subset >> i) & 1u)) planes[kept++] = planes[i];
            }
            if (kept == kMaxPlanes) break;
            count = kept;
        }
        planes[count++] = Plane{hit.normal, hit.plane_offset + kSurfaceOffset, hit.triangle, hit.face};
    }
    contact_.proxy = p;
    contact_.sweeps = sweeps;
    contact_.sliding = slid;
    contact_.converged = converged;
    contact_.constraints = 0;
    contact_.triangle = UINT32_MAX;
    if (count > 0) {
        const ClosestPoint solution = closest_point(planes, count, handle);
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
