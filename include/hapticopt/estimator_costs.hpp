// SPDX-License-Identifier: Apache-2.0
// The step-response costs C_E0..2 and C_OV of the wall with its velocity estimator (velocity_estimator.hpp,
// the loop of estimator_loop.hpp: its state s_j of N = 2 + Hy + Hv [+ 1] entries).
//
// Energy costs C_E0..2: the same integrals and Stein equations as energy_costs.hpp (E is a quadratic form
// of s_j on each segment; G_p = sum_j j^p s_j s_j^T from three Stein equations). A window is FIR, so its loop
// keeps the shift structure (a longer position history) and ShiftSteinSolver (stein_equation.hpp) solves
// them; the low-pass's loop has one more dense row (v_j) and a second shift chain (the past v's), which
// RowShiftSteinSolver (shift_rows_stein.hpp) solves the same way. Both after Schur-Cohn on p_est; within its
// margin 1e-4 of the boundary, and with `dense` = true, on the complex Schur form of the dense loop matrix
// (detail::energy_costs_from_schur). Exact up to rounding; the error grows like eps / (1 - rho^2) as
// for the backward loop. C_OV: the exact continuous maximum of overshoot.hpp on this loop.
// Costs: N = 2 + Hy + Hv [+ 1] states; the window's energy costs one (2N - 1)-square LU, the low-pass's one
// (3N - 3)-square LU (O(N^3) with a small constant, no eigen-decomposition), C_OV and the dense route
// O(N^3) per evaluation with the complex Schur form (~25 N^3). Measured: docs/benchmarks.md.
#pragma once

#include <array>
#include <cmath>
#include <cstddef>
#include <limits>

#include "characteristic_polynomial.hpp"
#include "config.hpp"
#include "energy_costs.hpp"
#include "estimator_loop.hpp"
#include "estimator_stability.hpp"
#include "loop_schur_form.hpp"
#include "overshoot.hpp"
#include "parameters.hpp"
#include "schur_cohn.hpp"
#include "shift_rows_stein.hpp"
#include "stein_equation.hpp"
#include "estimator_types.hpp"

namespace hapticopt {

namespace detail {

/// C_E0..2 of the loop `loop` given a factorised Stein solver of its M (ShiftSteinSolver, stein_equation.hpp, or
/// RowShiftSteinSolver, shift_rows_stein.hpp; only valid when ok()): the three Stein equations
/// G_0 = M G_0 M^T + s_0 s_0^T, G_1 = M G_1 M^T + M G_0 M^T, G_2 = M G_2 M^T + 2 G_1 - M G_0 M^T on the one
/// factorisation, the traces as in energy_costs_structured. +inf if a cost is not positive and finite (rounding
/// at the boundary).
template <typename Scalar, typename Solver>
EnergyCostsT<Scalar> energy_costs_from_stein_solver(const SampledPlant<Scalar>& plant, const ClosedLoop<Scalar>& loop,
                                                    const Solver& stein) {
    const Scalar inf = std::numeric_limits<Scalar>::infinity();
    using Square = typename Solver::Square;
    std::array<Square, 3> g;
    g[0] = stein.solve(Square(loop.initial_state * loop.initial_state.transpose()));
    Square c = stein.propagate(g[0]);  // G_1 = M G_1 M^T + M G_0 M^T, G_2 = M G_2 M^T + 2 G_1 - M G_0 M^T
    g[1] = stein.solve(c);
    g[2] = stein.solve(Square(Scalar(2) * g[1] - c));
    std::array<Scalar, 3> j{0, 0, 0};
    for (int s = 0; s < plant.segment_count(); ++s) {
        const DynamicMatrix<Scalar>& r = loop.segment_map[static_cast<std::size_t>(s)];
        const auto w = segment_weights(plant.segment(s), loop.total_stiffness);
        std::array<Matrix3<Scalar>, 3> y;
        for (std::size_t q = 0; q < 3; ++q) y[q] = r * g[q] * r.transpose();
        auto tr = [](const Matrix3<Scalar>& a, const Matrix3<Scalar>& b) { return a.cwiseProduct(b).sum(); };
        j[0] += tr(w[0], y[0]);
        j[1] += tr(w[0], y[1]) + tr(w[1], y[0]);
        j[2] += tr(w[0], y[2]) + Scalar(2) * tr(w[1], y[1]) + tr(w[2], y[0]);
    }
    const Scalar k = loop.total_stiffness;  // C_Ep = k J_p (energy_costs_structured)
    const EnergyCostsT<Scalar> out{k * j[0], k * j[1], k * j[2]};
    for (Scalar v : {out.ce0, out.ce1, out.ce2}) {
        if (!(v > Scalar(0)) || !std::isfinite(static_cast<double>(v))) return {inf, inf, inf};
    }
    return out;
}

/// C_E0..2 of a loop whose rows >= 2 are the shift rows of closed_loop.hpp (an FIR estimator without the
/// noise state: its state is the plant's plus a longer position history): energy_costs_from_stein_solver with
/// ShiftSteinSolver (one (2N - 1)-square LU). +inf if a pivot vanishes.
template <typename Scalar>
EnergyCostsT<Scalar> shift_structured_energy_costs(const SampledPlant<Scalar>& plant, const ClosedLoop<Scalar>& loop) {
    const Scalar inf = std::numeric_limits<Scalar>::infinity();
    using Solver = ShiftSteinSolver<Scalar, Eigen::Dynamic>;
    const Solver stein(typename Solver::Top(loop.transition.topRows(2)));
    if (!stein.ok()) return {inf, inf, inf};
    return energy_costs_from_stein_solver(plant, loop, stein);
}

/// C_E0..2 of the estimator's loop `loop` (make_estimator_loop) at gains whose p_est Schur-Cohn has already found
/// stable outside its margin kStabilityRefinementMargin: the window through shift_structured_energy_costs, the
/// low-pass through RowShiftSteinSolver (one LU each, no verdict of its own). +inf if a pivot vanishes.
template <typename Scalar>
EnergyCostsT<Scalar> structured_estimator_energy_costs(const SampledPlant<Scalar>& plant,
                                                       const VelocityEstimator& estimator,
                                                       const ClosedLoop<Scalar>& loop) {
    if (estimator.kind != VelocityEstimatorKind::lowpass) return shift_structured_energy_costs(plant, loop);
    const Scalar inf = std::numeric_limits<Scalar>::infinity();
    const RowShiftSteinSolver<Scalar> stein(loop.transition);
    if (!stein.ok()) return {inf, inf, inf};
    return energy_costs_from_stein_solver(plant, loop, stein);
}

}  // namespace detail

/// C_E0..2 with the estimator for a precomputed plant, +inf when unstable (M's spectral radius >= 1, or the
/// solver's pivots). Every kind, including the backward difference, goes through the estimator's loop here
/// (energy_costs() with an estimator sends the backward difference to the fast backward path instead):
/// the window through ShiftSteinSolver, the low-pass through RowShiftSteinSolver (header comment); `dense` = true
/// forces the complex-Schur method instead, for the cross-check in the tests.
template <typename Scalar>
EnergyCostsT<Scalar> estimator_energy_costs(const SampledPlant<Scalar>& plant, const VelocityEstimator& estimator,
                                            Scalar alpha, Scalar beta, bool dense = false) {
    const Scalar inf = std::numeric_limits<Scalar>::infinity();
    if (!(alpha + Scalar(plant.parameters().gamma) > Scalar(0))) return {inf, inf, inf};
    const EstimatorLoop<Scalar> el = make_estimator_loop(plant, estimator, alpha, beta, false);
    if (!dense) {
        // The structured solvers do not see instability by themselves: Schur-Cohn on p_est first; near the
        // boundary (|margin| < 1e-4) the complex-Schur path below decides by the spectral radius.
        const SchurCohnResult<Scalar> sc = schur_cohn<Scalar>(
            estimator_characteristic_polynomial(characteristic_polynomial(plant), estimator).at(alpha, beta));
        using std::abs;
        if (abs(sc.margin) >= Scalar(kStabilityRefinementMargin)) {
            if (!sc.stable) return {inf, inf, inf};
            return detail::structured_estimator_energy_costs(plant, estimator, el.loop);
        }
    }
    const LoopSchurForm<Scalar> schur = loop_schur_form(el.loop.transition);
    if (!(schur.spectral_radius < Scalar(1))) return {inf, inf, inf};
    const EnergyCostsT<Scalar> c = detail::energy_costs_from_schur(plant, el.loop, schur);
    for (Scalar v : {c.ce0, c.ce1, c.ce2}) {
        if (!(v > Scalar(0)) || !std::isfinite(static_cast<double>(v))) return {inf, inf, inf};
    }
    return c;
}

/// C_OV (eq. 9) with the estimator: the exact continuous-time maximum of overshoot.hpp
/// (detail::continuous_maximum: in-period maxima by Newton on the Taylor series, stop proven by the bound
/// |x(t) - x_inf| <= kappa sqrt(s_j^T P s_j)) on the estimator's loop, with P = M^T P M + I solved on the
/// complex Schur form of M^T. +inf when unstable. options.stop_above is not used: the value is always the whole
/// maximum (stopped_above stays false). Throws InvalidParameter for a tolerance outside (0, 1].
template <typename Scalar>
OvershootResultT<Scalar> estimator_overshoot(const SampledPlant<Scalar>& plant, const VelocityEstimator& estimator,
                                             Scalar alpha, Scalar beta, const OvershootOptions& options = {}) {
    detail::require_in_range("hapticopt::estimator_overshoot", "tolerance", options.tolerance, 0.0, true, 1.0,
                             "0 < tolerance <= 1");
    OvershootResultT<Scalar> result;
    result.time = std::numeric_limits<Scalar>::quiet_NaN();
    result.value = std::numeric_limits<Scalar>::infinity();
    if (!(alpha + Scalar(plant.parameters().gamma) > Scalar(0))) return result;
    const EstimatorLoop<Scalar> el = make_estimator_loop(plant, estimator, alpha, beta, false);
    const ClosedLoop<Scalar>& loop = el.loop;
    const LoopSchurForm<Scalar> schur = loop_schur_form(DynamicMatrix<Scalar>(loop.transition.transpose()));
    if (!(schur.spectral_radius < Scalar(1))) return result;
    const Eigen::Index n = loop.transition.rows();
    const ComplexMatrix<Scalar> x =
        solve_triangular_stein<Scalar>(schur.t, ComplexMatrix<Scalar>::Identity(n, n));  // U^H I U = I
    DynamicMatrix<Scalar> p = (schur.u * x * schur.u.adjoint()).real();
    p = (p + p.transpose()) / Scalar(2);
    for (Eigen::Index k = 0; k < n; ++k) {  // P >= I for a Schur-stable M; else rounding at the boundary
        if (!(p(k, k) >= Scalar(1) - Scalar(1e-9)) || !std::isfinite(static_cast<double>(p(k, k)))) return result;
    }
    const Scalar x_inf = loop.final_position;
    const detail::ContinuousMaximum<Scalar> scan =
        detail::continuous_maximum(plant, loop, p, -x_inf, Scalar(options.tolerance) * x_inf, options.max_periods);
    result.periods = scan.periods;
    result.converged = scan.converged;
    result.value = scan.value > 0 ? scan.value / x_inf : Scalar(0);
    if (result.value > 0) result.time = scan.time;
    result.within_tolerance = result.converged && result.value <= Scalar(options.tolerance);
    return result;
}

/// C_OV with the estimator for a normalised plant; the backward difference is overshoot(plant, gains).
HAPTICOPT_FUNC OvershootResult overshoot(const NormalizedPlant& plant, const NormalizedGains& gains,
                                         const VelocityEstimator& estimator, const OvershootOptions& options = {})
#if HAPTICOPT_DEFINITIONS
{
    validate(gains, "hapticopt::overshoot");
    validate(estimator, "hapticopt::overshoot");
    if (estimator.kind == VelocityEstimatorKind::backward) return overshoot(plant, gains, options);
    if (!EstimatorStabilityTest(plant, estimator).stable(gains.alpha, gains.beta)) {
        detail::require_in_range("hapticopt::overshoot", "tolerance", options.tolerance, 0.0, true, 1.0,
                                 "0 < tolerance <= 1");
        OvershootResult r;
        r.value = HUGE_VAL;
        r.time = std::nan("");
        return r;
    }
    return estimator_overshoot(SampledPlant<double>(plant), estimator, gains.alpha, gains.beta, options);
}
#else
    ;
#endif

/// C_E0..2 with the estimator; +inf when unstable. The backward difference is energy_costs(plant, gains).
HAPTICOPT_FUNC EnergyCosts energy_costs(const NormalizedPlant& plant, const NormalizedGains& gains,
                                        const VelocityEstimator& estimator)
#if HAPTICOPT_DEFINITIONS
{
    validate(gains, "hapticopt::energy_costs");
    validate(estimator, "hapticopt::energy_costs");
    if (estimator.kind == VelocityEstimatorKind::backward) return energy_costs(plant, gains);
    const EstimatorStabilityTest test(plant, estimator);
    if (!test.stable(gains.alpha, gains.beta)) return {HUGE_VAL, HUGE_VAL, HUGE_VAL};
    return estimator_energy_costs(SampledPlant<double>(plant), estimator, gains.alpha, gains.beta);
}
#else
    ;
#endif

}  // namespace hapticopt
