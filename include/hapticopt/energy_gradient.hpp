// SPDX-License-Identifier: Apache-2.0
// The gradient of the energy criteria C_E0, C_E1, C_E2 (Hulin et al. 2011, eqs. 6-8) with respect to the
// wall gains (alpha, beta), exact up to rounding, by the adjoint Stein equation.
//
// Forward (energy_costs.hpp): C_Ep = k J_p, k = alpha + gamma, J_p = sum_{q <= p} <H_q, G_q> with
//   H_q = C(p, q) sum_s R_s^T w_{p-q,s} R_s            (w_{r,s}: segment_weights, R_s: segment maps),
//   G_0 = P(G_0) + e_0 e_0^T,  G_1 = P(G_1) + P(G_0),  G_2 = P(G_2) + 2 G_1 - P(G_0),   P(X) = M X M^T.
// Adjoint: with S*(H) the solution L of L = M^T L M + H (ShiftSteinSolver::adjoint_solve),
//   L_2 = S*(H_2),  L_1 = S*(H_1 + 2 L_2),  L_0 = S*(H_0 + M^T (L_1 - L_2) M)
// (L_q = 0 and H_q = 0 for q > p), so that for a change dM of the loop matrix and de_0 of the initial state
//   dJ_p (through the G's) = 2 <L_2 M G_2 + L_1 M G_1 + (L_0 + L_1 - L_2) M G_0, dM> + 2 e_0^T L_0 de_0.
// The gains enter M (rows 0, 1 only), R_s and e_0 = -(1, 0, 1, ..., 1)/k and w (through k); M and R_s are
// affine in (alpha, beta) (closed_loop.hpp builds them from the force row alpha x + beta (x - x_prev)), so
// their derivatives are the same construction with the force row's derivative and no constant part:
//   dC_Ep/dalpha = J_p + k dJ_p/dalpha,   dC_Ep/dbeta = k dJ_p/dbeta,
//   dJ_p = [through the G's] + sum_q C(p, q) sum_s (2 <w R_s G_q, dR_s> + <dw, R_s G_q R_s^T>).
// A solution exists wherever the cost does (a Schur-stable loop); unstable gains give value +inf and NaN
// derivatives. Checked against central differences of energy_cost() and against long double in
// tests/core/test_energy_gradient.cpp. Cost: the cost's own work (one LU of size 2N - 1, p + 1 solves) plus
// p + 1 adjoint solves (O(N^2) each) and O(N^3) dense products with N = d + 3 states; measured in
// docs/benchmarks.md (BM_EnergyCostGradient).
#pragma once

#include <array>
#include <cmath>
#include <limits>

#include "config.hpp"
#include "energy_costs.hpp"

namespace hapticopt {

template <typename Scalar>
struct EnergyCostGradientT {
    Scalar value;    ///< C_Ep(alpha, beta), +inf when unstable
    Scalar d_alpha;  ///< dC_Ep / dalpha (NaN when unstable)
    Scalar d_beta;   ///< dC_Ep / dbeta (NaN when unstable)
};
using EnergyCostGradient = EnergyCostGradientT<double>;

namespace detail {

/// The derivative of the compact loop's top rows and segment maps along the gains' direction (da, db): the
/// construction of make_compact_closed_loop without its constant part (the loop is affine in the gains).
template <typename Scalar, int MaxN>
struct CompactLoopDerivative {
    Eigen::Matrix<Scalar, 2, Eigen::Dynamic, 0, 2, MaxN> top;
    std::array<Eigen::Matrix<Scalar, 3, Eigen::Dynamic, 0, 3, MaxN>, 2> segment_map;
};

template <typename Scalar, int MaxN>
CompactLoopDerivative<Scalar, MaxN> compact_loop_derivative(const SampledPlant<Scalar>& plant, Scalar da, Scalar db) {
    const int n = plant.state_dimension();
    CompactLoopDerivative<Scalar, MaxN> out;
    using Rows = Eigen::Matrix<Scalar, 2, Eigen::Dynamic, 0, 2, MaxN>;
    Rows rows = Rows::Zero(2, n);
    for (int s = 0; s < plant.segment_count(); ++s) {
        const auto& seg = plant.segment(s);
        auto& r = out.segment_map[static_cast<std::size_t>(s)];
        r.setZero(3, n);
        r.template topRows<2>() = rows;
        r(2, SampledPlant<Scalar>::position_index(seg.force_age)) += da + db;
        r(2, SampledPlant<Scalar>::position_index(seg.force_age + 1)) -= db;
        for (int l = 0; l < n; ++l) {
            for (int i = 0; i < 2; ++i)
                rows(i, l) = seg.exp(i, 0) * r(0, l) + seg.exp(i, 1) * r(1, l) + seg.exp(i, 2) * r(2, l);
        }
    }
    out.top = rows;
    return out;
}

/// One segment's term of dJ / dk (k = alpha or beta) in the adjoint gradient (header comment):
/// sum_q C(p, q) [2 <w_{p-q} R G_q, dR> + [k = alpha] <dw_{p-q} / dalpha, R G_q R^T>], R the segment map, dR its
/// derivative, w its weights (segment_weights) and dw / dalpha = (Z_x0, Z_x1 + s0 Z_x0, Z_x2 + 2 s0 Z_x1 + s0^2 Z_x0)
/// from z_r = k Z_x,r + Z_v,r (Z_x the segment's position Gramians, s0 its start). Shared by the backward loop
/// (R: 3 x N) and the estimator's (R: dense).
template <typename Scalar, typename Map, typename MapDerivative, typename Gramians>
Scalar segment_gradient_term(const PlantSegment<Scalar>& seg, bool by_alpha, const Map& r, const MapDerivative& dr,
                             const std::array<Matrix3<Scalar>, 3>& weights, const Gramians& g,
                             const std::array<Scalar, 3>& binomial, int p) {
    std::array<Matrix3<Scalar>, 3> dw;
    if (by_alpha) {
        const Scalar s0 = seg.start;
        const auto& zx = seg.position_gramian;
        dw = {zx[0], zx[1] + s0 * zx[0], zx[2] + Scalar(2) * s0 * zx[1] + s0 * s0 * zx[0]};
    }
    Scalar v = 0;
    for (int q = 0; q <= p; ++q) {
        const auto qi = static_cast<std::size_t>(q);
        const auto wi = static_cast<std::size_t>(p - q);
        const auto rg = (r * g[qi]).eval();
        Scalar t = Scalar(2) * (weights[wi] * rg).cwiseProduct(dr).sum();
        if (by_alpha) t += dw[wi].cwiseProduct((rg * r.transpose()).eval()).sum();
        v += binomial[qi] * t;
    }
    return v;
}

template <typename Scalar, int MaxN>
EnergyCostGradientT<Scalar> energy_cost_gradient_structured(const SampledPlant<Scalar>& plant, Scalar alpha,
                                                            Scalar beta, int index) {
    const Scalar inf = std::numeric_limits<Scalar>::infinity();
    const Scalar nan = std::numeric_limits<Scalar>::quiet_NaN();
    const EnergyCostGradientT<Scalar> unstable{inf, nan, nan};
    const auto loop = make_compact_closed_loop<Scalar, MaxN>(plant, alpha, beta);
    const ShiftSteinSolver<Scalar, MaxN> stein(loop.top);
    if (!stein.ok()) return unstable;
    using Square = typename ShiftSteinSolver<Scalar, MaxN>::Square;
    using Matrix3N = Eigen::Matrix<Scalar, 3, Eigen::Dynamic, 0, 3, MaxN>;
    const int n = loop.state_dimension;
    const int p = index;
    const std::array<Scalar, 3> binomial_p = p == 0   ? std::array<Scalar, 3>{1, 0, 0}
                                             : p == 1 ? std::array<Scalar, 3>{1, 1, 0}
                                                      : std::array<Scalar, 3>{1, 2, 1};  // C(p, q)
    // Dense M (rows >= 2: the shift rows).
    Square m = Square::Zero(n, n);
    m.topRows(2) = loop.top;
    for (int k = 2; k < n; ++k) m(k, shift_source(k)) = Scalar(1);
    const auto& e0 = loop.initial_state;
    // Forward: the G's.
    std::array<Square, 3> g;
    Square shifted;  // P(G_0)
    g[0] = stein.solve(Square(e0 * e0.transpose()));
    if (p >= 1) {
        shifted = stein.propagate(g[0]);
        g[1] = stein.solve(shifted);
        if (p >= 2) g[2] = stein.solve(Square(Scalar(2) * g[1] - shifted));
    }
    // H_q and the explicit part of J_p.
    std::array<Square, 3> h;
    for (int q = 0; q <= p; ++q) h[static_cast<std::size_t>(q)] = Square::Zero(n, n);
    std::array<std::array<Matrix3<Scalar>, 3>, 2> weights;
    for (int s = 0; s < plant.segment_count(); ++s) {
        const Matrix3N& r = loop.segment_map[static_cast<std::size_t>(s)];
        weights[static_cast<std::size_t>(s)] = segment_weights(plant.segment(s), loop.total_stiffness);
        for (int q = 0; q <= p; ++q) {
            const auto qi = static_cast<std::size_t>(q);
            const Matrix3<Scalar> w =
                binomial_p[qi] * weights[static_cast<std::size_t>(s)][static_cast<std::size_t>(p - q)];
            h[qi].noalias() += r.transpose() * (w * r);
        }
    }
    Scalar j = 0;
    for (int q = 0; q <= p; ++q) j += h[static_cast<std::size_t>(q)].cwiseProduct(g[static_cast<std::size_t>(q)]).sum();
    // Adjoint.
    std::array<Square, 3> l;
    for (auto& x : l) x = Square::Zero(n, n);
    if (p >= 2) l[2] = stein.adjoint_solve(h[2]);
    if (p >= 1) l[1] = stein.adjoint_solve(p >= 2 ? Square(h[1] + Scalar(2) * l[2]) : h[1]);
    {
        const Square d = l[1] - l[2];
        Square rhs = h[0];
        if (p >= 1) rhs.noalias() += m.transpose() * d * m;
        l[0] = stein.adjoint_solve(rhs);
    }
    // 2 <sum L M G, dM>: only rows 0, 1 of dM are non-zero, so only rows 0, 1 of the sum are needed.
    using Top = typename ShiftSteinSolver<Scalar, MaxN>::Top;
    Top through_m = Top::Zero(2, n);
    {
        const Square l0 = l[0] + l[1] - l[2];
        through_m.noalias() += l0.topRows(2) * (m * g[0]);
        if (p >= 1) through_m.noalias() += l[1].topRows(2) * (m * g[1]);
        if (p >= 2) through_m.noalias() += l[2].topRows(2) * (m * g[2]);
    }
    const Scalar k = loop.total_stiffness;
    Scalar dj[2];
    for (int dir = 0; dir < 2; ++dir) {
        const Scalar da = dir == 0 ? Scalar(1) : Scalar(0);
        const Scalar db = dir == 0 ? Scalar(0) : Scalar(1);
        const CompactLoopDerivative<Scalar, MaxN> dl = compact_loop_derivative<Scalar, MaxN>(plant, da, db);
        Scalar v = Scalar(2) * through_m.cwiseProduct(dl.top).sum();
        if (dir == 0) {  // e_0 = -u / k: de_0 / dalpha = -e_0 / k
            v += Scalar(2) * e0.dot(l[0] * (-e0 / k));
        }
        for (int s = 0; s < plant.segment_count(); ++s) {
            const auto si = static_cast<std::size_t>(s);
            v += segment_gradient_term(plant.segment(s), dir == 0, loop.segment_map[si], dl.segment_map[si],
                                       weights[si], g, binomial_p, p);
        }
        dj[dir] = v;
    }
    const Scalar value = k * j;
    if (!(value > Scalar(0)) || !std::isfinite(static_cast<double>(value))) return unstable;
    return {value, j + k * dj[0], k * dj[1]};
}

}  // namespace detail

/// C_E<index> (0, 1, 2) and its gradient with respect to (alpha, beta) for the precomputed plant (header
/// comment: the adjoint Stein equation); value +inf and NaN derivatives when the loop is unstable (Schur-Cohn,
/// as energy_cost). Throws InvalidParameter for an index outside 0..2.
template <typename Scalar>
EnergyCostGradientT<Scalar> energy_cost_gradient(const SampledPlant<Scalar>& plant, Scalar alpha, Scalar beta,
                                                 int index) {
    detail::require_in_range("hapticopt::energy_cost_gradient", "index", index, 0, false, 2, "0, 1 or 2");
    if (!loop_is_stable(plant, alpha, beta)) {
        return {std::numeric_limits<Scalar>::infinity(), std::numeric_limits<Scalar>::quiet_NaN(),
                std::numeric_limits<Scalar>::quiet_NaN()};
    }
    if (plant.state_dimension() <= kStackStateDimension) {
        return detail::energy_cost_gradient_structured<Scalar, kStackStateDimension>(plant, alpha, beta, index);
    }
    return detail::energy_cost_gradient_structured<Scalar, Eigen::Dynamic>(plant, alpha, beta, index);
}

}  // namespace hapticopt
