// SPDX-License-Identifier: Apache-2.0
// The Hessian of C_E0..2 with respect to (alpha, beta) for the wall with its velocity estimator, exact up to
// rounding, from the Stein solver of the gradient (estimator_gradient.hpp); it drives the damped Newton search of
// the fast CEx optimum (estimator_optimum.hpp: optimal_point, OptimumMethod::newton; newton_search.hpp).
//
// Equations (theta = (alpha, beta), subscripts i, j = derivatives along theta_i, theta_j). The forward equations
// F(G, theta) = 0 of estimator_gradient.hpp, with P(X) = M X M^T and E = e_0 e_0^T,
//   G_0 = P(G_0) + E,  G_1 = P(G_1) + P(G_0),  G_2 = P(G_2) + 2 G_1 - P(G_0),
// and J_p = sum_q <H_q, G_q> give the Lagrangian
//   Lag(G, L, theta) = sum_q <H_q, G_q> + <L_0, P(G_0) + E - G_0> + <L_1, P(G_1) + P(G_0) - G_1>
//                      + <L_2, P(G_2) + 2 G_1 - P(G_0) - G_2>,
// whose L-derivative is F and whose G-derivative vanishes at the adjoint L_q of estimator_gradient.hpp, so that
// J_p(theta) = Lag(G(theta), L(theta), theta) and dJ_p/dtheta_i = Lag_i (the partial derivative at fixed G, L).
// Lag is linear in G (Lag_GG = 0), and differentiating F(G(theta), theta) = 0 turns the adjoint derivatives'
// term into a state derivatives' one (the second-order adjoint, e.g. A. Griewank, A. Walther, "Evaluating
// Derivatives", 2nd ed., SIAM 2008, ch. 5), so
//   d^2 J_p / dtheta_i dtheta_j = Lag_ij + Lag_iG[G_,j] + Lag_jG[G_,i]
// with only the forward state derivatives G_q,j (p + 1 solves per gain on the factorised solver):
//   G_0,j = S(P_j(G_0) + E_j),  G_1,j = S(P_j(G_1) + P(G_0,j) + P_j(G_0)),
//   G_2,j = S(P_j(G_2) + 2 G_1,j - P(G_0,j) - P_j(G_0))        (S(C): X = M X M^T + C),
//   P_j(X) = M_j X M^T + M X M_j^T,  E_alpha = -2 E / k, E_beta = 0   (e_0 = -u / k, k = alpha + gamma).
// Lag_iG[X] is the gradient's G-linear part at X (detail::estimator_linear_term of estimator_gradient.hpp):
//   Lag_iG[X] = 2 <(L_0 + L_1 - L_2) M X_0 + L_1 M X_1 + L_2 M X_2, M_i>
//               + sum_q C(p, q) sum_s (2 <w R_s X_q, R_s,i> + <w_i, R_s X_q R_s^T>).
// M, R_s and w (w_{r,s} = the segment weights, affine in k) are affine in theta, so their second derivatives
// vanish and
//   Lag_ij = 2 <(L_0 + L_1 - L_2) M_i G_0 + L_1 M_i G_1 + L_2 M_i G_2, M_j> + <L_0, E_ij>
//            + sum_q C(p, q) sum_s 2 (<w R_s,j G_q, R_s,i> + <w_j R_s G_q, R_s,i> + <w_i R_s G_q, R_s,j>),
//   E_alpha,alpha = 6 E / k^2, E_alpha,beta = E_beta,beta = 0;  w_beta = 0, w_alpha = dw/dalpha (the position
//   Gramians' part, energy_gradient.hpp). M_i is zero below its first two rows, so L M_i X needs only L's
//   top-left 2 x 2 block. With C_Ep = k J_p:
//   d^2 C/dalpha^2 = 2 J_alpha + k J_alpha,alpha,  d^2 C/dalpha dbeta = J_beta + k J_alpha,beta,
//   d^2 C/dbeta^2 = k J_beta,beta.
// Cost: the gradient's (one factorisation, p + 1 forward and p + 1 adjoint solves) plus 2 (p + 1) forward solves on
// the same factorisation and O(N^2 + s N) products, against two more gradients (two factorisations, 4 (p + 1)
// solves) for the forward-difference Hessian. Checked against central differences of the gradient and against
// long double in tests/core/test_estimator_hessian.cpp.
#pragma once

#include <array>
#include <cmath>
#include <cstddef>
#include <limits>

#include "energy_costs.hpp"
#include "energy_gradient.hpp"
#include "errors.hpp"
#include "estimator_gradient.hpp"
#include "estimator_types.hpp"

namespace hapticopt {

template <typename Scalar>
struct EnergyCostHessianT {
    Scalar value;          ///< C_Ep(alpha, beta), +inf when unstable
    Scalar d_alpha;        ///< dC_Ep / dalpha (NaN when unstable)
    Scalar d_beta;         ///< dC_Ep / dbeta (NaN when unstable)
    Scalar d_alpha_alpha;  ///< d^2 C_Ep / dalpha^2 (NaN when unstable)
    Scalar d_alpha_beta;   ///< d^2 C_Ep / dalpha dbeta (NaN when unstable)
    Scalar d_beta_beta;    ///< d^2 C_Ep / dbeta^2 (NaN when unstable)
};
using EnergyCostHessian = EnergyCostHessianT<double>;

namespace detail {

/// P_j(X) = dM X M^T + M X dM^T for dM zero below its first two rows: rows 0, 1 of dM X M^T and their transpose
/// in columns 0, 1. O(N^2).
template <typename Scalar>
DynamicMatrix<Scalar> loop_congruence_derivative(const DynamicMatrix<Scalar>& m, const DynamicMatrix<Scalar>& dm,
                                                 const DynamicMatrix<Scalar>& x) {
    const Eigen::Index n = m.rows();
    const Eigen::Matrix<Scalar, 2, Eigen::Dynamic> top = dm.topRows(2).lazyProduct(x);
    const Eigen::Matrix<Scalar, 2, Eigen::Dynamic> y = top.lazyProduct(m.transpose());
    DynamicMatrix<Scalar> out = DynamicMatrix<Scalar>::Zero(n, n);
    out.topRows(2) = y;
    out.leftCols(2) += y.transpose();
    return out;
}

/// The state derivatives G_q,j along one gain (header comment): p + 1 forward solves on `stein`.
template <typename Scalar, typename Solver>
std::array<DynamicMatrix<Scalar>, 3> estimator_state_derivative(const Solver& stein, const ClosedLoop<Scalar>& loop,
                                                                const EstimatorAdjoint<Scalar>& a,
                                                                const DynamicMatrix<Scalar>& dm, bool by_alpha) {
    using Square = DynamicMatrix<Scalar>;
    const Square& m = loop.transition;
    const DynamicVector<Scalar>& e0 = loop.initial_state;
    std::array<Square, 3> x;
    const Square d0 = loop_congruence_derivative(m, dm, a.g[0]);  // P_j(G_0)
    if (by_alpha) {
        x[0] = stein.solve(Square(d0 - (Scalar(2) / loop.total_stiffness) * (e0 * e0.transpose())));
    } else {
        x[0] = stein.solve(d0);
    }
    if (a.p >= 1) {
        const Square shifted = stein.propagate(x[0]);  // P(G_0,j)
        x[1] = stein.solve(Square(loop_congruence_derivative(m, dm, a.g[1]) + shifted + d0));
        if (a.p >= 2) {
            x[2] = stein.solve(Square(loop_congruence_derivative(m, dm, a.g[2]) + Scalar(2) * x[1] - shifted - d0));
        }
    }
    return x;
}

/// <w A, B> = sum_ab w_ab (A B^T)_ba for 3-row A, B: O(N).
template <typename Scalar, typename A, typename B>
Scalar weighted_product(const Matrix3<Scalar>& w, const A& a, const B& b) {
    Scalar v = 0;
    for (int i = 0; i < 3; ++i) {
        for (int k = 0; k < 3; ++k) v += w(i, k) * a.row(k).dot(b.row(i));
    }
    return v;
}

/// The segment terms of dJ_p and of Lag_iG[G_,j], Lag_ij (header comment) from the 3 x N products R_s X_q
/// (X = G, G_,alpha, G_,beta) and R_s,i G_q, each formed once per segment and q: adds to dj[i] (the gradient's
/// through the G's), mixed[i][j] (Lag_iG[G_,j]) and second[i][j] (Lag_ij).
template <typename Scalar>
void estimator_segment_terms(const SampledPlant<Scalar>& plant, const ClosedLoop<Scalar>& loop,
                             const std::array<ClosedLoop<Scalar>, 2>& dloop, const EstimatorAdjoint<Scalar>& a,
                             const std::array<std::array<DynamicMatrix<Scalar>, 3>, 2>& dg, Scalar (&dj)[2],
                             Scalar (&mixed)[2][2], Scalar (&second)[2][2]) {
    using ThreeRows = Eigen::Matrix<Scalar, 3, Eigen::Dynamic>;
    for (int s = 0; s < plant.segment_count(); ++s) {
        const auto si = static_cast<std::size_t>(s);
        const PlantSegment<Scalar>& seg = plant.segment(s);
        const DynamicMatrix<Scalar>& r = loop.segment_map[si];
        const std::array<const DynamicMatrix<Scalar>*, 2> dr{&dloop[0].segment_map[si], &dloop[1].segment_map[si]};
        const Scalar s0 = seg.start;
        const auto& zx = seg.position_gramian;
        const std::array<Matrix3<Scalar>, 3> dw{zx[0], zx[1] + s0 * zx[0],
                                                zx[2] + Scalar(2) * s0 * zx[1] + s0 * s0 * zx[0]};
        for (int q = 0; q <= a.p; ++q) {
            const auto qi = static_cast<std::size_t>(q);
            const auto wi = static_cast<std::size_t>(a.p - q);
            const Matrix3<Scalar>& w = a.weights[si][wi];
            const Scalar c = a.binomial[qi];
            const ThreeRows rg = r * a.g[qi];
            const std::array<ThreeRows, 2> rdg{ThreeRows(r * dg[0][qi]), ThreeRows(r * dg[1][qi])};
            const std::array<ThreeRows, 2> drg{ThreeRows(*dr[0] * a.g[qi]), ThreeRows(*dr[1] * a.g[qi])};
            const Scalar dw_rgr = weighted_product(dw[wi], rg, r);  // <dw, R G R^T>
            for (int i = 0; i < 2; ++i) {
                const auto ii = static_cast<std::size_t>(i);
                // dJ_i: 2 <w R G, R_i> + [alpha] <dw, R G R^T>.
                dj[i] += c * (Scalar(2) * weighted_product(w, rg, *dr[ii]) + (i == 0 ? dw_rgr : Scalar(0)));
                for (int j = 0; j < 2; ++j) {
                    const auto ji = static_cast<std::size_t>(j);
                    // Lag_iG[G_,j]: 2 <w R G_,j, R_i> + [i = alpha] <dw, R G_,j R^T>.
                    Scalar m = Scalar(2) * weighted_product(w, rdg[ji], *dr[ii]);
                    if (i == 0) m += weighted_product(dw[wi], rdg[ji], r);
                    mixed[i][j] += c * m;
                    if (j < i) continue;
                    // Lag_ij: 2 (<w R_j G, R_i> + [j = alpha] <dw R G, R_i> + [i = alpha] <dw R G, R_j>).
                    Scalar t = weighted_product(w, drg[ji], *dr[ii]);
                    if (j == 0) t += weighted_product(dw[wi], rg, *dr[ii]);
                    if (i == 0) t += weighted_product(dw[wi], rg, *dr[ji]);
                    second[i][j] += Scalar(2) * c * t;
                }
            }
        }
    }
}

/// C_E<p>, its gradient and its Hessian for the estimator's loop given a Stein solver of its M and the loop's
/// derivatives along alpha and beta (as detail::estimator_gradient_from_solver). The header comment's equations.
template <typename Scalar, typename Solver>
EnergyCostHessianT<Scalar> estimator_hessian_from_solver(const SampledPlant<Scalar>& plant,
                                                         const ClosedLoop<Scalar>& loop, const Solver& stein,
                                                         const std::array<ClosedLoop<Scalar>, 2>& dloop, int p) {
    using Square = DynamicMatrix<Scalar>;
    using TwoRows = Eigen::Matrix<Scalar, 2, Eigen::Dynamic>;
    const Scalar inf = std::numeric_limits<Scalar>::infinity();
    const Scalar nan = std::numeric_limits<Scalar>::quiet_NaN();
    const EstimatorAdjoint<Scalar> a = estimator_adjoint(plant, loop, stein, p);
    const Scalar k = loop.total_stiffness;
    const Scalar value = k * a.j;
    if (!(value > Scalar(0)) || !std::isfinite(static_cast<double>(value))) return {inf, nan, nan, nan, nan, nan};
    const Square& m = loop.transition;
    const DynamicVector<Scalar>& e0 = loop.initial_state;
    const std::array<std::array<Square, 3>, 2> dg{
        estimator_state_derivative(stein, loop, a, dloop[0].transition, true),
        estimator_state_derivative(stein, loop, a, dloop[1].transition, false)};
    const std::array<TwoRows, 3> through{estimator_through(m, a, a.g), estimator_through(m, a, dg[0]),
                                         estimator_through(m, a, dg[1])};
    std::array<TwoRows, 2> dm;  // rows 0, 1 of M_alpha, M_beta
    for (std::size_t i = 0; i < 2; ++i) dm[i] = dloop[i].transition.topRows(2);
    // The M parts: dJ_i = 2 <through(G), M_i> + [alpha] 2 e_0^T L_0 de_0; Lag_iG[G_,j] = 2 <through(G_,j), M_i>;
    // Lag_ij = 2 <L M_i G, M_j> (L's top-left 2 x 2 blocks) + [alpha, alpha] <L_0, E_alpha,alpha>.
    const Eigen::Matrix<Scalar, 2, 2> first = (a.l[0] + a.l[1] - a.l[2]).template topLeftCorner<2, 2>();
    Scalar dj[2], mixed[2][2], second[2][2];
    for (int i = 0; i < 2; ++i) {
        const auto ii = static_cast<std::size_t>(i);
        dj[i] = Scalar(2) * through[0].cwiseProduct(dm[ii]).sum();
        TwoRows lmg = first * (dm[ii] * a.g[0]);
        if (p >= 1) lmg.noalias() += a.l[1].template topLeftCorner<2, 2>() * (dm[ii] * a.g[1]);
        if (p >= 2) lmg.noalias() += a.l[2].template topLeftCorner<2, 2>() * (dm[ii] * a.g[2]);
        for (int j = 0; j < 2; ++j) {
            const auto ji = static_cast<std::size_t>(j);
            mixed[i][j] = Scalar(2) * through[ji + 1].cwiseProduct(dm[ii]).sum();
            second[i][j] = Scalar(2) * lmg.cwiseProduct(dm[ji]).sum();
        }
    }
    second[0][0] += Scalar(6) * e0.dot(a.l[0] * e0) / (k * k);
    estimator_segment_terms(plant, loop, dloop, a, dg, dj, mixed, second);
    dj[0] += Scalar(2) * e0.dot(a.l[0] * (-e0 / k));  // de_0 / dalpha = -e_0 / k
    Scalar jj[2][2];
    for (int i = 0; i < 2; ++i) {
        for (int j = i; j < 2; ++j) jj[i][j] = second[i][j] + mixed[i][j] + mixed[j][i];
    }
    return {value, a.j + k * dj[0], k * dj[1], Scalar(2) * dj[0] + k * jj[0][0], dj[1] + k * jj[0][1], k * jj[1][1]};
}

}  // namespace detail

/// C_E<index> (0, 1, 2) with the estimator, its gradient and its Hessian with respect to (alpha, beta), exact up
/// to rounding (header comment), on the Stein solver estimator_energy_cost_gradient chooses (`dense` as there).
/// Unstable gains give value +inf and NaN derivatives. Cost: 1.6-1.9 gradients (C_E2 at d = 6, low-pass 0.02 and
/// window 15: BM_EstimatorOptimumParts/k/6/3, docs/benchmarks.md). Throws InvalidParameter for an index outside 0..2.
template <typename Scalar>
EnergyCostHessianT<Scalar> estimator_energy_cost_hessian(const SampledPlant<Scalar>& plant,
                                                         const VelocityEstimator& estimator, Scalar alpha, Scalar beta,
                                                         int index, bool dense = false) {
    detail::require_in_range("hapticopt::estimator_energy_cost_hessian", "index", index, 0, false, 2, "0, 1 or 2");
    const Scalar inf = std::numeric_limits<Scalar>::infinity();
    const Scalar nan = std::numeric_limits<Scalar>::quiet_NaN();
    const EnergyCostHessianT<Scalar> unstable{inf, nan, nan, nan, nan, nan};
    return detail::with_estimator_stein(
        plant, estimator, alpha, beta, dense, unstable,
        [&](const ClosedLoop<Scalar>& loop, const auto& stein, const std::array<ClosedLoop<Scalar>, 2>& dloop) {
            return detail::estimator_hessian_from_solver(plant, loop, stein, dloop, index);
        });
}

}  // namespace hapticopt
