// SPDX-License-Identifier: Apache-2.0
// A proof of stability over a plant set for summed gains whose matrices do not commute: the joint numerical range of
// the gains and the Edge Theorem. Beyond Hulin et al. 2011.
//
// The coupled loop (matrix_gain_stability.hpp) has the characteristic polynomial det P(z), P(z) = P_0(z) I +
// P_alpha(z) A + P_beta(z) B with symmetric A, B (r x r) and the scalar polynomials of the one-direction loop
// p(z; alpha, beta) = P_0 + alpha P_alpha + beta P_beta (with a velocity estimator: P_0 At, P_alpha At, P_alpha Bt).
// If det P(z) = 0, a unit vector v in C^r has P(z) v = 0, hence
//
//   v^* P(z) v = P_0(z) + a P_alpha(z) + b P_beta(z) = 0,   (a, b) = (v^* A v, v^* B v),
//
// with a, b real (A, B Hermitian): every root of the coupled loop is a root of the scalar loop at a point (a, b) of the
// joint numerical range W(A, B) = {(v^* A v, v^* B v): v in C^r, |v| = 1}. W is the numerical range of A + i B, compact
// and convex (Toeplitz-Hausdorff), with support function h(phi) = lambda_max(cos(phi) A + sin(phi) B). The mass scaled
// by 1 / s gives the gains s A, s B and the points s W.
//
// The certificate. (1) An outer polygon P of W: the half-planes cos(phi_j) a + sin(phi_j) b <= h(phi_j) + e at m
// directions phi_j (first 2 pi j / m, m a multiple of 4, so P lies in W's bounding box), e = 64 eps (|A| + |B|)
// covering the eigenvalues' rounding; its vertices are the intersections of consecutive lines. (2) K = conv(s_lo P u
// s_hi P), which holds s P for every s in [s_lo, s_hi] (s w is a convex combination of s_lo w and s_hi w), with crowded
// vertices merged outwards (K grows by at most 1 % of the gains' size where it does: merge_crowded_vertices). (3) Every
// edge of K judged as a gain segment (mass_scaling_stability.hpp, GainSegment) over the rest of the plant set by the
// caller's verdict: exact along the segment for one plant (MassScalingTest::segment_over), or certified over an arm box
// and a delay range (ArmBoxTest::segment_over). (4) Where an edge fails outside the hull of W's support points
// (scaled), P is refined there: a line halves the gap at each of the failing edge's ends (certify_by_numerical_range).
//
// Theorem used: the Edge Theorem (Bartlett, Hollot and Lin, Math. Control Signals Systems 1 (1988) 61-71; it holds for
// any simply connected stability domain, the unit disc included): a polytope of polynomials of one degree has all its
// members' roots in the domain iff every exposed edge's members do. The scalar loops with gains in K form such a
// polytope (the affine image of K; monic), whose exposed edges are images of edges of K. So if every edge is stable for
// every plant of the set, every scalar loop with gains in K is; by the above no coupled loop with gains s (A, B),
// s in [s_lo, s_hi], then has a root on the unit circle at any plant of the set; the set is connected and the roots
// move continuously with the plant, so the coupled loop is stable at every plant iff it is at one: the caller's anchor
// (a verdict of the coupled loop at one plant of the set).
//
// Families. A set F of gain pairs (A, B) whose ranges all lie in the hull H = conv(W(A_1, B_1) u ... u W(A_k, B_k)) of
// k members' ranges is certified at once with H for W: every root of every loop of F is a root of a scalar loop with
// gains in H. If F is connected and the roots move continuously over it, one anchor (one member at one plant) again
// decides every member at every plant. The case it serves: a mesh's proxy couples to the handle with K P, B P for the
// projector P of its active constraints (rank 1, 2 or 3, any orientation), beside other objects' (A_0, B_0); with
// (A_I, B_I) its gains at P = I, every P gives v^* A v = v^* A_0 v + tau v^* A_I v with one tau in [0, 1] for A and B
// alike (tau = |P w|^2 / |w|^2, w = M^-1/2 v), so every configuration's range lies in the hull of W(A_0, B_0) and
// W(A_0 + A_I, B_0 + B_I), and the family 0 <= Q <= I (Q for P) is convex. Several meshes: the members are A_0 plus
// each subset of them at P = I (2^k members).
//
// Sufficient, not necessary: W is a relaxation (the coupled loop can be stable while a scalar loop of W is not), and P
// exceeds W: each vertex lies within (D / 2) tan(dphi / 2) of W, D the distance between the support points of its two
// lines and dphi their angle (the triangle they form has the apex angle pi - dphi), and within its `excess` of the hull
// of the support points (NumericalRangeOutline). A certificate that fails proves nothing either way. Tested against the
// coupled loop's state matrix, built independently, at plants drawn from the set
// (tests/beyond/test_numerical_range_certificate.cpp).
// Cost per polygon: m symmetric r x r eigenvalue problems per member, a hull of 2 m points and at most m + 2 segment
// verdicts (K's edges: the edges of s_lo P facing the origin, those of s_hi P facing away, and two along rays), fewer
// after the merge; a refined polygon asks only for the verdicts of its new edges. Not for the real-time loop
// (allocates).
#pragma once

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <limits>
#include <utility>
#include <vector>

#include "config.hpp"
#include "errors.hpp"
#include "mass_scaling_stability.hpp"
#include "matrix_gain_stability.hpp"

namespace hapticopt {

namespace detail {
/// The distance from p to the segment [a, b] (a point when a = b).
inline double segment_distance(const Eigen::Vector2d& p, const Eigen::Vector2d& a, const Eigen::Vector2d& b) {
    const Eigen::Vector2d e = b - a;
    const double t = e.squaredNorm() > 0.0 ? std::clamp((p - a).dot(e) / e.squaredNorm(), 0.0, 1.0) : 0.0;
    return (a + t * e - p).norm();
}
}  // namespace detail

/// An outer polygon of the joint numerical range W(A, B) (header comment) from support lines at the directions
/// phi_j = 2 pi turns[j] (turns increasing in [0, 1), consecutive ones less than half a turn apart, the last to the
/// first across 1; a multiple of 1/4 is the axis direction exactly), with what bounds its excess over W.
struct NumericalRangeOutline {
    std::vector<Eigen::Vector2d> vertices;  ///< vertex j: lines j and j + 1 meet (counter-clockwise)
    std::vector<Eigen::Vector2d> support;   ///< a point of W on line j: (v^T A v, v^T B v), v its top eigenvector
    /// The distance of vertex j from the chord support[j] .. support[j + 1]. conv(support) lies in W, and the polygon
    /// minus conv(support) is the union of the triangles (support[j], vertex j, support[j + 1]): every point of the
    /// polygon lies within max(excess) of W.
    std::vector<double> excess;
};

/// One member of a family of summed gains (A, B symmetric r x r, normalised as the loop's): the family's certificate
/// judges the convex hull of the union of its members' numerical ranges (header comment, "Families").
struct GainMatrixPair {
    Eigen::MatrixXd A, B;
};

/// The outline of conv(W(A_1, B_1) u ... u W(A_k, B_k)) at `turns` (NumericalRangeOutline, with that hull for W): the
/// support function is the members' largest, max_i lambda_max(cos(phi) A_i + sin(phi) B_i), and each line's support
/// point the maximising member's. Cost: k symmetric r x r eigen problems per line. Throws InvalidParameter for no
/// member, A, B not square, of different sizes (also across members), not finite, or turns not as stated (2 to 4096
/// of them).
HAPTICOPT_FUNC NumericalRangeOutline numerical_range_outline(const std::vector<GainMatrixPair>& members,
                                                             const std::vector<double>& turns)
#if HAPTICOPT_DEFINITIONS
{
    const char* fn = "hapticopt::numerical_range_outline";
    if (members.empty()) throw InvalidParameter(fn, "members", 0.0, "at least one pair (A, B)");
    const Eigen::Index r = members.front().A.rows();
    for (const GainMatrixPair& g : members) {
        if (r == 0 || g.A.rows() != r || g.A.cols() != r || g.B.rows() != r || g.B.cols() != r) {
            throw InvalidParameter(fn, "A, B", static_cast<double>(g.A.rows()), "square matrices of one size >= 1");
        }
        if (!g.A.allFinite() || !g.B.allFinite()) throw InvalidParameter(fn, "A, B", 0.0, "finite entries");
    }
    const std::size_t m = turns.size();
    if (m < 2 || m > 4096) throw InvalidParameter(fn, "turns", static_cast<double>(m), "2 to 4096 directions");
    for (std::size_t j = 0; j < m; ++j) {
        const double gap = (j + 1 < m ? turns[j + 1] : turns[0] + 1.0) - turns[j];
        if (!(turns[j] >= 0.0 && turns[j] < 1.0 && gap > 0.0 && gap < 0.5)) {
            throw InvalidParameter(fn, "turns", turns[j], "increasing in [0, 1), consecutive ones less than 1/2 apart");
        }
    }
    std::vector<Eigen::MatrixXd> As, Bs;
    double rounding = 0.0;
    for (const GainMatrixPair& g : members) {
        As.push_back(0.5 * (g.A + g.A.transpose()));
        Bs.push_back(0.5 * (g.B + g.B.transpose()));
        rounding = std::max(rounding, kMatrixGainRoundingLevel * (As.back().norm() + Bs.back().norm()));
    }
    const double pi = 3.14159265358979323846;
    NumericalRangeOutline o;
    std::vector<double> c(m), s(m), h(m);
    o.support.resize(m);
    for (std::size_t j = 0; j < m; ++j) {
        const double quarters = 4.0 * turns[j];
        if (quarters == std::floor(quarters)) {  // the axis directions exactly: P then lies in W's bounding box
            const int q = static_cast<int>(quarters);
            c[j] = q == 0 ? 1.0 : (q == 2 ? -1.0 : 0.0);
            s[j] = q == 1 ? 1.0 : (q == 3 ? -1.0 : 0.0);
        } else {
            c[j] = std::cos(2 * pi * turns[j]);
            s[j] = std::sin(2 * pi * turns[j]);
        }
        h[j] = -std::numeric_limits<double>::infinity();
        for (std::size_t i = 0; i < members.size(); ++i) {
            const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> e(c[j] * As[i] + s[j] * Bs[i]);
            Eigen::Index top = 0;
            const double top_value = e.eigenvalues().maxCoeff(&top);
            if (!(top_value + rounding > h[j])) continue;
            h[j] = top_value + rounding;
            const Eigen::VectorXd v = e.eigenvectors().col(top);
            o.support[j] = Eigen::Vector2d(v.dot(As[i] * v), v.dot(Bs[i] * v));
        }
    }
    o.vertices.reserve(m);
    o.excess.reserve(m);
    for (std::size_t i = 0; i < m; ++i) {
        const std::size_t k = (i + 1) % m;
        // c_i a + s_i b = h_i and c_k a + s_k b = h_k (Cramer; the determinant is the sine of the gap, > 0).
        const double det = c[i] * s[k] - s[i] * c[k];
        const Eigen::Vector2d x((h[i] * s[k] - s[i] * h[k]) / det, (c[i] * h[k] - c[k] * h[i]) / det);
        o.vertices.push_back(x);
        o.excess.push_back(detail::segment_distance(x, o.support[i], o.support[k]));
    }
    return o;
}
#else
    ;
#endif

/// The outline of W(A, B) at `turns` (NumericalRangeOutline): the family of the one member (A, B). Throws as the
/// family's outline.
HAPTICOPT_FUNC NumericalRangeOutline numerical_range_outline(const Eigen::MatrixXd& A, const Eigen::MatrixXd& B,
                                                             const std::vector<double>& turns)
#if HAPTICOPT_DEFINITIONS
{
    return numerical_range_outline(std::vector<GainMatrixPair>{GainMatrixPair{A, B}}, turns);
}
#else
    ;
#endif

/// The outer polygon of W(A, B) from `directions` support lines at the equally spaced directions 2 pi j / m (m a
/// multiple of 4 in [4, 4096]): its vertices (a, b), counter-clockwise; each lies within (D / 2) tan(pi / m) of W
/// (header comment). Throws InvalidParameter as numerical_range_outline, and for another number of directions.
HAPTICOPT_FUNC std::vector<Eigen::Vector2d> numerical_range_polygon(const Eigen::MatrixXd& A, const Eigen::MatrixXd& B,
                                                                    int directions)
#if HAPTICOPT_DEFINITIONS
{
    if (directions < 4 || directions > 4096 || directions % 4 != 0) {
        throw InvalidParameter("hapticopt::numerical_range_polygon", "directions", directions,
                               "a multiple of 4 in [4, 4096]");
    }
    std::vector<double> turns(static_cast<std::size_t>(directions));
    for (int j = 0; j < directions; ++j) turns[static_cast<std::size_t>(j)] = static_cast<double>(j) / directions;
    return numerical_range_outline(A, B, turns).vertices;
}
#else
    ;
#endif

/// conv(s_lo P u s_hi P) of a polygon P (0 < s_lo <= s_hi, finite): its vertices counter-clockwise (Andrew's monotone
/// chain; points on an edge dropped).
HAPTICOPT_FUNC std::vector<Eigen::Vector2d> scaled_polygon_hull(const std::vector<Eigen::Vector2d>& polygon,
                                                                double s_lo, double s_hi)
#if HAPTICOPT_DEFINITIONS
{
    if (!(s_lo > 0 && s_lo <= s_hi && std::isfinite(s_hi))) {
        throw InvalidParameter("hapticopt::scaled_polygon_hull", "scale interval", s_lo, "0 < s_lo <= s_hi, finite");
    }
    std::vector<Eigen::Vector2d> points;
    for (const Eigen::Vector2d& v : polygon) {
        points.push_back(s_lo * v);
        if (s_hi > s_lo) points.push_back(s_hi * v);
    }
    std::sort(points.begin(), points.end(), [](const Eigen::Vector2d& a, const Eigen::Vector2d& b) {
        return a.x() < b.x() || (a.x() == b.x() && a.y() < b.y());
    });
    points.erase(std::unique(points.begin(), points.end()), points.end());
    if (points.size() < 3) return points;
    auto cross = [](const Eigen::Vector2d& o, const Eigen::Vector2d& a, const Eigen::Vector2d& b) {
        return (a.x() - o.x()) * (b.y() - o.y()) - (a.y() - o.y()) * (b.x() - o.x());
    };
    std::vector<Eigen::Vector2d> hull(2 * points.size());
    std::size_t k = 0;
    for (const Eigen::Vector2d& p : points) {  // lower chain
        while (k >= 2 && cross(hull[k - 2], hull[k - 1], p) <= 0) --k;
        hull[k++] = p;
    }
    for (std::size_t i = points.size() - 1, lower = k + 1; i-- > 0;) {  // upper chain
        while (k >= lower && cross(hull[k - 2], hull[k - 1], points[i]) <= 0) --k;
        hull[k++] = points[i];
    }
    hull.resize(k - 1);
    return hull;
}
#else
    ;
#endif

/// A convex polygon (counter-clockwise) holding `hull`, with fewer vertices where they crowd: an edge is dropped when
/// the lines of its two neighbouring edges meet ahead of both its ends, at a point w within `relative` times |v| of
/// every vertex v of `hull` that it replaces (the polygon grows by the triangle between the edge and w). Dropping an
/// edge drops its half-plane only, so the result holds `hull`. Cost: O(n^2) for n vertices.
HAPTICOPT_FUNC std::vector<Eigen::Vector2d> merge_crowded_vertices(std::vector<Eigen::Vector2d> hull, double relative)
#if HAPTICOPT_DEFINITIONS
{
    auto cross = [](const Eigen::Vector2d& a, const Eigen::Vector2d& b) { return a.x() * b.y() - a.y() * b.x(); };
    std::vector<std::vector<Eigen::Vector2d>> replaced(hull.size());  // the input's vertices each one stands for
    for (std::size_t i = 0; i < hull.size(); ++i) replaced[i].push_back(hull[i]);
    bool merged = true;
    while (merged && hull.size() > 3) {
        merged = false;
        const std::size_t n = hull.size();
        for (std::size_t i = 0; i < n && !merged; ++i) {
            const std::size_t next = (i + 1) % n;
            const Eigen::Vector2d& before = hull[(i + n - 1) % n];
            const Eigen::Vector2d& from = hull[i];
            const Eigen::Vector2d& to = hull[next];
            const Eigen::Vector2d& after = hull[(i + 2) % n];
            // from + t (from - before) = to + u (to - after), t, u >= 0
            const Eigen::Vector2d d1 = from - before, d2 = to - after, rhs = to - from;
            const double det = cross(d1, -d2);
            if (!(std::abs(det) > 0.0)) continue;
            const double t = cross(rhs, -d2) / det, u = cross(d1, rhs) / det;
            const Eigen::Vector2d w = from + t * d1;
            if (!(t >= 0.0 && u >= 0.0) || !w.allFinite()) continue;
            std::vector<Eigen::Vector2d> both = replaced[i];
            both.insert(both.end(), replaced[next].begin(), replaced[next].end());
            if (!std::all_of(both.begin(), both.end(),
                             [&](const Eigen::Vector2d& v) { return (w - v).norm() <= relative * v.norm(); }))
                continue;
            hull[i] = w;
            replaced[i] = std::move(both);
            hull.erase(hull.begin() + static_cast<std::ptrdiff_t>(next));
            replaced.erase(replaced.begin() + static_cast<std::ptrdiff_t>(next));
            merged = true;
        }
    }
    return hull;
}
#else
    ;
#endif

/// The distance from w to the convex polygon `hull` (counter-clockwise, as scaled_polygon_hull returns it): 0 inside.
HAPTICOPT_FUNC double distance_to_convex_polygon(const std::vector<Eigen::Vector2d>& hull, const Eigen::Vector2d& w)
#if HAPTICOPT_DEFINITIONS
{
    if (hull.empty()) return std::numeric_limits<double>::infinity();
    if (hull.size() < 3) return detail::segment_distance(w, hull.front(), hull.back());
    bool inside = true;
    double nearest = std::numeric_limits<double>::infinity();
    for (std::size_t i = 0; i < hull.size(); ++i) {
        const Eigen::Vector2d& a = hull[i];
        const Eigen::Vector2d& b = hull[(i + 1) % hull.size()];
        inside = inside && (b.x() - a.x()) * (w.y() - a.y()) - (b.y() - a.y()) * (w.x() - a.x()) >= 0.0;
        nearest = std::min(nearest, detail::segment_distance(w, a, b));
    }
    return inside ? 0.0 : nearest;
}
#else
    ;
#endif

/// Refinements of certify_by_numerical_range after a verdict that failed without deciding (GainRayStability::certified
/// false: e.g. an arm box's subdivision limit), each of which costs the caller's whole budget.
inline constexpr int kNumericalRangeUndecidedRefinements = 2;

/// The narrowest gap between two support lines a refinement makes, in turns (below, a vertex's two lines are so close
/// to parallel that Cramer's rule loses its digits).
inline constexpr double kNumericalRangeFinestGap = 1.0 / 65536;

/// How far certify_by_numerical_range lets K grow to merge crowded vertices (merge_crowded_vertices), relative to the
/// gains' size at each: the polygon's ends at the tip of a thin range crowd, and each of their edges costs a verdict.
inline constexpr double kNumericalRangeMergeRelative = 0.01;

/// The outcome of certify_by_numerical_range.
struct NumericalRangeCertificate {
    bool proven =
        false;      ///< every edge of K stable over the set: no coupled loop of the family has a root on the circle
    int edges = 0;  ///< edge verdicts asked of the caller (an edge of an earlier polygon kept by a finer one: once)
    int directions = 0;                          ///< support lines of the last polygon P
    int refinements = 0;                         ///< polygons refined after a failing verdict
    double failing_alpha = 0, failing_beta = 0;  ///< not proven: the gains of K at which the last edge's verdict failed
};

/// The certificate of the header comment for symmetric A, B (r x r, normalised for the reference mass; not commuting,
/// else the per-direction verdicts are exact and cheaper) over the scales [s_lo, s_hi] (0 < s_lo <= s_hi), starting
/// with `directions` equally spaced support lines. `segment_verdict(const GainSegment&)` returns a GainRayStability
/// (stable, and the segment's u where it fails) for every plant of the rest of the set. Edges are judged longest first.
///
/// Refinement, up to `max_directions` lines (0: none). A failing verdict at gains g of K proves nothing when g lies
/// outside K_in = conv(s_lo Q u s_hi Q), Q the convex hull of the support points (Q lies in W, so K_in in the hull of
/// the set's ranges): g may then belong to the polygon's excess alone. The failing edge's gains are at a distance
/// delta > 0 from K_in; K lies within s_hi max(excess) of K_in (NumericalRangeOutline), so some vertex has an excess of
/// at least delta / s_hi, and every gap between two lines whose vertex exceeds delta / (2 s_hi) is halved (the new line
/// at the mean direction). The finer polygon is judged again; its edges that are edges of an earlier polygon keep their
/// verdicts. The certificate ends unproven when g lies in K_in (W's own hull fails there: no polygon can help), when no
/// line is left, after kNumericalRangeUndecidedRefinements refinements for undecided verdicts (certified false), or on
/// the first failure without refinement.
/// Cost: per polygon, one r x r eigen problem per line and the verdicts of its new edges.
/// The family's certificate (header comment, "Families"): the same with conv(W(A_1, B_1) u ... u W(A_k, B_k)) for W.
template <typename SegmentVerdict>
NumericalRangeCertificate certify_by_numerical_range(const std::vector<GainMatrixPair>& members, double s_lo,
                                                     double s_hi, int directions, SegmentVerdict&& segment_verdict,
                                                     int max_directions = 0) {
    const char* fn = "hapticopt::certify_by_numerical_range";
    if (directions < 4 || directions > 4096 || directions % 4 != 0) {
        throw InvalidParameter(fn, "directions", directions, "a multiple of 4 in [4, 4096]");
    }
    if (max_directions != 0 && (max_directions < directions || max_directions > 4096)) {
        throw InvalidParameter(fn, "max_directions", max_directions, "0 (no refinement) or directions .. 4096");
    }
    NumericalRangeCertificate r;
    std::vector<double> turns(static_cast<std::size_t>(directions));
    for (int j = 0; j < directions; ++j) turns[static_cast<std::size_t>(j)] = static_cast<double>(j) / directions;
    // Edges found stable, by their ends (a vertex kept by a refinement is recomputed bit for bit).
    std::vector<std::pair<Eigen::Vector2d, Eigen::Vector2d>> stable_edges;
    int undecided = 0;
    for (;;) {
        const NumericalRangeOutline outline = numerical_range_outline(members, turns);
        r.directions = static_cast<int>(turns.size());
        const std::vector<Eigen::Vector2d> hull =
            merge_crowded_vertices(scaled_polygon_hull(outline.vertices, s_lo, s_hi), kNumericalRangeMergeRelative);
        if (!std::all_of(hull.begin(), hull.end(), [](const Eigen::Vector2d& w) { return w.allFinite(); })) return r;
        // The longest edges first: the polygon's excess over the range is largest at their ends, where an unstable
        // gain pair outside the range most often lies, so a certificate that fails most often fails at its first
        // verdicts.
        std::vector<std::size_t> order(hull.size() == 2 ? 1 : hull.size());
        for (std::size_t i = 0; i < order.size(); ++i) order[i] = i;
        auto length = [&](std::size_t i) { return (hull[(i + 1) % hull.size()] - hull[i]).norm(); };
        std::stable_sort(order.begin(), order.end(),
                         [&](std::size_t a, std::size_t b) { return length(a) > length(b); });
        bool failed = false;
        Eigen::Vector2d failing_from, failing_to;
        bool failure_decided = false;
        for (const std::size_t i : order) {
            const Eigen::Vector2d& from = hull[i];
            const Eigen::Vector2d& to = hull.size() == 1 ? hull[i] : hull[(i + 1) % hull.size()];
            const auto known = std::find_if(stable_edges.begin(), stable_edges.end(),
                                            [&](const auto& e) { return e.first == from && e.second == to; });
            if (known != stable_edges.end()) continue;
            const GainSegment edge = GainSegment::between(from.x(), from.y(), to.x(), to.y());
            ++r.edges;
            const GainRayStability v = segment_verdict(edge);
            if (v.stable) {
                stable_edges.emplace_back(from, to);
                continue;
            }
            failing_from = from;
            failing_to = to;
            r.failing_alpha = edge.alpha(v.failing_scale);
            r.failing_beta = edge.beta(v.failing_scale);
            failed = true;
            failure_decided = v.certified;
            break;
        }
        if (!failed) {
            r.proven = !hull.empty();
            return r;
        }
        if (max_directions == 0 || static_cast<int>(turns.size()) >= max_directions) return r;
        // A decided failure: refine only where the polygon exceeds the range's hull by more than the merge's growth.
        // An undecided one (its edge may be decidable in shorter pieces): at most kNumericalRangeUndecidedRefinements.
        double threshold = 0.0;
        if (failure_decided) {
            const double delta = distance_to_convex_polygon(scaled_polygon_hull(outline.support, s_lo, s_hi),
                                                            Eigen::Vector2d(r.failing_alpha, r.failing_beta));
            if (!(delta > kNumericalRangeMergeRelative * std::hypot(r.failing_alpha, r.failing_beta)) ||
                !std::isfinite(delta))
                return r;
            threshold = delta / (2.0 * s_hi);
        } else if (++undecided > kNumericalRangeUndecidedRefinements) {
            return r;
        }
        // The gaps whose vertices are nearest the failing edge's ends (their scaled copies), if they exceed the
        // threshold; else, for a decided failure, every gap that does.
        std::vector<bool> refine(turns.size(), false);
        bool local = false;
        for (const Eigen::Vector2d& end : {failing_from, failing_to}) {
            std::size_t nearest = 0;
            double d = std::numeric_limits<double>::infinity();
            for (std::size_t j = 0; j < turns.size(); ++j) {
                const double dj =
                    std::min((s_lo * outline.vertices[j] - end).norm(), (s_hi * outline.vertices[j] - end).norm());
                if (dj < d) {
                    d = dj;
                    nearest = j;
                }
            }
            refine[nearest] = outline.excess[nearest] > threshold;
            local = local || refine[nearest];
        }
        if (!local && !failure_decided) return r;
        std::vector<double> finer;
        finer.reserve(2 * turns.size());
        for (std::size_t j = 0; j < turns.size(); ++j) {
            finer.push_back(turns[j]);
            const double next = j + 1 < turns.size() ? turns[j + 1] : turns[0] + 1.0;
            const double mean = 0.5 * (turns[j] + next);
            const bool gap = local ? refine[j] : outline.excess[j] > threshold;
            const auto lines = turns.size() + (finer.size() - j - 1);
            if (gap && static_cast<int>(lines) < max_directions && next - turns[j] >= 2 * kNumericalRangeFinestGap) {
                finer.push_back(mean < 1.0 ? mean : mean - 1.0);
            }
        }
        std::sort(finer.begin(), finer.end());
        if (finer.size() == turns.size()) return r;
        turns = std::move(finer);
        ++r.refinements;
    }
}

/// The certificate of the pair (A, B): the family of that one member.
template <typename SegmentVerdict>
NumericalRangeCertificate certify_by_numerical_range(const Eigen::MatrixXd& A, const Eigen::MatrixXd& B, double s_lo,
                                                     double s_hi, int directions, SegmentVerdict&& segment_verdict,
                                                     int max_directions = 0) {
    return certify_by_numerical_range(std::vector<GainMatrixPair>{GainMatrixPair{A, B}}, s_lo, s_hi, directions,
                                      std::forward<SegmentVerdict>(segment_verdict), max_directions);
}

}  // namespace hapticopt
