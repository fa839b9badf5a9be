// SPDX-License-Identifier: Apache-2.0
#include "mesh/self_intersection.hpp"

#include "mesh/mesh_hierarchy.hpp"

#include <Eigen/Geometry>

#include <array>
#include <cmath>
#include <cstdint>
#include <utility>
#include <vector>

namespace hapticd::mesh::detail {
namespace {

using Vec = Eigen::Vector3d;

// A point counts as inside a triangle when its barycentric coordinates all exceed kInside. A coordinate is
// computed to about 1e-16 times the triangle's aspect ratio, so 1e-9 separates "on an edge" from "inside" for
// aspect ratios up to 1e6, and is 1 nm on a 1 m edge.
constexpr double kInside = 1e-9;
// A vertex counts as on a plane when within kPlane times the mesh's bounding-box diagonal of it: a plane distance
// is computed to about 1e-16 of the coordinates (the mesh's own frame), 1e-12 leaves four orders of margin and is
// 1 pm on a 1 m mesh.
constexpr double kPlane = 1e-12;

std::string edge_text(std::uint32_t a, std::uint32_t b) {
    return "(" + std::to_string(a) + ", " + std::to_string(b) + ")";
}

// Barycentric coordinates (v, w) of x - a in the triangle a, a + ab, a + ac (x on its plane): the normal equations
// of x - a = v ab + w ac.
bool strictly_inside(const Vec& x, const Vec& a, const Vec& b, const Vec& c) {
    const Vec ab = b - a, ac = c - a, ax = x - a;
    const double d00 = ab.dot(ab), d01 = ab.dot(ac), d11 = ac.dot(ac);
    const double d20 = ax.dot(ab), d21 = ax.dot(ac);
    const double det = d00 * d11 - d01 * d01;
    const double v = (d11 * d20 - d01 * d21) / det, w = (d00 * d21 - d01 * d20) / det;
    return v > kInside && w > kInside && v + w < 1.0 - kInside;
}

// Ends of an edge strictly on both sides of a plane: signed distances beyond `side`, of opposite signs.
bool straddles(double d0, double d1, double side) { return (d0 > side && d1 < -side) || (d0 < -side && d1 > side); }

// Two triangles in one plane (normal n) have overlapping interiors when no edge of either separates them
// (separating-axis theorem: two convex polygons in a plane are disjoint iff a line along one of their edges
// separates them). An edge separates when every vertex of the other triangle has barycentric coordinate (towards
// the edge's opposite vertex) at most kInside: touching along an edge or at a vertex is no overlap.
bool separated_by_an_edge(const std::array<const Vec*, 3>& x, const std::array<const Vec*, 3>& y, const Vec& n) {
    for (int k = 0; k < 3; ++k) {
        const Vec& p = *x[k];
        const Vec e = *x[(k + 1) % 3] - p;
        const double scale = e.cross(*x[(k + 2) % 3] - p).dot(n);
        bool all_outside = true;
        for (const Vec* w : y) {
            if (e.cross(*w - p).dot(n) / scale > kInside) {
                all_outside = false;
                break;
            }
        }
        if (all_outside) return true;
    }
    return false;
}

class PairTest {
  public:
    PairTest(const TriangleMesh& mesh, double side) : mesh_(mesh), side_(side) {
        normals_.reserve(mesh.triangles.size());
        for (const auto& t : mesh.triangles) {
            const Vec& a = mesh.vertices[t[0]];
            normals_.push_back((mesh.vertices[t[1]] - a).cross(mesh.vertices[t[2]] - a).normalized());
        }
    }

    // The rule triangles t and o break, or nothing. Both triangles' vertices' signed distances to the other's
    // plane (0 for shared vertices) decide: coplanar (all within side_) -> the overlap test; else the crossings.
    std::optional<std::string> operator()(std::uint32_t t, std::uint32_t o) const {
        const auto& ti = mesh_.triangles[t];
        const auto& oi = mesh_.triangles[o];
        const std::array<const Vec*, 3> tp{&mesh_.vertices[ti[0]], &mesh_.vertices[ti[1]], &mesh_.vertices[ti[2]]};
        const std::array<const Vec*, 3> op{&mesh_.vertices[oi[0]], &mesh_.vertices[oi[1]], &mesh_.vertices[oi[2]]};
        std::array<bool, 3> t_shared{}, o_shared{};
        int shared = 0;
        for (int k = 0; k < 3; ++k) {
            for (int j = 0; j < 3; ++j) {
                if (ti[k] == oi[j]) {
                    t_shared[k] = o_shared[j] = true;
                    ++shared;
                }
            }
        }
        std::array<double, 3> dt{}, d_o{};  // T's vertices to O's plane, O's to T's
        for (int k = 0; k < 3; ++k) {
            dt[k] = t_shared[k] ? 0.0 : normals_[o].dot(*tp[k] - *op[0]);
            d_o[k] = o_shared[k] ? 0.0 : normals_[t].dot(*op[k] - *tp[0]);
        }
        const auto one_side = [this](const std::array<double, 3>& d) {
            return (d[0] > side_ && d[1] > side_ && d[2] > side_) || (d[0] < -side_ && d[1] < -side_ && d[2] < -side_);
        };
        if (one_side(dt) || one_side(d_o)) return std::nullopt;
        const auto flat = [this](const std::array<double, 3>& d) {
            return std::abs(d[0]) <= side_ && std::abs(d[1]) <= side_ && std::abs(d[2]) <= side_;
        };
        if (flat(dt) && flat(d_o)) {
            if (separated_by_an_edge(tp, op, normals_[t]) || separated_by_an_edge(op, tp, normals_[t])) {
                return std::nullopt;
            }
            std::string which;
            if (shared == 1 || shared == 2) {
                std::vector<std::uint32_t> common;
                for (int k = 0; k < 3; ++k)
                    if (t_shared[k] && (shared == 1 || t_shared[(k + 1) % 3])) {
                        common.push_back(ti[k]);
                        if (shared == 2) common.push_back(ti[(k + 1) % 3]);
                        break;
                    }
                which = shared == 1 ? ", sharing vertex " + std::to_string(common[0])
                                    : ", sharing edge " + edge_text(common[0], common[1]);
            } else if (shared == 3) {
                which = ", on the same vertices";
            }
            return "mesh: mode solid: the mesh overlaps itself: triangles " + std::to_string(t) + " and " +
                   std::to_string(o) + which +
                   ", lie in one plane and their interiors overlap (a solid's surface must not fold back onto "
                   "itself or hold a face twice)";
        }
        if (shared >= 2) return std::nullopt;  // not coplanar: they meet on the shared edge's line only
        if (shared == 1) {
            // T meets O's plane on [v, pt], O meets T's plane on [v, po], both on the planes' common line through
            // the shared vertex v (the far ends on the edges opposite v); the interiors cross when these
            // segments leave v in the same direction.
            int k = 0, j = 0;
            while (!t_shared[k]) ++k;
            while (!o_shared[j]) ++j;
            const int k1 = (k + 1) % 3, k2 = (k + 2) % 3, j1 = (j + 1) % 3, j2 = (j + 2) % 3;
            if (straddles(dt[k1], dt[k2], side_) && straddles(d_o[j1], d_o[j2], side_)) {
                const Vec& v = *tp[k];
                const Vec pt = *tp[k1] + (dt[k1] / (dt[k1] - dt[k2])) * (*tp[k2] - *tp[k1]) - v;
                const Vec po = *op[j1] + (d_o[j1] / (d_o[j1] - d_o[j2])) * (*op[j2] - *op[j1]) - v;
                if (pt.dot(po) > 0.0) {
                    return "mesh: mode solid: the mesh intersects itself: triangles " + std::to_string(t) + " and " +
                           std::to_string(o) + ", sharing vertex " + std::to_string(ti[k]) +
                           ", cross along a segment from it (a solid's surface must not cross itself)";
                }
            }
        }
        // An edge (sharing no vertex with the other triangle) whose ends lie strictly on both sides of the other's
        // plane and whose crossing point is inside it.
        const auto edge_crossing = [this](std::uint32_t edge_triangle, std::uint32_t other,
                                          const std::array<const Vec*, 3>& e, const std::array<bool, 3>& e_shared,
                                          const std::array<double, 3>& d,
                                          const std::array<const Vec*, 3>& f) -> std::optional<std::string> {
            for (int k = 0; k < 3; ++k) {
                const int k1 = (k + 1) % 3;
                if (e_shared[k] || e_shared[k1] || !straddles(d[k], d[k1], side_)) continue;
                const Vec x = *e[k] + (d[k] / (d[k] - d[k1])) * (*e[k1] - *e[k]);
                if (strictly_inside(x, *f[0], *f[1], *f[2])) {
                    const auto& ei = mesh_.triangles[edge_triangle];
                    return "mesh: mode solid: the mesh intersects itself: edge " + edge_text(ei[k], ei[k1]) +
                           " of triangle " + std::to_string(edge_triangle) + " crosses triangle " +
                           std::to_string(other) + " (a solid's surface must not cross itself)";
                }
            }
            return std::nullopt;
        };
        if (auto e = edge_crossing(t, o, tp, t_shared, dt, op)) return e;
        return edge_crossing(o, t, op, o_shared, d_o, tp);
    }

  private:
    const TriangleMesh& mesh_;
    double side_;
    std::vector<Vec> normals_;  // unit front normals, by triangle
};

}  // namespace

// Candidate pairs: for each triangle t, the triangles o > t in the hierarchy's leaves whose boxes meet t's box
// (grown by the plane tolerance), depth first with a fixed stack. Two triangles that intersect have overlapping
// boxes, so every pair that can break a rule is tested; the first t with a broken rule reports its smallest o.
std::optional<std::string> self_intersection_error(const TriangleMesh& mesh) {
    const auto h = MeshHierarchy::build(mesh, MeshMode::solid);
    Vec lower = mesh.vertices[0], upper = mesh.vertices[0];
    for (const auto& v : mesh.vertices) {
        lower = lower.cwiseMin(v);
        upper = upper.cwiseMax(v);
    }
    const double side = kPlane * (upper - lower).norm();
    const PairTest test(mesh, side);
    const auto& nodes = h->nodes();
    const auto& leaves = h->triangles();
    std::array<std::uint32_t, MeshHierarchy::kStackSize> stack{};
    for (std::uint32_t t = 0; t < mesh.triangles.size(); ++t) {
        const auto& tri = mesh.triangles[t];
        const Vec& a = mesh.vertices[tri[0]];
        const Vec& b = mesh.vertices[tri[1]];
        const Vec& c = mesh.vertices[tri[2]];
        const Vec box_lower = a.cwiseMin(b).cwiseMin(c).array() - side;
        const Vec box_upper = a.cwiseMax(b).cwiseMax(c).array() + side;
        std::optional<std::string> first;
        std::uint32_t first_o = UINT32_MAX;
        std::size_t top = 0;
        stack[top++] = 0;
        while (top > 0) {
            const MeshHierarchy::Node& node = nodes[stack[--top]];
            if ((node.lower.array() > box_upper.array()).any() || (node.upper.array() < box_lower.array()).any()) {
                continue;
            }
            if (node.count > 0) {
                for (std::uint32_t i = node.first; i < node.first + node.count; ++i) {
                    const std::uint32_t o = leaves[i].index;
                    if (o <= t || o >= first_o) continue;
                    if (auto e = test(t, o)) {
                        first = std::move(e);
                        first_o = o;
                    }
                }
            } else if (top + 2 <= MeshHierarchy::kStackSize) {
                stack[top++] = node.first + 1;
                stack[top++] = node.first;
            }
        }
        if (first) return first;
    }
    return std::nullopt;
}

}  // namespace hapticd::mesh::detail
