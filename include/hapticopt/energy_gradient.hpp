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

/// The products of the gradient below, written out as loops over Eigen storage (each sum in index order): the
/// same arithmetic as Eigen's product expressions up to the order of the additions, at a fraction of their
/// compile time (Eigen's product kernels, instantiated per operand type and per storage variant, made most of
/// the README example's compile time; docs/building.md, "Compile time of the library").
/// out = a b.
template <typename Out, typename A, typename B>
void multiply_into(Out& out, const A& a, const B& b) {
    const Eigen::Index rows = a.rows(), cols = b.cols(), depth = a.cols();
    out.resize(rows, cols);
    for (Eigen::Index l = 0; l < cols; ++l) {
        for (Eigen::Index i = 0; i < rows; ++i) {
            typename Out::Scalar v = 0;
            for (Eigen::Index k = 0; k < depth; ++k) v += a(i, k) * b(k, l);
            out(i, l) = v;
        }
    }
}

/// out += a^T b.
template <typename Out, typename A, typename B>
void add_transposed_product(Out& out, const A& a, const B& b) {
    const Eigen::Index rows = a.cols(), cols = b.cols(), depth = a.rows();
    for (Eigen::Index l = 0; l < cols; ++l) {
        for (Eigen::Index i = 0; i < rows; ++i) {
            typename Out::Scalar v = 0;
            for (Eigen::Index k = 0; k < depth; ++k) v += a(k, i) * b(k, l);
            out(i, l) += v;
        }
    }
}

/// <a, b> = sum_ij a_ij b_ij.
template <typename Scalar, typename A, typename B>
Scalar frobenius_product(const A& a, const B& b) {
    Scalar v = 0;
    for (Eigen::Index l = 0; l < a.cols(); ++l) {
        for (Eigen::Index i = 0; i < a.rows(); ++i) v += a(i, l) * b(i, l);
    }
    return v;
}

/// One segment's term of dJ / dk (k = alpha or beta) in the adjoint gradient (header comment):
/// sum_q C(p, q) [2 <w_{p-q} R G_q, dR> + [k = alpha] <dw_{p-q} / dalpha, R G_q R^T>], R the segment map, dR its
/// derivative, w its weights (segment_weights) and dw / dalpha = (Z_x0, Z_x1 + s0 Z_x0, Z_x2 + 2 s0 Z_x1 + s0^2 Z_x0)
/// from z_r = k Z_x,r + Z_v,r (Z_x the segment's position Gramians, s0 its start). Shared by the backward loop
/// (R: 3 x N) and the estimator's (R: dense storage, 3 rows).
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
    using Gramian = typename Gramians::value_type;
    Eigen::Matrix<Scalar, 3, Eigen::Dynamic, 0, 3, Gramian::MaxColsAtCompileTime> rg;
    Matrix3<Scalar> rgr;
    const Eigen::Index n = r.cols();
    Scalar v = 0;
    for (int q = 0; q <= p; ++q) {
        const auto qi = static_cast<std::size_t>(q);
        const Matrix3<Scalar>& w = weights[static_cast<std::size_t>(p - q)];
        multiply_into(rg, r, g[qi]);  // R G_q (R has 3 rows)
        Scalar t = 0;                 // <w R G_q, dR>
        for (Eigen::Index l = 0; l < n; ++l) {
            for (int i = 0; i < 3; ++i) t += (w(i, 0) * rg(0, l) + w(i, 1) * rg(1, l) + w(i, 2) * rg(2, l)) * dr(i, l);
        }
        t *= Scalar(2);
        if (by_alpha) {
            for (int k = 0; k < 3; ++k) {  // R G_q R^T
                for (int i = 0; i < 3; ++i) {
                    Scalar y = 0;
                    for (Eigen::Index l = 0; l < n; ++l) y += rg(i, l) * r(k, l);
                    rgr(i, k) = y;
                }
            }
            t += frobenius_product<Scalar>(dw[static_cast<std::size_t>(p - q)], rgr);
        }
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
    for (int l = 0; l < n; ++l) {
        m(0, l) = loop.top(0, l);
        m(1, l) = loop.top(1, l);
    }
    for (int k = 2; k < n; ++k) m(k, shift_source(k)) = Scalar(1);
    const auto& e0 = loop.initial_state;
    // Forward: the G's.
    std::array<Square, 3> g;
    Square shifted;  // P(G_0)
    {
        Square c(n, n);  // e_0 e_0^T
        for (int l = 0; l < n; ++l) {
            for (int k = 0; k < n; ++k) c(k, l) = e0(k) * e0(l);
        }
        g[0] = stein.solve(c);
    }
    if (p >= 1) {
        shifted = stein.propagate(g[0]);
        g[1] = stein.solve(shifted);
        if (p >= 2) {
            Square c(n, n);  // 2 G_1 - P(G_0)
            for (int l = 0; l < n; ++l) {
                for (int k = 0; k < n; ++k) c(k, l) = Scalar(2) * g[1](k, l) - shifted(k, l);
            }
            g[2] = stein.solve(c);
        }
    }
    // H_q and the explicit part of J_p.
    std::array<Square, 3> h;
    for (int q = 0; q <= p; ++q) h[static_cast<std::size_t>(q)] = Square::Zero(n, n);
    std::array<std::array<Matrix3<Scalar>, 3>, 2> weights;
    Matrix3N wr(3, n);
    for (int s = 0; s < plant.segment_count(); ++s) {
        const Matrix3N& r = loop.segment_map[static_cast<std::size_t>(s)];
        weights[static_cast<std::size_t>(s)] = segment_weights(plant.segment(s), loop.total_stiffness);
        for (int q = 0; q <= p; ++q) {
            const auto qi = static_cast<std::size_t>(q);
            const Matrix3<Scalar> w =
                binomial_p[qi] * weights[static_cast<std::size_t>(s)][static_cast<std::size_t>(p - q)];
            multiply_into(wr, w, r);
            add_transposed_product(h[qi], r, wr);  // H_q += R^T w R
        }
    }
    Scalar j = 0;
    for (int q = 0; q <= p; ++q) {
        j += frobenius_product<Scalar>(h[static_cast<std::size_t>(q)], g[static_cast<std::size_t>(q)]);
    }
    // Adjoint.
    std::array<Square, 3> l;
    for (auto& x : l) x = Square::Zero(n, n);
    if (p >= 2) l[2] = stein.adjoint_solve(h[2]);
    if (p >= 1) {
        Square c = h[1];  // H_1 + 2 L_2
        if (p >= 2) {
            for (int b = 0; b < n; ++b) {
                for (int a = 0; a < n; ++a) c(a, b) = h[1](a, b) + Scalar(2) * l[2](a, b);
            }
        }
        l[1] = stein.adjoint_solve(c);
    }
    {
        Square rhs = h[0];  // H_0 + M^T (L_1 - L_2) M
        if (p >= 1) {
            Square d(n, n);
            for (int b = 0; b < n; ++b) {
                for (int a = 0; a < n; ++a) d(a, b) = l[1](a, b) - l[2](a, b);
            }
            Square mtd = Square::Zero(n, n);
            add_transposed_product(mtd, m, d);
            Square mtdm;
            multiply_into(mtdm, mtd, m);
            for (int b = 0; b < n; ++b) {
                for (int a = 0; a < n; ++a) rhs(a, b) += mtdm(a, b);
            }
        }
        l[0] = stein.adjoint_solve(rhs);
    }
    // 2 <sum L M G, dM>: only rows 0, 1 of dM are non-zero, so only rows 0, 1 of the sum are needed.
    using Top = typename ShiftSteinSolver<Scalar, MaxN>::Top;
    Top through_m = Top::Zero(2, n);
    {
        Square l0(n, n);  // L_0 + L_1 - L_2
        for (int b = 0; b < n; ++b) {
            for (int a = 0; a < n; ++a) l0(a, b) = l[0](a, b) + l[1](a, b) - l[2](a, b);
        }
        Square mg;
        for (int q = 0; q <= p; ++q) {
            const auto qi = static_cast<std::size_t>(q);
            const Square& left = q == 0 ? l0 : l[qi];
            multiply_into(mg, m, g[qi]);  // through_m += left.topRows(2) (M G_q)
            for (int b = 0; b < n; ++b) {
                for (int a = 0; a < 2; ++a) {
                    Scalar v = 0;
                    for (int i = 0; i < n; ++i) v += left(a, i) * mg(i, b);
                    through_m(a, b) += v;
                }
            }
        }
    }
    const Scalar k = loop.total_stiffness;
    Scalar dj[2];
    for (int dir = 0; dir < 2; ++dir) {
        const Scalar da = dir == 0 ? Scalar(1) : Scalar(0);
        const Scalar db = dir == 0 ? Scalar(0) : Scalar(1);
        const CompactLoopDerivative<Scalar, MaxN> dl = compact_loop_derivative<Scalar, MaxN>(plant, da, db);
        Scalar v = Scalar(2) * frobenius_product<Scalar>(through_m, dl.top);
        if (dir == 0) {  // e_0 = -u / k: de_0 / dalpha = -e_0 / k; the term 2 e_0^T L_0 de_0
            Scalar dot = 0;
            for (int a = 0; a < n; ++a) {
                Scalar y = 0;
                for (int b = 0; b < n; ++b) y += l[0](a, b) * (-e0(b) / k);
                dot += e0(a) * y;
            }
            v += Scalar(2) * dot;
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
