// SPDX-License-Identifier: Apache-2.0
// The energy criteria C_E0, C_E1, C_E2 of the unit step response (Hulin et al. 2011, eqs. 4-8),
// in closed form: exact integrals within each period and exact infinite sums over periods.
//
//   E(t) = 1/2 (alpha + gamma) (x(t) - x_inf)^2 + 1/2 x'(t)^2,   E(0) = 1 / (2 (alpha + gamma)),
//   C_Ep = (1 / E(0)) integral_0^inf t^p E(t) dt   (normalised units, T = 1).
//
// Within period j the energy is a quadratic form of the loop state e_j: on segment s (start s0,
// length h), E(j + s0 + tau) = 1/2 xi^T Qe(tau) xi with xi = R_s e_j, so
//   integral over period j of (j + tau)^p E = sum_q C(p,q) j^(p-q) e_j^T W_q e_j,
//   W_q = 1/2 sum_s R_s^T [ sum_r C(q,r) s0^(q-r) Z_r(h) ] R_s      (Z_r: exponential_integrals.hpp).
// The sums over j >= 0 are traces against G_p = sum_j j^p e_j e_j^T, which solve the Stein equations
//   G_0 = M G_0 M^T + e_0 e_0^T,   G_1 = M G_1 M^T + M G_0 M^T,   G_2 = M G_2 M^T + 2 G_1 - M G_0 M^T
// (subtract the shifted sums). They are solved by ShiftSteinSolver (stein_equation.hpp), which uses
// the shift structure of M (two dense rows) to reduce each equation to a (2N - 1)-square linear
// system with one LU shared by the three solves; so the result is exact up to rounding: no
// time-stepping, no truncated horizon, no eigen-decomposition.
//
// Accuracy (measured against the same algorithm in long double and against time-stepping with
// quadrature, tests/core/test_energy_costs.cpp; and against the complex-Schur method,
// detail::energy_costs_complex_schur): relative error <= 1e-10 for spectral radius
// rho <= 0.999, and <= 1e-13 / (1 - rho)^2 closer to the boundary (measured worst: 3% of that
// bound, d = 0 .. 50). Unstable loops (Schur-Cohn), and non-positive or non-finite sums from
// rounding right at the boundary: +infinity.
// Cost: O(N^2) assembly + one LU of size 2N - 1 ((2/3)(2N-1)^3 flops) + O(N^2) per Stein solve;
// for N <= 16 (d <= 13) the loop and solver storage is fixed-capacity (no heap allocation). energy_cost() for one
// index solves only the equations it needs. Measured times: docs/benchmarks.md.
#pragma once

#include <array>
#include <cmath>
#include <limits>

#include "config.hpp"
#include "loop_schur_form.hpp"

namespace hapticopt {

template <typename Scalar>
struct EnergyCostsT {
    Scalar ce0;  ///< eq. 6
    Scalar ce1;  ///< eq. 7
    Scalar ce2;  ///< eq. 8
};
using EnergyCosts = EnergyCostsT<double>;

namespace detail {

/// Real part of tr(W Y) for symmetric W and Hermitian Y.
template <typename Scalar>
Scalar trace_product(const Matrix3<Scalar>& w, const Eigen::Matrix<std::complex<Scalar>, 3, 3>& y) {
    return (w.cwiseProduct(y.real().transpose())).sum();
}

/// The three C_Ep given the loop and its Schur form (the loop must be stable).
template <typename Scalar>
EnergyCostsT<Scalar> energy_costs_from_schur(const SampledPlant<Scalar>& plant, const ClosedLoop<Scalar>& loop,
                                             const LoopSchurForm<Scalar>& schur) {
    using Complex3N = Eigen::Matrix<std::complex<Scalar>, 3, Eigen::Dynamic>;
    using Complex33 = Eigen::Matrix<std::complex<Scalar>, 3, 3>;
    const auto& t = schur.t;
    const auto& u = schur.u;
    const ComplexVector<Scalar> c = u.adjoint() * loop.initial_state.template cast<std::complex<Scalar>>();
    const ComplexMatrix<Scalar> x0 = solve_triangular_stein<Scalar>(t, c * c.adjoint());
    const ComplexMatrix<Scalar> shifted = t * x0 * t.adjoint();
    const ComplexMatrix<Scalar> x1 = solve_triangular_stein<Scalar>(t, shifted);
    const ComplexMatrix<Scalar> x2 = solve_triangular_stein<Scalar>(t, Scalar(2) * x1 - shifted);

    Scalar j0 = 0, j1 = 0, j2 = 0;
    for (int s = 0; s < plant.segment_count(); ++s) {
        const auto& seg = plant.segment(s);
        const Complex3N b = loop.segment_map[static_cast<std::size_t>(s)].template cast<std::complex<Scalar>>() * u;
        const Complex33 y0 = b * x0 * b.adjoint();
        const Complex33 y1 = b * x1 * b.adjoint();
        const Complex33 y2 = b * x2 * b.adjoint();
        std::array<Matrix3<Scalar>, 3> z;  // local-time Gramians of the energy
        for (std::size_t r = 0; r < 3; ++r) {
            z[r] = loop.total_stiffness * seg.position_gramian[r] + seg.velocity_gramian[r];
        }
        const Scalar s0 = seg.start;
        const Matrix3<Scalar> w0 = z[0];
        const Matrix3<Scalar> w1 = z[1] + s0 * z[0];
        const Matrix3<Scalar> w2 = z[2] + Scalar(2) * s0 * z[1] + s0 * s0 * z[0];
        j0 += trace_product(w0, y0);
        j1 += trace_product(w0, y1) + trace_product(w1, y0);
        j2 += trace_product(w0, y2) + Scalar(2) * trace_product(w1, y1) + trace_product(w2, y0);
    }
    // C_Ep = J_p / E(0) with J_p carrying the factor 1/2 of the energy: (1/2) J / (1/(2 k)) = k J.
    const Scalar k = loop.total_stiffness;
    return EnergyCostsT<Scalar>{k * j0, k * j1, k * j2};
}

/// E-weights of segment s for the local-time moments: w_q = sum_r C(q,r) s0^(q-r) Z_r (energy Gramians).
template <typename Scalar>
std::array<Matrix3<Scalar>, 3> segment_weights(const PlantSegment<Scalar>& seg, Scalar total_stiffness) {
    std::array<Matrix3<Scalar>, 3> z;
    for (std::size_t r = 0; r < 3; ++r) {
        z[r] = total_stiffness * seg.position_gramian[r] + seg.velocity_gramian[r];
    }
    const Scalar s0 = seg.start;
    return {z[0], z[1] + s0 * z[0], z[2] + Scalar(2) * s0 * z[1] + s0 * s0 * z[0]};
}

/// C_E0 .. C_E<highest> by the shift-structured Stein solver (stein_equation.hpp); the entries above
/// `highest` are left NaN. The loop must be stable (Schur-Cohn); returns +inf if the solver's pivots
/// or the sums reveal otherwise (rounding right at the boundary).
template <typename Scalar, int MaxN>
EnergyCostsT<Scalar> energy_costs_structured(const SampledPlant<Scalar>& plant, Scalar alpha, Scalar beta,
                                             int highest) {
    const Scalar inf = std::numeric_limits<Scalar>::infinity();
    const Scalar nan = std::numeric_limits<Scalar>::quiet_NaN();
    const auto loop = make_compact_closed_loop<Scalar, MaxN>(plant, alpha, beta);
    const ShiftSteinSolver<Scalar, MaxN> stein(loop.top);
    if (!stein.ok()) return {inf, inf, inf};
    using Square = typename ShiftSteinSolver<Scalar, MaxN>::Square;
    using Matrix3N = Eigen::Matrix<Scalar, 3, Eigen::Dynamic, 0, 3, MaxN>;
    // G_0 = M G_0 M^T + e_0 e_0^T,  G_1 = M G_1 M^T + M G_0 M^T,  G_2 = M G_2 M^T + 2 G_1 - M G_0 M^T.
    std::array<Square, 3> g;
    const int n = loop.state_dimension;
    {
        Square c0(n, n);
        for (int l = 0; l < n; ++l) {
            for (int k = 0; k < n; ++k) c0(k, l) = loop.initial_state(k) * loop.initial_state(l);
        }
        g[0] = stein.solve(c0);
    }
    if (highest >= 1) {
        Square c = stein.propagate(g[0]);
        g[1] = stein.solve(c);
        if (highest >= 2) {
            for (int l = 0; l < n; ++l) {
                for (int k = 0; k < n; ++k) c(k, l) = Scalar(2) * g[1](k, l) - c(k, l);
            }
            g[2] = stein.solve(c);
        }
    }
    std::array<Scalar, 3> j{0, 0, 0};
    for (int s = 0; s < plant.segment_count(); ++s) {
        const auto& r = loop.segment_map[static_cast<std::size_t>(s)];
        const auto w = segment_weights(plant.segment(s), loop.total_stiffness);
        std::array<Matrix3<Scalar>, 3> y;
        for (std::size_t q = 0; q <= static_cast<std::size_t>(highest); ++q) {
            // y_q = R g_q R^T, written out: rg = R g_q (3 x N), then rg R^T.
            Matrix3N rg(3, n);
            for (int l = 0; l < n; ++l) {
                for (int i = 0; i < 3; ++i) {
                    Scalar v = 0;
                    for (int m = 0; m < n; ++m) v += r(i, m) * g[q](m, l);
                    rg(i, l) = v;
                }
            }
            for (int i = 0; i < 3; ++i) {
                for (int k = 0; k < 3; ++k) {
                    Scalar v = 0;
                    for (int l = 0; l < n; ++l) v += rg(i, l) * r(k, l);
                    y[q](i, k) = v;
                }
            }
        }
        auto tr = [](const Matrix3<Scalar>& a, const Matrix3<Scalar>& b) {  // <a, b> = sum_ij a_ij b_ij
            Scalar v = 0;
            for (int k = 0; k < 9; ++k) v += a.data()[k] * b.data()[k];
            return v;
        };
        j[0] += tr(w[0], y[0]);
        if (highest >= 1) j[1] += tr(w[0], y[1]) + tr(w[1], y[0]);
        if (highest >= 2) j[2] += tr(w[0], y[2]) + Scalar(2) * tr(w[1], y[1]) + tr(w[2], y[0]);
    }
    // C_Ep = J_p / E(0) with J_p carrying the factor 1/2 of the energy: (1/2) J / (1/(2 k)) = k J.
    const Scalar k = loop.total_stiffness;
    EnergyCostsT<Scalar> out{nan, nan, nan};
    Scalar* fields[3] = {&out.ce0, &out.ce1, &out.ce2};
    for (int p = 0; p <= highest; ++p) {
        const Scalar c = k * j[static_cast<std::size_t>(p)];
        // Every C_Ep of a stable loop is a positive finite integral; anything else is the rounding of a
        // loop at the stability boundary.
        if (!(c > Scalar(0)) || !std::isfinite(static_cast<double>(c))) return {inf, inf, inf};
        *fields[p] = c;
    }
    return out;
}

template <typename Scalar>
EnergyCostsT<Scalar> energy_costs_up_to(const SampledPlant<Scalar>& plant, Scalar alpha, Scalar beta, int highest) {
    const Scalar inf = std::numeric_limits<Scalar>::infinity();
    if (!loop_is_stable(plant, alpha, beta)) return {inf, inf, inf};
    if (plant.state_dimension() <= kStackStateDimension) {
        return energy_costs_structured<Scalar, kStackStateDimension>(plant, alpha, beta, highest);
    }
    return energy_costs_structured<Scalar, Eigen::Dynamic>(plant, alpha, beta, highest);
}

}  // namespace detail

/// C_E0, C_E1, C_E2 for the precomputed plant and gains (alpha, beta); +infinity when unstable.
template <typename Scalar>
EnergyCostsT<Scalar> energy_costs(const SampledPlant<Scalar>& plant, Scalar alpha, Scalar beta) {
    return detail::energy_costs_up_to(plant, alpha, beta, 2);
}

/// C_E<index> alone (index 0, 1, 2): solves only index + 1 of the three Stein equations.
template <typename Scalar>
Scalar energy_cost(const SampledPlant<Scalar>& plant, Scalar alpha, Scalar beta, int index) {
    const EnergyCostsT<Scalar> c = detail::energy_costs_up_to(plant, alpha, beta, index);
    return index <= 0 ? c.ce0 : index == 1 ? c.ce1 : c.ce2;
}

namespace detail {

/// An independent way to the same costs, for the tests and the benchmarks (not part of the API): the
/// complex Schur form of M and three triangular Stein solves (O(N^3), ~25 N^3 for the Schur form).
template <typename Scalar>
EnergyCostsT<Scalar> energy_costs_complex_schur(const SampledPlant<Scalar>& plant, Scalar alpha, Scalar beta) {
    const Scalar inf = std::numeric_limits<Scalar>::infinity();
    if (!loop_is_stable(plant, alpha, beta)) return {inf, inf, inf};
    const ClosedLoop<Scalar> loop = make_closed_loop(plant, alpha, beta);
    const LoopSchurForm<Scalar> schur = loop_schur_form(loop.transition);
    if (!(schur.spectral_radius < Scalar(1))) return {inf, inf, inf};
    return energy_costs_from_schur(plant, loop, schur);
}

}  // namespace detail

/// Convenience: C_E0..2 at (gamma, delta, d) and (alpha, beta). Throws InvalidParameter for NaN or
/// infinite gains and for invalid plant parameters.
HAPTICOPT_FUNC EnergyCosts energy_costs(const NormalizedPlant& plant, const NormalizedGains& gains)
#if HAPTICOPT_DEFINITIONS
{
    validate(gains, "hapticopt::energy_costs");
    return energy_costs(SampledPlant<double>(plant), gains.alpha, gains.beta);
}
#else
    ;
#endif

}  // namespace hapticopt
