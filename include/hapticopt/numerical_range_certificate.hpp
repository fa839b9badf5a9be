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
// directions phi_j = 2 pi j / m (m a multiple of 4, so P lies in W's bounding box), e = 64 eps (|A| + |B|) covering the
// eigenvalues' rounding; its vertices are the intersections of consecutive lines. (2) K = conv(s_lo P u s_hi P), which
// holds s P for every s in [s_lo, s_hi] (s w is a convex combination of s_lo w and s_hi w). (3) Every edge of K judged
// as a gain segment (mass_scaling_stability.hpp, GainSegment) over the rest of the plant set by the caller's verdict:
// exact along the segment for one plant (MassScalingTest::segment_over), or certified over an arm box and a delay
// range (ArmBoxTest::segment_over).
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
// Sufficient, not necessary: W is a relaxation (the coupled loop can be stable while a scalar loop of W is not), and P
// exceeds W: each vertex lies within (D / 2) tan(pi / m) of W, D the distance between the support points of its two
// lines (the triangle they form has the apex angle pi - 2 pi / m). A certificate that fails proves nothing
// either way. Tested against the coupled loop's state matrix, built independently, at plants drawn from the set
// (tests/beyond/test_numerical_range_certificate.cpp).
// Cost: m symmetric r x r eigenvalue problems, a hull of 2 m points and at most m + 2 segment verdicts (K's edges: the
// edges of s_lo P facing the origin, those of s_hi P facing away, and two along rays).
// Not for the real-time loop (allocates).
#pragma once

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <utility>
#include <vector>

#include "config.hpp"
#include "errors.hpp"
#include "mass_scaling_stability.hpp"
#include "matrix_gain_stability.hpp"

namespace hapticopt {

/// The outer polygon of the joint numerical range W(A, B) (header comment) from `directions` support lines (a multiple
/// of 4 in [4, 4096]): its vertices (a, b), counter-clockwise. Throws InvalidParameter for A, B not square, of
/// different sizes, not finite, or another number of directions.
HAPTICOPT_FUNC std::vector<Eigen::Vector2d> numerical_range_polygon(const Eigen::MatrixXd& A, const Eigen::MatrixXd& B,
                                                                    int directions)
#if HAPTICOPT_DEFINITIONS
{
    const char* fn = "hapticopt::numerical_range_polygon";
    if (A.rows() == 0 || A.rows() != A.cols() || B.rows() != A.rows() || B.cols() != A.cols()) {
        throw InvalidParameter(fn, "A, B", static_cast<double>(A.rows()), "square matrices of one size >= 1");
    }
    if (!A.allFinite() || !B.allFinite()) throw InvalidParameter(fn, "A, B", 0.0, "finite entries");
    if (directions < 4 || directions > 4096 || directions % 4 != 0) {
        throw InvalidParameter(fn, "directions", directions, "a multiple of 4 in [4, 4096]");
    }
    const Eigen::MatrixXd As = 0.5 * (A + A.transpose()), Bs = 0.5 * (B + B.transpose());
    const double pi = 3.14159265358979323846;
    const double rounding = kMatrixGainRoundingLevel * (As.norm() + Bs.norm());
    std::vector<double> c(static_cast<std::size_t>(directions)), s(c.size()), h(c.size());
    for (int j = 0; j < directions; ++j) {
        const auto i = static_cast<std::size_t>(j);
        // The axis directions exactly (j = 0, m/4, m/2, 3m/4): P then lies in W's bounding box.
        const int quarter = directions / 4;
        if (j % quarter == 0) {
            const int q = j / quarter;
            c[i] = q == 0 ? 1.0 : (q == 2 ? -1.0 : 0.0);
            s[i] = q == 1 ? 1.0 : (q == 3 ? -1.0 : 0.0);
        } else {
            c[i] = std::cos(2 * pi * j / directions);
            s[i] = std::sin(2 * pi * j / directions);
        }
        const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> e(c[i] * As + s[i] * Bs, Eigen::EigenvaluesOnly);
        h[i] = e.eigenvalues().maxCoeff() + rounding;
    }
    std::vector<Eigen::Vector2d> vertices;
    vertices.reserve(c.size());
    for (std::size_t i = 0; i < c.size(); ++i) {
        const std::size_t k = (i + 1) % c.size();
        // c_i a + s_i b = h_i and c_k a + s_k b = h_k (Cramer; the determinant is sin(2 pi / m) > 0).
        const double det = c[i] * s[k] - s[i] * c[k];
        vertices.emplace_back((h[i] * s[k] - s[i] * h[k]) / det, (c[i] * h[k] - c[k] * h[i]) / det);
    }
    return vertices;
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

/// The outcome of certify_by_numerical_range.
struct NumericalRangeCertificate {
    bool proven =
        false;      ///< every edge of K stable over the set: no coupled loop of the family has a root on the circle
    int edges = 0;  ///< edges of K judged (up to the first that failed)
    int directions = 0;                          ///< support lines of the polygon P
    double failing_alpha = 0, failing_beta = 0;  ///< not proven: the gains of K at which the edge's verdict failed
};

/// The certificate of the header comment for symmetric A, B (r x r, normalised for the reference mass; not commuting,
/// else the per-direction verdicts are exact and cheaper) over the scales [s_lo, s_hi] (0 < s_lo <= s_hi), with
/// `directions` support lines. `segment_verdict(const GainSegment&)` returns a GainRayStability (stable, and the
/// segment's u where it fails) for every plant of the rest of the set. Edges are judged longest first, and the first
/// that fails ends the certificate.
template <typename SegmentVerdict>
NumericalRangeCertificate certify_by_numerical_range(const Eigen::MatrixXd& A, const Eigen::MatrixXd& B, double s_lo,
                                                     double s_hi, int directions, SegmentVerdict&& segment_verdict) {
    NumericalRangeCertificate r;
    r.directions = directions;
    const std::vector<Eigen::Vector2d> hull =
        scaled_polygon_hull(numerical_range_polygon(A, B, directions), s_lo, s_hi);
    // The longest edges first: the polygon's excess over the range is largest at their ends, where an unstable gain
    // pair outside the range most often lies, so a certificate that fails most often fails at its first verdicts.
    std::vector<std::size_t> order(hull.size() == 2 ? 1 : hull.size());
    for (std::size_t i = 0; i < order.size(); ++i) order[i] = i;
    auto length = [&](std::size_t i) { return (hull[(i + 1) % hull.size()] - hull[i]).norm(); };
    std::stable_sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) { return length(a) > length(b); });
    for (const std::size_t i : order) {
        const Eigen::Vector2d& from = hull[i];
        const Eigen::Vector2d& to = hull[(i + 1) % hull.size()];
        const GainSegment edge = hull.size() == 1 ? GainSegment::between(from.x(), from.y(), from.x(), from.y())
                                                  : GainSegment::between(from.x(), from.y(), to.x(), to.y());
        ++r.edges;
        const GainRayStability v = segment_verdict(edge);
        if (!v.stable) {
            r.failing_alpha = edge.alpha(v.failing_scale);
            r.failing_beta = edge.beta(v.failing_scale);
            return r;
        }
    }
    r.proven = !hull.empty();
    return r;
}

}  // namespace hapticopt
