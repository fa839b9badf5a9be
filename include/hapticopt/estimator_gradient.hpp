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

/// The forward and adjoint Stein solutions of C_E<p> on the estimator's loop (estimator_energy_cost_gradient's
/// equations): G_q and L_q (zero for q > p), the segments' weights w_{r,s}, C(p, q) and J_p.
template <typename Scalar>
struct EstimatorAdjoint {
    std::array<DynamicMatrix<Scalar>, 3> g, l;
    std::array<std::array<Matrix3<Scalar>, 3>, 2> weights;
    std::array<Scalar, 3> binomial;
    Scalar j;
    int p;
};

/// G_q, L_q and J_p for the estimator's loop `loop` (any structure) given a Stein solver of its M
/// (ShiftSteinSolver, RowShiftSteinSolver or SchurSteinSolver): p + 1 forward and p + 1 adjoint solves.
template <typename Scalar, typename Solver>
EstimatorAdjoint<Scalar> estimator_adjoint(const SampledPlant<Scalar>& plant, const ClosedLoop<Scalar>& loop,
                                           const Solver& stein, int p) {
    using Square = DynamicMatrix<Scalar>;
    const Eigen::Index n = loop.transition.rows();
    const DynamicVector<Scalar>& e0 = loop.initial_state;
    EstimatorAdjoint<Scalar> a;
    a.p = p;
    a.binomial = p == 0   ? std::array<Scalar, 3>{1, 0, 0}
                 : p == 1 ? std::array<Scalar, 3>{1, 1, 0}
                          : std::array<Scalar, 3>{1, 2, 1};  // C(p, q)
    std::array<Square, 3> h;
    for (int q = 0; q < 3; ++q) {
        h[static_cast<std::size_t>(q)] = Square::Zero(n, n);
        a.l[static_cast<std::size_t>(q)] = Square::Zero(n, n);
    }
    a.g[0] = stein.solve(Square(e0 * e0.transpose()));
    if (p >= 1) {
        const Square shifted = stein.propagate(a.g[0]);
        a.g[1] = stein.solve(shifted);
        if (p >= 2) a.g[2] = stein.solve(Square(Scalar(2) * a.g[1] - shifted));
    }
    const Scalar k = loop.total_stiffness;
    for (int s = 0; s < plant.segment_count(); ++s) {
        const auto si = static_cast<std::size_t>(s);
        a.weights[si] = segment_weights(plant.segment(s), k);
        const Square& r = loop.segment_map[si];
        for (int q = 0; q <= p; ++q) {
            const auto qi = static_cast<std::size_t>(q);
            h[qi].noalias() += r.transpose() * (a.binomial[qi] * a.weights[si][static_cast<std::size_t>(p - q)]) * r;
        }
    }
    a.j = 0;
    for (int q = 0; q <= p; ++q)
        a.j += h[static_cast<std::size_t>(q)].cwiseProduct(a.g[static_cast<std::size_t>(q)]).sum();
    if (p >= 2) a.l[2] = stein.adjoint_solve(h[2]);
    if (p >= 1) a.l[1] = stein.adjoint_solve(p >= 2 ? Square(h[1] + Scalar(2) * a.l[2]) : h[1]);
    a.l[0] = stein.adjoint_solve(p >= 1 ? Square(h[0] + stein.transpose_congruence(Square(a.l[1] - a.l[2]))) : h[0]);
    return a;
}

/// The first two rows of (L_0 + L_1 - L_2) M X_0 + L_1 M X_1 + L_2 M X_2 (X = G: the gradient's adjoint product;
/// X = dG: the Hessian's mixed terms, estimator_hessian.hpp). O(N^2) per q.
template <typename Scalar>
Eigen::Matrix<Scalar, 2, Eigen::Dynamic> estimator_through(const DynamicMatrix<Scalar>& m,
                                                           const EstimatorAdjoint<Scalar>& a,
                                                           const std::array<DynamicMatrix<Scalar>, 3>& x) {
    using TwoRows = Eigen::Matrix<Scalar, 2, Eigen::Dynamic>;
    const TwoRows first = (a.l[0] + a.l[1] - a.l[2]).topRows(2);
    TwoRows through = (first * m) * x[0];
    if (a.p >= 1) through.noalias() += (a.l[1].topRows(2) * m) * x[1];
    if (a.p >= 2) through.noalias() += (a.l[2].topRows(2) * m) * x[2];
    return through;
}

/// The part of dJ_p along alpha (`by_alpha`) or beta that is linear in the G's, evaluated at X_q in their place
/// (`through` = estimator_through(M, a, X)):
///   2 <(L_0 + L_1 - L_2) M X_0 + L_1 M X_1 + L_2 M X_2, dM> + sum_q C(p, q) sum_s (2 <w_{p-q,s} R_s X_q, dR_s>
///   + [alpha] <dw_{p-q,s} / dalpha, R_s X_q R_s^T>).
/// `dloop` holds dM and dR_s along that gain. dM is zero below its first two rows (the gains enter only the
/// force row, make_estimator_loop), so only the first two rows of the products are needed.
template <typename Scalar>
Scalar estimator_linear_term(const SampledPlant<Scalar>& plant, const ClosedLoop<Scalar>& loop,
                             const EstimatorAdjoint<Scalar>& a, const std::array<DynamicMatrix<Scalar>, 3>& x,
                             const Eigen::Matrix<Scalar, 2, Eigen::Dynamic>& through, const ClosedLoop<Scalar>& dloop,
                             bool by_alpha) {
    Scalar v = Scalar(2) * through.cwiseProduct(dloop.transition.topRows(2)).sum();
    for (int s = 0; s < plant.segment_count(); ++s) {
        const auto si = static_cast<std::size_t>(s);
        v += segment_gradient_term(plant.segment(s), by_alpha, loop.segment_map[si], dloop.segment_map[si],
                                   a.weights[si], x, a.binomial, a.p);
    }
    return v;
}

/// C_E<p> and its gradient for the estimator's loop `loop` (any structure) given a Stein solver of its M
/// (ShiftSteinSolver or SchurSteinSolver) and the loop's derivatives along alpha and beta (`dloop`: M and R_s
/// only). The equations of estimator_energy_cost_gradient.
template <typename Scalar, typename Solver>
EnergyCostGradientT<Scalar> estimator_gradient_from_solver(const SampledPlant<Scalar>& plant,
                                                           const ClosedLoop<Scalar>& loop, const Solver& stein,
                                                           const std::array<ClosedLoop<Scalar>, 2>& dloop, int p) {
    const Scalar inf = std::numeric_limits<Scalar>::infinity();
    const Scalar nan = std::numeric_limits<Scalar>::quiet_NaN();
    const EstimatorAdjoint<Scalar> a = estimator_adjoint(plant, loop, stein, p);
    const Scalar k = loop.total_stiffness;
    const DynamicVector<Scalar>& e0 = loop.initial_state;
    const Eigen::Matrix<Scalar, 2, Eigen::Dynamic> through = estimator_through(loop.transition, a, a.g);
    Scalar dj[2];
    for (int dir = 0; dir < 2; ++dir) {
        Scalar v = estimator_linear_term(plant, loop, a, a.g, through, dloop[static_cast<std::size_t>(dir)], dir == 0);
        if (dir == 0) v += Scalar(2) * e0.dot(a.l[0] * (-e0 / k));  // e_0 = -u / k: de_0 / dalpha = -e_0 / k
        dj[dir] = v;
    }
    const Scalar value = k * a.j;
    if (!(value > Scalar(0)) || !std::isfinite(static_cast<double>(value))) return {inf, nan, nan};
    return {value, a.j + k * dj[0], k * dj[1]};
}

/// Builds the estimator's loop at (alpha, beta), its derivatives along alpha and beta (M and R_s only) and the
/// Stein solver estimator_energy_cost_gradient describes (ShiftSteinSolver for the window and the backward
/// difference, RowShiftSteinSolver for the low-pass, the complex Schur form with `dense` or within the Schur-Cohn
/// margin 1e-4 of the boundary), and returns f(loop, solver, dloop); `unstable` where the loop is not Schur-stable.
template <typename Scalar, typename Result, typename F>
Result with_estimator_stein(const SampledPlant<Scalar>& plant, const VelocityEstimator& estimator, Scalar alpha,
                            Scalar beta, bool dense, const Result& unstable, F&& f) {
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
                return f(loop, stein, dloop);
            }
            const RowShiftSteinSolver<Scalar> stein(loop.transition);
            if (!stein.ok()) return unstable;
            return f(loop, stein, dloop);
        }
    }
    const LoopSchurForm<Scalar> schur = loop_schur_form(loop.transition);
    if (!(schur.spectral_radius < Scalar(1))) return unstable;
    const SchurSteinSolver<Scalar> stein(loop.transition, schur);
    return f(loop, stein, dloop);
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
    return detail::with_estimator_stein(
        plant, estimator, alpha, beta, dense, unstable,
        [&](const ClosedLoop<Scalar>& loop, const auto& stein, const std::array<ClosedLoop<Scalar>, 2>& dloop) {
            return detail::estimator_gradient_from_solver(plant, loop, stein, dloop, index);
        });
}

}  // namespace hapticopt
