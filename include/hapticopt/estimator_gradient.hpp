// SPDX-License-Identifier: Apache-2.0
// The gradient of C_E0..2 with respect to (alpha, beta) for the wall with its velocity estimator
// (velocity_estimator.hpp, the loop of estimator_loop.hpp, the costs of estimator_costs.hpp).
//
// Gradient of C_E0..2 (estimator_energy_cost_gradient): the adjoint Stein equation of energy_gradient.hpp on this
// loop (M and R_s are affine in alpha and beta); it drives the fast CEx optimum (estimator_optimum.hpp:
// optimal_point, OptimumMethod::newton).
#pragma once

#include <array>
#include <cmath>
#include <complex>
#include <cstddef>
#include <limits>

#include "characteristic_polynomial.hpp"
#include "energy_costs.hpp"
#include "energy_gradient.hpp"
#include "errors.hpp"
#include "estimator_loop.hpp"
#include "estimator_stability.hpp"
#include "loop_schur_form.hpp"
#include "schur_cohn.hpp"
#include "shift_rows_stein.hpp"
#include "stein_equation.hpp"
#include "estimator_types.hpp"

namespace hapticopt {

namespace detail {

/// X = M X M^T + C and the adjoint L = M^T L M + H (real symmetric right-hand sides) for any Schur-stable loop
/// matrix, on its complex Schur form M = U T U^H: U^H X U solves the triangular equation of stein_equation.hpp,
/// and Y = U^H L U solves Y = T^H Y T + U^H H U, which the exchange J turns into that form:
/// J Y J = (J T^H J)(J Y J)(J T^H J)^H + J U^H H U J with J T^H J upper triangular. O(N^3) per solve.
template <typename Scalar>
class SchurSteinSolver {
  public:
    using Square = DynamicMatrix<Scalar>;
    SchurSteinSolver(const DynamicMatrix<Scalar>& m, const LoopSchurForm<Scalar>& schur)
        : m_(m), schur_(schur), flipped_(flip<Scalar>(ComplexMatrix<Scalar>(schur.t.adjoint()))) {}

    Square solve(const Square& c) const { return back(solve_triangular_stein<Scalar>(schur_.t, to_schur(c))); }
    Square adjoint_solve(const Square& h) const {
        return back(flip<Scalar>(solve_triangular_stein<Scalar>(flipped_, flip<Scalar>(to_schur(h)))));
    }
    Square propagate(const Square& x) const { return m_ * x * m_.transpose(); }
    Square transpose_congruence(const Square& x) const { return m_.transpose() * x * m_; }

  private:
    ComplexMatrix<Scalar> to_schur(const Square& c) const {
        return schur_.u.adjoint() * c.template cast<std::complex<Scalar>>() * schur_.u;
    }
    Square back(const ComplexMatrix<Scalar>& x) const {
        const Square r = (schur_.u * x * schur_.u.adjoint()).real();
        return (r + r.transpose()) / Scalar(2);
    }
    const DynamicMatrix<Scalar>& m_;
    const LoopSchurForm<Scalar>& schur_;
    ComplexMatrix<Scalar> flipped_;
};

/// C_E<p> and its gradient for the estimator's loop `loop` (any structure) given a Stein solver of its M
/// (ShiftSteinSolver or SchurSteinSolver) and the loop's derivatives along alpha and beta (`dloop`: M and R_s
/// only). The equations of estimator_energy_cost_gradient.
template <typename Scalar, typename Solver>
EnergyCostGradientT<Scalar> estimator_gradient_from_solver(const SampledPlant<Scalar>& plant,
                                                           const ClosedLoop<Scalar>& loop, const Solver& stein,
                                                           const std::array<ClosedLoop<Scalar>, 2>& dloop, int p) {
    using Square = DynamicMatrix<Scalar>;
    const Scalar inf = std::numeric_limits<Scalar>::infinity();
    const Scalar nan = std::numeric_limits<Scalar>::quiet_NaN();
    const Square& m = loop.transition;
    const Eigen::Index n = m.rows();
    const DynamicVector<Scalar>& e0 = loop.initial_state;
    const std::array<Scalar, 3> binomial = p == 0   ? std::array<Scalar, 3>{1, 0, 0}
                                           : p == 1 ? std::array<Scalar, 3>{1, 1, 0}
                                                    : std::array<Scalar, 3>{1, 2, 1};  // C(p, q)
    std::array<Square, 3> g, h, l;
    for (int q = 0; q < 3; ++q) {
        h[static_cast<std::size_t>(q)] = Square::Zero(n, n);
        l[static_cast<std::size_t>(q)] = Square::Zero(n, n);
    }
    g[0] = stein.solve(Square(e0 * e0.transpose()));
    if (p >= 1) {
        const Square shifted = stein.propagate(g[0]);
        g[1] = stein.solve(shifted);
        if (p >= 2) g[2] = stein.solve(Square(Scalar(2) * g[1] - shifted));
    }
    const Scalar k = loop.total_stiffness;
    std::array<std::array<Matrix3<Scalar>, 3>, 2> weights;
    for (int s = 0; s < plant.segment_count(); ++s) {
        const auto si = static_cast<std::size_t>(s);
        weights[si] = segment_weights(plant.segment(s), k);
        const Square& r = loop.segment_map[si];
        for (int q = 0; q <= p; ++q) {
            const auto qi = static_cast<std::size_t>(q);
            h[qi].noalias() += r.transpose() * (binomial[qi] * weights[si][static_cast<std::size_t>(p - q)]) * r;
        }
    }
    Scalar j = 0;
    for (int q = 0; q <= p; ++q) j += h[static_cast<std::size_t>(q)].cwiseProduct(g[static_cast<std::size_t>(q)]).sum();
    if (p >= 2) l[2] = stein.adjoint_solve(h[2]);
    if (p >= 1) l[1] = stein.adjoint_solve(p >= 2 ? Square(h[1] + Scalar(2) * l[2]) : h[1]);
    l[0] = stein.adjoint_solve(p >= 1 ? Square(h[0] + stein.transpose_congruence(Square(l[1] - l[2]))) : h[0]);
    // dM is zero below its first two rows (the gains enter only the force row, make_estimator_loop), so only
    // the first two rows of (L_0 + L_1 - L_2) M G_0 + L_1 M G_1 + L_2 M G_2 are needed: O(N^2) products.
    using TwoRows = Eigen::Matrix<Scalar, 2, Eigen::Dynamic>;
    const TwoRows first = (l[0] + l[1] - l[2]).topRows(2);
    TwoRows through = (first * m) * g[0];
    if (p >= 1) through.noalias() += (l[1].topRows(2) * m) * g[1];
    if (p >= 2) through.noalias() += (l[2].topRows(2) * m) * g[2];
    Scalar dj[2];
    for (int dir = 0; dir < 2; ++dir) {
        const ClosedLoop<Scalar>& dl = dloop[static_cast<std::size_t>(dir)];
        Scalar v = Scalar(2) * through.cwiseProduct(dl.transition.topRows(2)).sum();
        if (dir == 0) v += Scalar(2) * e0.dot(l[0] * (-e0 / k));  // e_0 = -u / k: de_0 / dalpha = -e_0 / k
        for (int s = 0; s < plant.segment_count(); ++s) {
            const auto si = static_cast<std::size_t>(s);
            v += segment_gradient_term(plant.segment(s), dir == 0, loop.segment_map[si], dl.segment_map[si],
                                       weights[si], g, binomial, p);
        }
        dj[dir] = v;
    }
    const Scalar value = k * j;
    if (!(value > Scalar(0)) || !std::isfinite(static_cast<double>(value))) return {inf, nan, nan};
    return {value, j + k * dj[0], k * dj[1]};
}

}  // namespace detail

/// C_E<index> (0, 1, 2) with the estimator and its gradient with respect to (alpha, beta), exact up to rounding,
/// by the adjoint Stein equation of energy_gradient.hpp applied to the estimator's loop (header comment). With
/// the loop matrix M, the segment maps R_s and e_0 = -x_inf (1, 0, 1, .., 1, 0, .., 0) of make_estimator_loop:
///   C_Ep = k J_p,  J_p = sum_{q <= p} <H_q, G_q>,  H_q = C(p, q) sum_s R_s^T w_{p-q,s} R_s,
///   G_0 = M G_0 M^T + e_0 e_0^T,  G_1 = M G_1 M^T + M G_0 M^T,  G_2 = M G_2 M^T + 2 G_1 - M G_0 M^T,
///   L_2 = S*(H_2),  L_1 = S*(H_1 + 2 L_2),  L_0 = S*(H_0 + M^T (L_1 - L_2) M)   (S*(H): L = M^T L M + H;
///   L_q = 0 for q > p),
///   dJ_p = 2 <(L_0 + L_1 - L_2) M G_0 + L_1 M G_1 + L_2 M G_2, dM> + 2 e_0^T L_0 de_0
///          + sum_q C(p, q) sum_s (2 <w_{p-q,s} R_s G_q, dR_s> + <dw_{p-q,s}, R_s G_q R_s^T>),
///   dC_Ep/dalpha = J_p + k dJ_p/dalpha,  dC_Ep/dbeta = k dJ_p/dbeta   (k = alpha + gamma).
/// The gains enter only the force row alpha y + beta v of every segment, so M and R_s are affine in
/// (alpha, beta) and dM, dR_s along alpha or beta are the same construction without its constant part
/// (make_estimator_loop with `derivative`); de_0/dalpha = -e_0 / k; dw/dalpha = the position Gramians' part of w
/// (dw/dbeta = 0). The Stein equations are solved as estimator_energy_costs solves them: the window by
/// ShiftSteinSolver, the low-pass by RowShiftSteinSolver (shift_rows_stein.hpp; their adjoint_solve gives S*, on
/// the same LU as the forward solves), and with `dense` = true or within the Schur-Cohn margin 1e-4 of the
/// boundary on the complex Schur form (detail::SchurSteinSolver). A solution
/// exists wherever the cost does (a Schur-stable loop); unstable gains give value +inf and NaN derivatives.
/// Checked against central differences of estimator_energy_costs in long double
/// (tests/core/test_estimator_fast_optimum.cpp). Cost: about twice the costs' own evaluation (one LU, p + 1 forward
/// and p + 1 adjoint solves, O(N^3) products with small constants). Throws InvalidParameter for an index outside 0..2.
template <typename Scalar>
EnergyCostGradientT<Scalar> estimator_energy_cost_gradient(const SampledPlant<Scalar>& plant,
                                                           const VelocityEstimator& estimator, Scalar alpha,
                                                           Scalar beta, int index, bool dense = false) {
    detail::require_in_range("hapticopt::estimator_energy_cost_gradient", "index", index, 0, false, 2, "0, 1 or 2");
    const Scalar inf = std::numeric_limits<Scalar>::infinity();
    const Scalar nan = std::numeric_limits<Scalar>::quiet_NaN();
    const EnergyCostGradientT<Scalar> unstable{inf, nan, nan};
    if (!(alpha + Scalar(plant.parameters().gamma) > Scalar(0))) return unstable;
    const ClosedLoop<Scalar> loop = make_estimator_loop(plant, estimator, alpha, beta, false).loop;
    const std::array<ClosedLoop<Scalar>, 2> dloop{
        make_estimator_loop(plant, estimator, Scalar(1), Scalar(0), false, true).loop,
        make_estimator_loop(plant, estimator, Scalar(0), Scalar(1), false, true).loop};
    if (!dense) {
        const SchurCohnResult<Scalar> sc = schur_cohn<Scalar>(
            estimator_characteristic_polynomial(characteristic_polynomial(plant), estimator).at(alpha, beta));
        using std::abs;
        if (abs(sc.margin) >= Scalar(kStabilityRefinementMargin)) {
            if (!sc.stable) return unstable;
            if (estimator.kind != VelocityEstimatorKind::lowpass) {
                using Solver = ShiftSteinSolver<Scalar, Eigen::Dynamic>;
                const Solver stein(typename Solver::Top(loop.transition.topRows(2)));
                if (!stein.ok()) return unstable;
                return detail::estimator_gradient_from_solver(plant, loop, stein, dloop, index);
            }
            const RowShiftSteinSolver<Scalar> stein(loop.transition);
            if (!stein.ok()) return unstable;
            return detail::estimator_gradient_from_solver(plant, loop, stein, dloop, index);
        }
    }
    const LoopSchurForm<Scalar> schur = loop_schur_form(loop.transition);
    if (!(schur.spectral_radius < Scalar(1))) return unstable;
    const detail::SchurSteinSolver<Scalar> stein(loop.transition, schur);
    return detail::estimator_gradient_from_solver(plant, loop, stein, dloop, index);
}

}  // namespace hapticopt
