// SPDX-License-Identifier: Apache-2.0
// The wall's velocity estimator in the exact model, and the force noise that position quantisation
// causes through it (normalised units m = T = 1, Hulin et al. 2011 Table I).
//
// Force law: f_j = alpha y_j + beta v_j, y_j the measured position. The estimators:
//   backward  v_j = y_j - y_{j-1}                                   (the paper's; the default)
//   lowpass   v_j = lambda v_{j-1} + (1 - lambda)(y_j - y_{j-1}),   lambda = exp(-2 pi nu), nu = f_c T
//             (a first-order low-pass, pole at lambda = exp(-omega_c T), after the backward difference)
//   window    v_j = (y_j - y_{j-N}) / N,  N >= 1                    (difference over N periods)
// All are v_j = sum_i b_i y_{j-i} + sum_{k>=1} a_k v_{j-k} with sum_i b_i = 0, so v = 0 and f = alpha x_inf
// at rest and the step's final position stays x_inf = 1 / (alpha + gamma).
//
// Loop state (deviations from the final values): s_j = (x_j - x_inf, x'_j, y_{j-1} - x_inf, ...,
// y_{j-Hy} - x_inf, v_{j-1}, ..., v_{j-Hv} [, e_j]). The positions are the plant's (SampledPlant,
// exact per period and per delay segment); the force acting on segment s is f_{j-a_s}. For an FIR estimator
// (na = 0) v_{j-a} is written out in the y's (Hv = 0, Hy = max(1, a_max + nb - 1)); for the low-pass the
// v's are states (Hv = max(1, a_max), Hy = max(1, a_max, nb - 1)). For the backward difference this is
// exactly the state of closed_loop.hpp. Step response from rest: s_0 = -x_inf on the position entries,
// 0 on x', the v's and e.
//
// Stability: the characteristic polynomial. With p(z) = P_0 + alpha P_alpha + beta P_beta of the backward
// loop (characteristic_polynomial.hpp; P_alpha = q(z) z, P_beta = q(z)(z - 1)) the controller
// alpha + beta (1 - 1/z) becomes alpha + beta B(1/z) / A(1/z); multiplying by At(z) = z^L A(1/z),
// L = max(nb - 1, na), and writing Bt(z) = z^L B(1/z):
//   p_est(z) = P_0 At + alpha P_alpha At + beta P_alpha Bt,
// (for the backward difference p_est = z p: one extra root at 0). Schur-Cohn on p_est in double, recomputed
// in long double where its margin is below 1e-4, as loop_verdict does (loop_schur_form.hpp). The spectral
// radius reported is the largest eigenvalue modulus of the loop matrix (complex Schur form).
//
// Energy costs C_E0..2: the same integrals and Stein equations as energy_costs.hpp (E is a quadratic form
// of s_j on each segment; G_p = sum_j j^p s_j s_j^T from three Stein equations). A window is FIR, so its loop
// keeps the shift structure (a longer position history) and ShiftSteinSolver (stein_equation.hpp) solves
// them; the low-pass's v states break it, so they are solved on the complex Schur form of the dense loop
// matrix (detail::energy_costs_from_schur). Exact up to rounding; the error grows like eps / (1 - rho^2) as
// for the backward loop. C_OV: the exact continuous maximum of overshoot.hpp on this loop.
//
// Quantisation noise (the derivation; docs/velocity-estimation.md): the measured position is
// y_j = x_j + e_j with e_j white, variance q^2/12 (a uniform rounding error, valid when the motion spans many
// counts between samples). Appending e_j to the state with e_{j+1} = w_j (w white) makes the closed loop
// s_{j+1} = M s_j + g w_j, g the unit vector of e; the measured position y_j enters the force law, the
// stored history and the estimator, the plant's own x_j only its propagation. The commanded force's
// deviation is f_j - f_inf = c^T s_j (c: alpha on y_j plus beta times the estimator's form). In steady
// state P = E[s s^T] solves the Stein equation  P = M P M^T + var(e) g g^T  and var(f) = c^T P c.
// Linear in q: in normalised units with q = 1, var(e) = 1/12 and g_F = sqrt(c^T P c); physically
// (f = F T^2 / m, positions unscaled) sigma_F = (m q / T^2) g_F. For the backward difference without
// feedback g_F would be sqrt(((alpha + beta)^2 + beta^2) / 12); the loop's response adds to it.
// Gradient of C_E0..2 (estimator_energy_cost_gradient): the adjoint Stein equation of energy_gradient.hpp on this
// loop (M and R_s are affine in alpha and beta); it drives the fast CEx optimum (optimal_point, OptimumMethod::newton).
// Costs: N = 2 + Hy + Hv [+ 1] states; the window's energy costs one (2N - 1)-square LU, everything else
// O(N^3) per evaluation (complex Schur form of the N-square loop matrix). Measured: docs/benchmarks.md.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <complex>
#include <limits>
#include <type_traits>
#include <utility>
#include <vector>

#include "config.hpp"
#include "energy_costs.hpp"
#include "energy_gradient.hpp"
#include "optimum.hpp"
#include "overshoot.hpp"
#include "region_minimum.hpp"
#include "stability.hpp"

namespace hapticopt {

enum class VelocityEstimatorKind { backward, lowpass, window };

/// How the wall estimates velocity from the sampled position (header comment).
struct VelocityEstimator {
    VelocityEstimatorKind kind = VelocityEstimatorKind::backward;
    double cutoff = 0;  ///< lowpass: normalised cutoff nu = f_c T, finite and > 0
    int window = 1;     ///< window: N, 1 <= N <= kMaxVelocityWindow

    static VelocityEstimator backward_difference() { return {}; }
    /// Throws InvalidParameter unless nu is finite and > 0.
    static VelocityEstimator low_pass(double nu);
    /// Throws InvalidParameter unless 1 <= n <= kMaxVelocityWindow.
    static VelocityEstimator moving_window(int n);
};

/// Longest window accepted: 1000 periods (1 s at 1 kHz; the loop state grows by one per period).
inline constexpr int kMaxVelocityWindow = 1000;

/// Throws InvalidParameter (message starting with `function`) for a low-pass cutoff that is not finite and
/// > 0, or a window outside 1 .. kMaxVelocityWindow.
inline void validate(const VelocityEstimator& e, const char* function = "hapticopt::validate") {
    if (e.kind == VelocityEstimatorKind::lowpass) {
        detail::require_in_range(function, "cutoff", e.cutoff, 0.0, true, HUGE_VAL,
                                 "finite and > 0 (normalised cutoff nu = f_c T)");
    } else if (e.kind == VelocityEstimatorKind::window) {
        detail::require_in_range(function, "window", e.window, 1.0, false, kMaxVelocityWindow,
                                 "1 <= N <= 1000 periods");
    }
}

inline VelocityEstimator VelocityEstimator::low_pass(double nu) {
    VelocityEstimator e;
    e.kind = VelocityEstimatorKind::lowpass;
    e.cutoff = nu;
    validate(e, "hapticopt::VelocityEstimator::low_pass");
    return e;
}

inline VelocityEstimator VelocityEstimator::moving_window(int n) {
    VelocityEstimator e;
    e.kind = VelocityEstimatorKind::window;
    e.window = n;
    validate(e, "hapticopt::VelocityEstimator::moving_window");
    return e;
}

/// The estimator as a difference equation v_j = sum_i b[i] y_{j-i} + sum_k a[k-1] v_{j-k} (header).
template <typename Scalar>
struct EstimatorCoefficients {
    std::vector<Scalar> b;  ///< nb >= 2 coefficients on y_j, y_{j-1}, ...
    std::vector<Scalar> a;  ///< na coefficients on v_{j-1}, ... (empty for FIR)
};

template <typename Scalar>
EstimatorCoefficients<Scalar> estimator_coefficients(const VelocityEstimator& e) {
    EstimatorCoefficients<Scalar> c;
    switch (e.kind) {
        case VelocityEstimatorKind::backward:
            c.b = {Scalar(1), Scalar(-1)};
            break;
        case VelocityEstimatorKind::lowpass: {
            using std::exp;
            const Scalar pi = Scalar(3.141592653589793238462643383279502884L);
            const Scalar lambda = exp(-Scalar(2) * pi * Scalar(e.cutoff));
            c.b = {Scalar(1) - lambda, lambda - Scalar(1)};
            c.a = {lambda};
            break;
        }
        case VelocityEstimatorKind::window: {
            c.b.assign(static_cast<std::size_t>(e.window) + 1, Scalar(0));
            c.b.front() = Scalar(1) / Scalar(e.window);
            c.b.back() = -Scalar(1) / Scalar(e.window);
            break;
        }
    }
    return c;
}

/// The closed loop with the estimator (header comment): M, s_0, R_s as in ClosedLoop, plus the force's form.
template <typename Scalar>
struct EstimatorLoop {
    ClosedLoop<Scalar> loop;
    DynamicVector<Scalar> force;  ///< c: f_j - f_inf = c^T s_j
    int noise_index = -1;         ///< index of e_j in s_j, -1 without the noise state
};

/// Builds the loop of the header comment. Cost O(N^2). Requires alpha + gamma != 0 unless `derivative`.
/// M and R_s are affine in (alpha, beta); with `derivative` = true the constant part is left out, so that
/// (alpha, beta) = (da, db) gives their derivative along that direction (initial state, force and final position
/// are then not meaningful).
template <typename Scalar>
EstimatorLoop<Scalar> make_estimator_loop(const SampledPlant<Scalar>& plant, const VelocityEstimator& estimator,
                                          Scalar alpha, Scalar beta, bool with_noise, bool derivative = false) {
    const EstimatorCoefficients<Scalar> co = estimator_coefficients<Scalar>(estimator);
    const int nb = static_cast<int>(co.b.size());
    const int na = static_cast<int>(co.a.size());
    const int age_max = plant.segment(0).force_age;  // segment 0 carries the older force
    const bool fir = na == 0;
    const int hy = fir ? std::max(1, age_max + nb - 1) : std::max({1, age_max, nb - 1});
    const int hv = fir ? 0 : std::max({1, age_max, na});
    const int n = 2 + hy + hv + (with_noise ? 1 : 0);
    using Vec = DynamicVector<Scalar>;
    auto unit = [n](int i) {
        Vec v = Vec::Zero(n);
        v(i) = Scalar(1);
        return v;
    };
    const int noise = with_noise ? n - 1 : -1;
    auto measured = [&](int i) {  // y_{j-i} - x_inf
        if (i == 0) {
            Vec v = unit(0);
            if (noise >= 0) v(noise) = Scalar(1);
            return v;
        }
        return unit(1 + i);
    };
    auto v_slot = [&](int k) { return 1 + hy + k; };  // index of v_{j-k}, k >= 1
    auto velocity = [&](int age) {                    // v_{j-age}
        Vec v = Vec::Zero(n);
        if (fir || age == 0) {
            for (int i = 0; i < nb; ++i) v += co.b[static_cast<std::size_t>(i)] * measured(age + i);
            if (!fir) {
                for (int k = 1; k <= na; ++k) v(v_slot(k)) += co.a[static_cast<std::size_t>(k - 1)];
            }
        } else {
            v(v_slot(age)) = Scalar(1);
        }
        return v;
    };
    EstimatorLoop<Scalar> out;
    out.noise_index = noise;
    out.force = alpha * measured(0) + beta * velocity(0);
    ClosedLoop<Scalar>& loop = out.loop;
    loop.alpha = alpha;
    loop.beta = beta;
    loop.total_stiffness = alpha + Scalar(plant.parameters().gamma);
    loop.final_position = Scalar(1) / loop.total_stiffness;
    DynamicMatrix<Scalar> rows = DynamicMatrix<Scalar>::Zero(2, n);
    if (!derivative) {
        rows(0, 0) = 1;
        rows(1, 1) = 1;
    }
    for (int s = 0; s < plant.segment_count(); ++s) {
        const auto& seg = plant.segment(s);
        DynamicMatrix<Scalar>& r = loop.segment_map[static_cast<std::size_t>(s)];
        r = DynamicMatrix<Scalar>::Zero(3, n);
        r.topRows(2) = rows;
        r.row(2) = (alpha * measured(seg.force_age) + beta * velocity(seg.force_age)).transpose();
        DynamicMatrix<Scalar> next(2, n);
        for (int i = 0; i < 2; ++i) {
            next.row(i) = seg.exp(i, 0) * r.row(0) + seg.exp(i, 1) * r.row(1) + seg.exp(i, 2) * r.row(2);
        }
        rows = next;
    }
    DynamicMatrix<Scalar>& m = loop.transition;
    m = DynamicMatrix<Scalar>::Zero(n, n);
    m.topRows(2) = rows;
    if (derivative) return out;
    m.row(2) = measured(0).transpose();             // y_j becomes y_{(j+1)-1}
    for (int i = 2; i <= hy; ++i) m(1 + i, i) = 1;  // y_{j-i+1} becomes y_{(j+1)-i}
    if (hv > 0) {
        m.row(v_slot(1)) = velocity(0).transpose();  // v_j becomes v_{(j+1)-1}
        for (int k = 2; k <= hv; ++k) m(v_slot(k), v_slot(k - 1)) = 1;
    }
    loop.initial_state = Vec::Zero(n);
    loop.initial_state(0) = -loop.final_position;
    for (int i = 1; i <= hy; ++i) loop.initial_state(1 + i) = -loop.final_position;
    return out;
}

namespace detail {

/// c = a * b for ascending coefficient vectors.
template <typename Scalar>
Eigen::Matrix<Scalar, Eigen::Dynamic, 1> poly_product(const Eigen::Matrix<Scalar, Eigen::Dynamic, 1>& a,
                                                      const Eigen::Matrix<Scalar, Eigen::Dynamic, 1>& b) {
    Eigen::Matrix<Scalar, Eigen::Dynamic, 1> c =
        Eigen::Matrix<Scalar, Eigen::Dynamic, 1>::Zero(a.size() + b.size() - 1);
    for (Eigen::Index i = 0; i < a.size(); ++i) {
        for (Eigen::Index k = 0; k < b.size(); ++k) c(i + k) += a(i) * b(k);
    }
    return c;
}

}  // namespace detail

/// p_est(z) = P_0 At + alpha P_alpha At + beta P_alpha Bt (header comment) from the backward loop's p(z).
template <typename Scalar>
AffineCharacteristicPolynomial<Scalar> estimator_characteristic_polynomial(
    const AffineCharacteristicPolynomial<Scalar>& base, const VelocityEstimator& estimator) {
    using Coefficients = typename AffineCharacteristicPolynomial<Scalar>::Coefficients;
    const EstimatorCoefficients<Scalar> co = estimator_coefficients<Scalar>(estimator);
    const int nb = static_cast<int>(co.b.size());
    const int na = static_cast<int>(co.a.size());
    const int l = std::max(nb - 1, na);
    Coefficients at = Coefficients::Zero(l + 1), bt = Coefficients::Zero(l + 1);
    at(l) = 1;
    for (int k = 1; k <= na; ++k) at(l - k) = -co.a[static_cast<std::size_t>(k - 1)];
    for (int i = 0; i < nb; ++i) bt(l - i) = co.b[static_cast<std::size_t>(i)];
    AffineCharacteristicPolynomial<Scalar> p;
    p.base = detail::poly_product(base.base, at);
    p.alpha = detail::poly_product(base.alpha, at);
    p.beta = detail::poly_product(base.alpha, bt);
    return p;
}

/// Stability of the loop with the estimator, by Schur-Cohn on p_est with the long double refinement below
/// |margin| 1e-4 (as loop_verdict). Precomputes both polynomials once; stable(alpha, beta) is O(degree^2).
class EstimatorStabilityTest {
  public:
    HAPTICOPT_DEFERRED
    EstimatorStabilityTest(const NormalizedPlant& plant, const VelocityEstimator& estimator)
        : gamma_(plant.gamma),
          poly_(estimator_characteristic_polynomial(characteristic_polynomial(SampledPlant<double>(plant)), estimator)),
          fine_(estimator_characteristic_polynomial(characteristic_polynomial(plant_transitions<long double>(plant)),
                                                    estimator)) {}

    LoopVerdict<double> verdict(double alpha, double beta) const {
        LoopVerdict<double> v;
        if (!(alpha + gamma_ > 0)) return v;
        const SchurCohnResult<double> test = schur_cohn<double>(poly_.at(alpha, beta));
        v.stable = test.stable;
        v.margin = test.margin;
        if constexpr (std::numeric_limits<long double>::digits > std::numeric_limits<double>::digits) {
            if (std::abs(test.margin) < kStabilityRefinementMargin) {
                using LD = long double;
                const SchurCohnResult<LD> r = schur_cohn<LD>(fine_.at(LD(alpha), LD(beta)));
                v.stable = r.stable;
                v.margin = static_cast<double>(r.margin);
                v.refined = true;
            }
        }
        return v;
    }
    bool stable(double alpha, double beta) const { return verdict(alpha, beta).stable; }
    const AffineCharacteristicPolynomial<double>& polynomial() const { return poly_; }

  private:
    double gamma_;
    AffineCharacteristicPolynomial<double> poly_;
    AffineCharacteristicPolynomial<long double> fine_;
};

namespace detail {

/// C_E0..2 of a loop whose rows >= 2 are the shift rows of closed_loop.hpp (an FIR estimator without the
/// noise state: its state is the plant's plus a longer position history): the three Stein equations by
/// ShiftSteinSolver (one (2N - 1)-square LU), the traces as in energy_costs_structured. +inf if a pivot
/// vanishes or a cost is not positive and finite (rounding at the boundary).
template <typename Scalar>
EnergyCostsT<Scalar> shift_structured_energy_costs(const SampledPlant<Scalar>& plant, const ClosedLoop<Scalar>& loop) {
    const Scalar inf = std::numeric_limits<Scalar>::infinity();
    using Solver = ShiftSteinSolver<Scalar, Eigen::Dynamic>;
    const Solver stein(typename Solver::Top(loop.transition.topRows(2)));
    if (!stein.ok()) return {inf, inf, inf};
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

}  // namespace detail

/// C_E0..2 with the estimator for a precomputed plant, +inf when unstable (M's spectral radius >= 1, or the
/// solver's pivots). Every kind, including the backward difference, goes through the estimator's loop here
/// (energy_costs() with an estimator sends the backward difference to the fast backward path instead):
/// the window through ShiftSteinSolver (its loop has the shift structure; `dense` = true forces the
/// complex-Schur method instead, for the cross-check in the tests), the low-pass on the complex Schur form.
template <typename Scalar>
EnergyCostsT<Scalar> estimator_energy_costs(const SampledPlant<Scalar>& plant, const VelocityEstimator& estimator,
                                            Scalar alpha, Scalar beta, bool dense = false) {
    const Scalar inf = std::numeric_limits<Scalar>::infinity();
    if (!(alpha + Scalar(plant.parameters().gamma) > Scalar(0))) return {inf, inf, inf};
    const EstimatorLoop<Scalar> el = make_estimator_loop(plant, estimator, alpha, beta, false);
    const bool fir = estimator.kind != VelocityEstimatorKind::lowpass;
    if (fir && !dense) {
        // The shift solver does not see instability by itself: Schur-Cohn on p_est first; near the boundary
        // (|margin| < 1e-4) the complex-Schur path below decides by the spectral radius.
        const SchurCohnResult<Scalar> sc = schur_cohn<Scalar>(
            estimator_characteristic_polynomial(characteristic_polynomial(plant), estimator).at(alpha, beta));
        using std::abs;
        if (abs(sc.margin) >= Scalar(kStabilityRefinementMargin)) {
            if (!sc.stable) return {inf, inf, inf};
            return detail::shift_structured_energy_costs(plant, el.loop);
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
/// ShiftSteinSolver (its adjoint_solve gives S*), the low-pass (or `dense` = true, or a window within the
/// Schur-Cohn margin 1e-4 of the boundary) on the complex Schur form (detail::SchurSteinSolver). A solution
/// exists wherever the cost does (a Schur-stable loop); unstable gains give value +inf and NaN derivatives.
/// Checked against central differences of estimator_energy_costs in long double
/// (tests/core/test_estimator_fast_optimum.cpp). Cost: about twice the costs' own evaluation (p + 1 adjoint solves
/// and O(N^3) products). Throws InvalidParameter for an index outside 0..2.
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
    if (estimator.kind != VelocityEstimatorKind::lowpass && !dense) {
        const SchurCohnResult<Scalar> sc = schur_cohn<Scalar>(
            estimator_characteristic_polynomial(characteristic_polynomial(plant), estimator).at(alpha, beta));
        using std::abs;
        if (abs(sc.margin) >= Scalar(kStabilityRefinementMargin)) {
            if (!sc.stable) return unstable;
            using Solver = ShiftSteinSolver<Scalar, Eigen::Dynamic>;
            const Solver stein(typename Solver::Top(loop.transition.topRows(2)));
            if (!stein.ok()) return unstable;
            return detail::estimator_gradient_from_solver(plant, loop, stein, dloop, index);
        }
    }
    const LoopSchurForm<Scalar> schur = loop_schur_form(loop.transition);
    if (!(schur.spectral_radius < Scalar(1))) return unstable;
    const detail::SchurSteinSolver<Scalar> stein(loop.transition, schur);
    return detail::estimator_gradient_from_solver(plant, loop, stein, dloop, index);
}

/// g_F of the header comment: sigma_F = (m q / T^2) g_F; +inf when unstable.
template <typename Scalar>
Scalar estimator_force_noise_gain(const SampledPlant<Scalar>& plant, const VelocityEstimator& estimator, Scalar alpha,
                                  Scalar beta) {
    const Scalar inf = std::numeric_limits<Scalar>::infinity();
    if (!(alpha + Scalar(plant.parameters().gamma) > Scalar(0))) return inf;
    const EstimatorLoop<Scalar> el = make_estimator_loop(plant, estimator, alpha, beta, true);
    const LoopSchurForm<Scalar> schur = loop_schur_form(el.loop.transition);
    if (!(schur.spectral_radius < Scalar(1))) return inf;
    using Complex = std::complex<Scalar>;
    const ComplexVector<Scalar> gu = schur.u.row(el.noise_index).adjoint();  // U^H g
    const ComplexMatrix<Scalar> c = (gu * gu.adjoint()) / Scalar(12);
    const ComplexMatrix<Scalar> x = solve_triangular_stein<Scalar>(schur.t, c);  // P = U X U^H
    const ComplexVector<Scalar> cu = schur.u.adjoint() * el.force.template cast<Complex>();
    const Scalar variance = (cu.adjoint() * x * cu)(0, 0).real();
    using std::sqrt;
    return variance >= Scalar(0) ? sqrt(variance) : inf;
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

/// Stability with the estimator: the Schur-Cohn verdict (EstimatorStabilityTest) and the spectral radius of
/// the loop matrix. The backward difference is the existing stability(plant, gains).
HAPTICOPT_FUNC StabilityReport stability(const NormalizedPlant& plant, const NormalizedGains& gains,
                                         const VelocityEstimator& estimator)
#if HAPTICOPT_DEFINITIONS
{
    validate(gains, "hapticopt::stability");
    validate(estimator, "hapticopt::stability");
    if (estimator.kind == VelocityEstimatorKind::backward) return stability(plant, gains);
    const SampledPlant<double> sampled(plant);
    const LoopVerdict<double> v = EstimatorStabilityTest(plant, estimator).verdict(gains.alpha, gains.beta);
    StabilityReport report;
    report.stable = v.stable;
    report.margin = v.margin;
    report.refined = v.refined;
    report.spectral_radius =
        loop_schur_form(make_estimator_loop(sampled, estimator, gains.alpha, gains.beta, false).loop.transition)
            .spectral_radius;
    return report;
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

/// g_F (header comment): the steady-state standard deviation of the commanded force per encoder step, in
/// normalised units (sigma_F = (m q / T^2) g_F); +inf when the loop is unstable.
HAPTICOPT_FUNC double force_noise_gain(const NormalizedPlant& plant, const NormalizedGains& gains,
                                       const VelocityEstimator& estimator = {})
#if HAPTICOPT_DEFINITIONS
{
    validate(gains, "hapticopt::force_noise_gain");
    validate(estimator, "hapticopt::force_noise_gain");
    if (!EstimatorStabilityTest(plant, estimator).stable(gains.alpha, gains.beta)) return HUGE_VAL;
    return estimator_force_noise_gain(SampledPlant<double>(plant), estimator, gains.alpha, gains.beta);
}
#else
    ;
#endif

/// sigma_F [N] = (m q / T^2) g_F for the physical loop, gains and encoder step q [m] (> 0, finite).
HAPTICOPT_FUNC double force_noise_std(const PhysicalPlant& plant, const WallGains& gains, double position_resolution,
                                      const VelocityEstimator& estimator = {})
#if HAPTICOPT_DEFINITIONS
{
    const char* fn = "hapticopt::force_noise_std";
    validate(plant, fn);
    detail::require_positive(fn, "position_resolution", position_resolution);
    const NormalizedGains g = normalize(gains, plant.mass, plant.period);
    return plant.mass * position_resolution / (plant.period * plant.period) *
           force_noise_gain(normalize(plant), g, estimator);
}
#else
    ;
#endif

/// A stable set of the gain plane not connected to the main region, as seen on the region's scan grid
/// (bounding box of its stable grid cells; islands thinner than a cell can be missed).
struct StableIsland {
    double alpha_min = 0, alpha_max = 0, beta_min = 0, beta_max = 0;
};

struct EstimatorRegionOptions {
    int alpha_grid = 160;      ///< scan cells along alpha, >= 16
    int beta_grid = 160;       ///< scan cells along beta, >= 16
    bool find_islands = true;  ///< false: islands() stays empty, the box is fitted on a coarse grid first
};

/// The main stable region with the estimator: the connected stable set that contains small alpha > 0
/// (alpha -> 0+ at some beta). Found by a scan of the Schur-Cohn verdict on a grid over alpha in (0, 1],
/// beta in [-1, 4], flood fill from the grid's first alpha column (only the cells the fill reaches are tested,
/// except in the first scan when islands are wanted; where that column has nothing stable,
/// the box shrinks 4x in alpha and beta towards beta = 0 until it does, down to alpha 1e-9), the box re-fitted
/// to the region until it fills it (a pass whose first column has nothing stable scans no further). Without
/// find_islands (the fast optimum's grid) the box is fitted on a 16 x 16 grid first, then scanned at the options'
/// grid (not again where that is 16 x 16); where that finds nothing, the search runs again at 40 x 40, then at the
/// default 160 x 160; and on a grid coarser than 40 x 40 a corner tip (below) has the region scanned again at
/// 40 x 40 before its Brent search.
/// The region's edge along a line of constant beta is the first instability reached by marching up in alpha
/// from a main-region cell (steps of a quarter cell) refined by bisection to 1e-14. alpha_max: the largest
/// local maximum of the D-decomposition curve (alpha(theta), beta(theta)) solving p(e^{i theta}) = 0
/// (stability_region.hpp; sampled at max(64, 16 degree) frequencies in (0, pi), refined by Brent) inside the
/// scan's tip cells, taken (as the edge there) when the edge at its beta agrees with it to 1e-12 alpha; else (a corner
/// tip, where two branches cross) the maximum of the edge over beta (Brent, scalar_search.hpp). Stable components of
/// the first (wide) scan that are not connected to the main one are reported as islands. Accuracy: alpha_max
/// to ~1e-12 where the maximum is a smooth tip (checked against the exact d = 0 value 12 - 8 sqrt(2) for
/// window 1, tests/core/test_velocity_estimator.cpp).
class EstimatorStabilityRegion {
  public:
    HAPTICOPT_DEFERRED
    EstimatorStabilityRegion(const NormalizedPlant& plant, const VelocityEstimator& estimator,
                             const EstimatorRegionOptions& options = {})
        : test_(plant, estimator), options_(options) {
        const char* fn = "hapticopt::EstimatorStabilityRegion";
        validate(plant, fn);
        validate(estimator, fn);
        detail::require_in_range(fn, "alpha_grid", options.alpha_grid, 16, false, 1e5, "16 <= alpha_grid <= 10^5");
        detail::require_in_range(fn, "beta_grid", options.beta_grid, 16, false, 1e5, "16 <= beta_grid <= 10^5");
        std::vector<StableIsland> wide;
        bool found = !options.find_islands && fit_box(true, nullptr);
        if (!found) found = fit_box(false, options.find_islands ? &wide : nullptr);
        // Nothing found on a coarse grid: again at kFallbackGrid, then at the default grid (a region whose
        // first column the coarser scans miss: a thin one, or one at beta < 0 that the box shrinking towards
        // beta = 0 leaves).
        for (const int grid : {kFallbackGrid, EstimatorRegionOptions{}.alpha_grid}) {
            if (found || options.find_islands || std::min(options.alpha_grid, options.beta_grid) >= grid) continue;
            options_.alpha_grid = std::max(options.alpha_grid, grid);
            options_.beta_grid = std::max(options.beta_grid, grid);
            found = fit_box(false, nullptr);
        }
        if (!found) {
            alpha_max_ = 0;
            islands_ = wide;
            return;
        }
        if (!refine_tip() && !options.find_islands &&
            std::min(options_.alpha_grid, options_.beta_grid) < kFallbackGrid) {
            // A corner tip on a grid coarser than kFallbackGrid: the region again on that grid (the tip's Brent
            // search and the beta intervals start from the scan's cells); the coarse region where that finds none.
            const EstimatorRegionOptions coarse = options_;
            options_.alpha_grid = std::max(options_.alpha_grid, kFallbackGrid);
            options_.beta_grid = std::max(options_.beta_grid, kFallbackGrid);
            if (!fit_box(false, nullptr)) {
                options_ = coarse;
                fit_box(true, nullptr);
            }
            refine_tip();
        }
        // Islands: the components of the first (widest) scan not connected to its first column, except any that
        // overlaps the main region's box (a main region thinner than that scan's cells can appear detached in it).
        const double db = (b1_ - b0_) / nb();
        const double main_lo = b0_ + main_j0_ * db, main_hi = b0_ + (main_j1_ + 1) * db;
        for (const StableIsland& i : wide) {
            const bool overlaps = i.alpha_min < alpha_max_ && i.beta_min < main_hi && i.beta_max > main_lo;
            if (!overlaps) islands_.push_back(i);
        }
    }

    double alpha_max() const { return alpha_max_; }
    double beta_at_alpha_max() const { return beta_at_alpha_max_; }
    const std::vector<StableIsland>& islands() const { return islands_; }
    bool stable(double alpha, double beta) const { return test_.stable(alpha, beta); }
    const EstimatorStabilityTest& test() const { return test_; }

    /// The stable beta interval of the main region at alpha (0 < alpha < alpha_max), its ends bisected to
    /// `tolerance` x max(1, |beta|) (default 1e-14: ends to ~1e-13; a start grid needs far less);
    /// (0, 0) when alpha is outside (0, alpha_max). From the lowest main cell centre stable at alpha (nearest
    /// columns first), the lower end is marched down in steps of a quarter cell; the upper end is marched up a
    /// cell at a time through that column's run of main cells while they are stable at alpha, then in quarter
    /// cells.
    std::pair<double, double> beta_interval(double alpha, double tolerance = 1e-14) const {
        if (!(alpha > 0 && alpha < alpha_max_)) return {0, 0};
        const double da = a1_ / na(), db = (b1_ - b0_) / nb();
        int i = std::clamp(static_cast<int>(alpha / da), 0, na() - 1);
        // A stable beta of the main region at this alpha: main cells of the nearest columns, centre out.
        double start = std::nan("");
        int start_column = i;
        for (int di = 0; di <= 2 && std::isnan(start); ++di) {
            for (int sgn : {-1, 1}) {
                const int c = std::clamp(i + sgn * di, 0, na() - 1);
                for (int j = 0; j < nb() && std::isnan(start); ++j) {
                    const double b = b0_ + (j + 0.5) * db;
                    if (label(c, j) == 1 && test_.stable(alpha, b)) {
                        start = b;
                        start_column = c;
                    }
                }
            }
        }
        if (std::isnan(start)) return {0, 0};
        // Up through the run of main cells above start in its column, a cell at a time while stable at alpha.
        double top = start;
        for (int j = static_cast<int>((start - b0_) / db) + 1; j < nb() && label(start_column, j) == 1; ++j) {
            const double b = b0_ + (j + 0.5) * db;
            if (!test_.stable(alpha, b)) break;
            top = b;
        }
        auto edge = [&](double direction) {
            const double from = direction > 0 ? top : start;
            double inside = from, outside = from;
            for (int k = 1; k < 8 * nb(); ++k) {
                outside = from + direction * k * db / 4;
                if (!test_.stable(alpha, outside)) break;
                inside = outside;
            }
            for (int k = 0; k < 80 && std::abs(outside - inside) > tolerance * std::max(1.0, std::abs(inside)); ++k) {
                const double mid = (inside + outside) / 2;
                (test_.stable(alpha, mid) ? inside : outside) = mid;
            }
            return inside;
        };
        return {edge(-1), edge(1)};
    }

  private:
    static constexpr int kCoarseGrid = 16;
    static constexpr int kFallbackGrid = 40;
    int na() const { return scan_na_; }
    int nb() const { return scan_nb_; }
    int label(int i, int j) const { return labels_[static_cast<std::size_t>(i * nb() + j)]; }

    /// Scans from the box (0, 1] x [-1, 4] and re-fits it until the main region fills it (class comment); false
    /// when the region is empty (nothing stable in the first column down to alpha 1e-9). `coarse`: the passes
    /// are on kCoarseGrid until the box fits, then one more at the options' grid (re-fitted there if it no longer
    /// fits; none more where the options' grid is kCoarseGrid). `wide`: receives the first scan's other components (the
    /// islands).
    bool fit_box(bool coarse, std::vector<StableIsland>* wide) {
        double a1 = 1, b0 = -1, b1 = 4;
        bool fine = !coarse || (options_.alpha_grid == kCoarseGrid && options_.beta_grid == kCoarseGrid);
        for (int pass = 0; pass < 40; ++pass) {
            scan(a1, b0, b1, fine ? options_.alpha_grid : kCoarseGrid, fine ? options_.beta_grid : kCoarseGrid,
                 !(wide && pass == 0));
            if (wide && pass == 0) *wide = other_components();
            if (main_cells_ == 0) {  // nothing stable in the first column: the main region is below one cell, or empty
                if (a1 < 1e-9) return false;
                const double w = (b1 - b0) / 4;
                a1 /= 4;
                b0 = -0.2 * w;
                b1 = 0.8 * w;
                continue;
            }
            // Re-fit the box: grow where the region touches an edge, shrink where it fills little of it.
            const double da = a1 / na(), db = (b1 - b0) / nb();
            const double top = (main_i1_ + 1) * da;
            const double lo = b0 + main_j0_ * db, hi = b0 + (main_j1_ + 1) * db;
            const bool touches = main_i1_ == na() - 1 || main_j0_ == 0 || main_j1_ == nb() - 1;
            const bool loose = top < 0.6 * a1 || (hi - lo) < 0.6 * (b1 - b0);
            if (!touches && !loose) {
                if (fine) return true;
                fine = true;  // the coarse box fits: scan it at the options' grid
                continue;
            }
            const double na1 = main_i1_ == na() - 1 ? 2 * a1 : 1.25 * top;
            const double margin = 0.15 * (hi - lo);
            const double nb0 = main_j0_ == 0 ? b0 - (b1 - b0) : lo - margin;
            const double nb1 = main_j1_ == nb() - 1 ? b1 + (b1 - b0) : hi + margin;
            a1 = na1;
            b0 = nb0;
            b1 = nb1;
        }
        return true;
    }

    /// Labels: 0 unstable (or, with `main_only`, not tested), 1 main component (flood fill from column 0), 2 stable
    /// elsewhere. `main_only`: only column 0 and the cells the flood fill reaches are tested (the main component is
    /// the same; nothing is labelled 2), so a pass whose column 0 has no stable cell tests that column only.
    void scan(double a1, double b0, double b1, int alpha_cells, int beta_cells, bool main_only) {
        scan_na_ = alpha_cells;
        scan_nb_ = beta_cells;
        a1_ = a1;
        b0_ = b0;
        b1_ = b1;
        const double da = a1 / na(), db = (b1 - b0) / nb();
        labels_.assign(static_cast<std::size_t>(na() * nb()), 0);
        main_cells_ = 0;
        main_i1_ = -1;
        main_j0_ = nb();
        main_j1_ = -1;
        auto stable_cell = [&](int cell) {
            const int i = cell / nb(), j = cell % nb();
            return test_.stable((i + 0.5) * da, b0 + (j + 0.5) * db);
        };
        std::vector<char> tested(labels_.size(), 0);
        if (!main_only) {
            for (std::size_t cell = 0; cell < labels_.size(); ++cell) {
                tested[cell] = 1;
                if (stable_cell(static_cast<int>(cell))) labels_[cell] = 2;
            }
        }
        std::vector<int> stack;
        auto visit = [&](int cell) {  // a stable cell the fill reaches joins the main component
            const auto c = static_cast<std::size_t>(cell);
            const bool stable = tested[c] ? labels_[c] == 2 : stable_cell(cell);
            tested[c] = 1;
            if (stable) {
                labels_[c] = 1;
                stack.push_back(cell);
            }
        };
        for (int j = 0; j < nb(); ++j) visit(j);
        while (!stack.empty()) {
            const int cell = stack.back();
            stack.pop_back();
            const int i = cell / nb(), j = cell % nb();
            ++main_cells_;
            main_i1_ = std::max(main_i1_, i);
            main_j0_ = std::min(main_j0_, j);
            main_j1_ = std::max(main_j1_, j);
            if (i > 0) visit(cell - nb());
            if (i + 1 < na()) visit(cell + nb());
            if (j > 0) visit(cell - 1);
            if (j + 1 < nb()) visit(cell + 1);
        }
    }

    std::vector<StableIsland> other_components() {
        const double da = a1_ / na(), db = (b1_ - b0_) / nb();
        std::vector<StableIsland> out;
        std::vector<int> seen(labels_.size(), 0);
        for (std::size_t start = 0; start < labels_.size(); ++start) {
            if (labels_[start] != 2 || seen[start]) continue;
            StableIsland box{HUGE_VAL, -HUGE_VAL, HUGE_VAL, -HUGE_VAL};
            std::vector<int> stack{static_cast<int>(start)};
            while (!stack.empty()) {
                const int cell = stack.back();
                stack.pop_back();
                if (labels_[static_cast<std::size_t>(cell)] != 2 || seen[static_cast<std::size_t>(cell)]) continue;
                seen[static_cast<std::size_t>(cell)] = 1;
                const int i = cell / nb(), j = cell % nb();
                box.alpha_min = std::min(box.alpha_min, i * da);
                box.alpha_max = std::max(box.alpha_max, (i + 1) * da);
                box.beta_min = std::min(box.beta_min, b0_ + j * db);
                box.beta_max = std::max(box.beta_max, b0_ + (j + 1) * db);
                if (i > 0) stack.push_back(cell - nb());
                if (i + 1 < na()) stack.push_back(cell + nb());
                if (j > 0) stack.push_back(cell - 1);
                if (j + 1 < nb()) stack.push_back(cell + 1);
            }
            out.push_back(box);
        }
        return out;
    }

    /// The main region's edge at beta: march up from its highest cell in the nearest column, then bisect.
    double edge_at(double beta) const {
        const double da = a1_ / na(), db = (b1_ - b0_) / nb();
        const int j = std::clamp(static_cast<int>((beta - b0_) / db), 0, nb() - 1);
        double inside = -1;
        for (int i = na() - 1; i >= 0 && inside < 0; --i) {
            if (label(i, j) == 1 && test_.stable((i + 0.5) * da, beta)) inside = (i + 0.5) * da;
        }
        if (inside < 0) return 0;
        double outside = inside;
        for (int k = 1; k < 16 * na(); ++k) {
            outside = inside + da / 4;
            if (!test_.stable(outside, beta)) break;
            inside = outside;
        }
        for (int k = 0; k < 80 && outside - inside > 1e-14 * std::max(1.0, inside); ++k) {
            const double mid = (inside + outside) / 2;
            (test_.stable(mid, beta) ? inside : outside) = mid;
        }
        return inside;
    }

    /// Sets alpha_max_ and beta_at_alpha_max_; true when the curve's maximum gave them (a smooth tip).
    bool refine_tip() {
        const double db = (b1_ - b0_) / nb();
        int best_j = -1;
        for (int j = 0; j < nb() && best_j < 0; ++j) {
            if (label(main_i1_, j) == 1) best_j = j;
        }
        int last_j = best_j;
        while (last_j + 1 < nb() && label(main_i1_, last_j + 1) == 1) ++last_j;
        const double centre = b0_ + ((best_j + last_j) / 2.0 + 0.5) * db;
        const double half = (last_j - best_j + 1) * db / 2 + 2 * db;
        if (curve_tip(centre - half, centre + half)) return true;
        const detail::ScalarMinimum m =
            detail::minimize_scalar([&](double b) { return -edge_at(b); }, centre - half, centre + half, 1e-13);
        beta_at_alpha_max_ = m.x;
        alpha_max_ = -m.value;
        return false;
    }

    /// The tip as a smooth maximum of the D-decomposition curve (header comment), when the region's own edge
    /// confirms it: true and alpha_max_, beta_at_alpha_max_ set, or false (a corner tip, or no local maximum of
    /// the curve in the tip's window) and nothing set.
    bool curve_tip(double beta_lo, double beta_hi) {
        const AffineCharacteristicPolynomial<double>& p = test_.polynomial();
        const int n = p.degree();
        auto point = [&](double theta) {
            const std::complex<double> z = std::polar(1.0, theta);
            std::complex<double> c0 = 0, ca = 0, cb = 0;
            for (int k = n; k >= 0; --k) {
                c0 = c0 * z + p.base(k);
                ca = ca * z + p.alpha(k);
                cb = cb * z + p.beta(k);
            }
            const double det = ca.real() * cb.imag() - ca.imag() * cb.real();
            return std::pair<double, double>{(c0.imag() * cb.real() - c0.real() * cb.imag()) / det,
                                             (c0.real() * ca.imag() - c0.imag() * ca.real()) / det};
        };
        const double pi = 3.14159265358979323846;
        const int samples = std::max(64, 16 * n);
        const double da = a1_ / na();
        const double a_lo = (main_i1_ - 1) * da, a_hi = (main_i1_ + 2) * da;
        double best_alpha = -HUGE_VAL, best_beta = 0;
        std::pair<double, double> previous = point(pi / samples), current = point(2 * pi / samples);
        for (int k = 2; k < samples; ++k) {
            const std::pair<double, double> next = point(pi * (k + 1) / samples);
            const bool peak = current.first >= previous.first && current.first >= next.first;
            if (peak && current.first > a_lo && current.first < a_hi && current.second > beta_lo &&
                current.second < beta_hi) {
                const detail::ScalarMinimum m = detail::minimize_scalar(
                    [&](double t) { return -point(t).first; }, pi * (k - 1) / samples, pi * (k + 1) / samples, 1e-15);
                const std::pair<double, double> tip = point(m.x);
                if (tip.first > best_alpha && std::isfinite(tip.second)) {
                    best_alpha = tip.first;
                    best_beta = tip.second;
                }
            }
            previous = current;
            current = next;
        }
        if (!(best_alpha > 0 && best_alpha < HUGE_VAL)) return false;
        const double edge = edge_at(best_beta);
        if (!(std::abs(edge - best_alpha) <= 1e-12 * best_alpha + 2e-14)) return false;
        alpha_max_ = edge;  // the stable side, as the edge's maximum below
        beta_at_alpha_max_ = best_beta;
        return true;
    }

    EstimatorStabilityTest test_;
    EstimatorRegionOptions options_;
    std::vector<int> labels_;
    std::vector<StableIsland> islands_;
    double a1_ = 1, b0_ = -1, b1_ = 4;
    int main_cells_ = 0, main_i1_ = -1, main_j0_ = 0, main_j1_ = -1;
    int scan_na_ = 16, scan_nb_ = 16;
    double alpha_max_ = 0, beta_at_alpha_max_ = 0;
};

/// The boundary of the main stable region with the estimator, as a closed polyline of (alpha, beta) in normalised
/// units: at alphas alpha_max sin(pi s / 2), s = 1e-6 and k / points (k = 1 .. points - 1), the ends of the
/// main region's stable beta interval (EstimatorStabilityRegion::beta_interval: the Schur-Cohn verdict of
/// EstimatorStabilityTest marched from a main-region cell and bisected to ~1e-14, i.e. the D-decomposition's
/// curves found pointwise instead of parametrically); the lower ends in increasing alpha, the tip
/// (alpha_max, beta_at_alpha_max), the upper ends in decreasing alpha, the first point repeated. The sine
/// spacing puts the points densely near the tip, where the two ends meet. Assumes one stable beta interval of the
/// main region per alpha (the region between a lower and an upper edge, as the backward difference's; where a
/// cross-section has several, the one through the scan's main cell is drawn). Stable islands are not part of it
/// (EstimatorStabilityRegion::islands). For window 1 (the backward difference) the points lie on
/// StabilityRegion's exact boundary (tests/core/test_velocity_cli.cpp). Empty when the region is empty
/// (alpha_max 0). Cost: about 2 (points + 1) x (8 beta_grid + 50) verdicts, O(degree^2) each. Throws
/// InvalidParameter naming `points` unless 8 <= points <= 10^5.
HAPTICOPT_DEFERRED
std::vector<std::pair<double, double>> estimator_region_boundary(const EstimatorStabilityRegion& region,
                                                                 int points = 256) {
    detail::require_in_range("hapticopt::estimator_region_boundary", "points", points, 8, false, 1e5,
                             "8 <= points <= 10^5");
    std::vector<std::pair<double, double>> lower, upper;
    if (!(region.alpha_max() > 0)) return lower;
    const double pi = 3.14159265358979323846;
    for (int k = 0; k < points; ++k) {
        const double s = k == 0 ? 1e-6 : static_cast<double>(k) / points;
        const double a = region.alpha_max() * std::sin(pi * s / 2);
        const std::pair<double, double> interval = region.beta_interval(a);
        if (!(interval.second > interval.first)) continue;
        lower.emplace_back(a, interval.first);
        upper.emplace_back(a, interval.second);
    }
    lower.emplace_back(region.alpha_max(), region.beta_at_alpha_max());
    lower.insert(lower.end(), upper.rbegin(), upper.rend());
    lower.push_back(lower.front());
    return lower;
}

/// An optimum with the estimator: the criterion's point, its cost (none for amax) and the main region's tip.
struct EstimatorOptimum {
    Criterion criterion = Criterion::CE2;
    double alpha = 0;
    double beta = 0;
    std::optional<double> cost;
    double alpha_max = 0;
    double beta_at_alpha_max = 0;
};

/// Options of optimal_point with an estimator.
struct EstimatorOptimumOptions {
    RegionSearchOptions search;                    ///< grids of the CEx search (region_minimum.hpp)
    double overshoot_tolerance = 1e-12;            ///< "no overshoot" means C_OV <= this (relative), (0, 1]
    double alpha_tolerance = 1e-10;                ///< bisection tolerance of the CEx+OV points, relative to alpha_max
    OptimumMethod method = OptimumMethod::newton;  ///< search of the CE0..2 points (optimal_point below); brent is
                                                   ///< the slower independent one; CEx+OV always use brent's curve
};

/// Scan grid of the main region used by OptimumMethod::newton (optimal_point with an estimator): 16 x 16 cells,
/// no islands (EstimatorStabilityRegion: a corner tip re-scanned at 40 x 40; nothing found, again at 40 x 40 and
/// 160 x 160). The optimum needs only the main region's tip (the curve's maximum) and its stable beta intervals
/// (the Schur-Cohn verdict marched and bisected), whatever the grid, once the grid resolves the region (the scan
/// re-fits its box until the region fills at least 60 % of it, so 16 cells give it about 10 in each direction);
/// the tests require alpha_max of this grid and the default one to agree to 1e-10 at smooth tips.
inline constexpr EstimatorRegionOptions kFastOptimumRegionGrid{16, 16, false};

/// OptimumMethod::newton with an estimator: a minimum found below this fraction of alpha_max is on the edge
/// alpha -> 0+, and its beta is polished there by a 1-d Newton (optimal_point).
inline constexpr double kAlphaEdge = 1e-9;

/// The optimum of amax, CE0..2 or CE0+OV..CE2+OV with the estimator over the main stable region. The backward
/// difference is optimal_point() (optimum.hpp, with options.method). Others: alpha_max from
/// EstimatorStabilityRegion; the CEx points by options.method:
///  - newton (default): the region on the kFastOptimumRegionGrid scan; a start grid of max(4, alpha_grid / 4)
///    alphas across (0, alpha_max) x max(4, beta_grid / 4) betas across the main region's beta interval
///    (6 x 4 by default; the interval's ends to 1e-3); then damped Newton (newton_search.hpp, minimize_newton_2d)
///    from the best start point on the analytic gradient estimator_energy_cost_gradient, in coordinates scaled by
///    alpha_max and that point's interval width, to a step below 1e-12 of them or the function's resolution. A
///    minimum below kAlphaEdge alpha_max lies on the edge alpha -> 0+ (gamma > 0): its beta is then minimised at
///    that alpha by minimize_newton_1d. A point outside the main region's beta interval there, or a start grid
///    without a finite cost, goes to brent's region search on the same region;
///  - brent: the region on the default 160 x 160 scan; minimize_on_region (region_minimum.hpp: coarse grid over
///    (0, alpha_max) x the main region's beta interval, then Brent over alpha with Brent over beta inside).
/// The tests require both to agree (tests/core/test_estimator_fast_optimum.cpp); measured times of both:
/// docs/benchmarks.md. The CEx+OV points (either method) as in optimum.hpp:
/// the optimal curve beta_opt(alpha) (grid + Brent over the main region's beta interval), a scan down from
/// alpha_max in `search.alpha_grid` steps to the first alpha whose curve point has C_OV <= tolerance
/// (estimator_overshoot), then bisection. Throws InvalidParameter for the OV criterion (its point is not
/// searched with an estimator) and when no scanned curve point meets the tolerance. An empty main region
/// (alpha_max = 0) gives cost +inf for the CEx criteria.
HAPTICOPT_FUNC EstimatorOptimum optimal_point(Criterion criterion, const NormalizedPlant& plant,
                                              const VelocityEstimator& estimator,
                                              const EstimatorOptimumOptions& options = {})
#if HAPTICOPT_DEFINITIONS
{
    const char* fn = "hapticopt::optimal_point";
    validate(estimator, fn);
    detail::require_in_range(fn, "overshoot_tolerance", options.overshoot_tolerance, 0.0, true, 1.0,
                             "0 < tolerance <= 1");
    detail::require_in_range(fn, "alpha_tolerance", options.alpha_tolerance, 0.0, true, 1e-2,
                             "0 < alpha_tolerance <= 0.01");
    EstimatorOptimum out;
    out.criterion = criterion;
    if (estimator.kind == VelocityEstimatorKind::backward) {
        OptimumOptions o;
        o.overshoot_tolerance = options.overshoot_tolerance;
        o.method = options.method;
        const Optimum b = optimal_point(criterion, plant, o);
        out.alpha = b.alpha;
        out.beta = b.beta;
        out.cost = b.cost;
        out.alpha_max = b.alpha_max;
        out.beta_at_alpha_max = b.beta_at_alpha_max;
        return out;
    }
    if (criterion == Criterion::Overshoot) {
        throw InvalidParameter(fn, "criterion", static_cast<double>(criterion),
                               "amax, CE0..2 or CE0+OV..CE2+OV with a velocity estimator other than backward");
    }
    // The fast method serves the CEx points; the CEx+OV points keep the nested Brent curve (their time goes to the
    // overshoot scans, and their bisection needs beta_opt only to the overshoot's resolution).
    const bool newton = options.method == OptimumMethod::newton && !requires_no_overshoot(criterion);
    const EstimatorStabilityRegion region(plant, estimator, newton ? kFastOptimumRegionGrid : EstimatorRegionOptions{});
    out.alpha_max = region.alpha_max();
    out.beta_at_alpha_max = region.beta_at_alpha_max();
    if (criterion == Criterion::AlphaMax) {
        out.alpha = out.alpha_max;
        out.beta = out.beta_at_alpha_max;
        return out;
    }
    if (!(out.alpha_max > 0) && !requires_no_overshoot(criterion)) {  // no main region: no CEx point
        out.cost = HUGE_VAL;
        return out;
    }
    const int index = *energy_index(criterion);
    const SampledPlant<double> sampled(plant);
    auto cost = [&](double a, double b) {
        const EnergyCosts c = estimator_energy_costs(sampled, estimator, a, b);
        return index == 0 ? c.ce0 : index == 1 ? c.ce1 : c.ce2;
    };
    auto interval = [&](double a) { return region.beta_interval(a); };
    auto gradient = [&](double a, double b) { return estimator_energy_cost_gradient(sampled, estimator, a, b, index); };
    const int fast_alphas = std::max(4, options.search.alpha_grid / 4);
    const int fast_betas = std::max(4, options.search.beta_grid / 4);
    if (!requires_no_overshoot(criterion) && newton) {
        // Start grid of fast_alphas x fast_betas cell centres over the main region, then damped Newton
        // (newton_search.hpp) in coordinates scaled by alpha_max and the best start's beta interval width.
        // The start grid's intervals need their ends to a small fraction of a grid cell only: 1e-3 (the march
        // brackets them to a quarter of a scan cell first).
        double best_a = out.alpha_max / 2, best_b = 0, best_width = 1, best_value = HUGE_VAL;
        for (int i = 0; i < fast_alphas; ++i) {
            const double a = (i + 0.5) * out.alpha_max / fast_alphas;
            const auto [lo, hi] = region.beta_interval(a, 1e-3);
            if (!(hi > lo)) continue;
            for (int j = 0; j < fast_betas; ++j) {
                const double b = lo + (j + 0.5) * (hi - lo) / fast_betas;
                const double v = cost(a, b);
                if (v < best_value) {
                    best_value = v;
                    best_a = a;
                    best_b = b;
                    best_width = hi - lo;
                }
            }
        }
        // No finite start cost (a region thinner than the start grid resolves): the region search below.
        if (std::isfinite(best_value)) {
            auto fg = [&](double a, double b) {
                if (!(a > 0 && a < out.alpha_max)) return detail::ValueAndGradient2{HUGE_VAL, 0, 0};
                const EnergyCostGradient g = gradient(a, b);
                return detail::ValueAndGradient2{g.value, g.d_alpha, g.d_beta};
            };
            detail::NewtonMinimum2 m = detail::minimize_newton_2d(fg, best_a, best_b, out.alpha_max, best_width);
            // The steps are bounded in alpha only; a point outside the main region's beta interval (another stable
            // region, or within the ends' 1e-6 of them) leaves the answer to the region search below.
            const auto [lo, hi] = region.beta_interval(m.x, 1e-6);
            if (m.y > lo && m.y < hi) {
                if (m.x < kAlphaEdge * out.alpha_max) {
                    // The minimum lies on the edge alpha -> 0+ (with gamma > 0), where the damped 2-d steps move
                    // along alpha only: beta's minimum at that alpha by the 1-d Newton.
                    const double a = m.x;
                    auto fd = [&](double b) {
                        const EnergyCostGradient g = gradient(a, b);
                        return detail::ValueAndDerivative{g.value, g.d_beta};
                    };
                    const detail::NewtonMinimum2 e = detail::minimize_newton_1d(fd, m.y, lo, hi);
                    if (e.value < m.value) m.y = e.x;
                }
                out.alpha = m.x;
                out.beta = m.y;
                out.cost = cost(m.x, m.y);
                return out;
            }
        }
    }
    if (!requires_no_overshoot(criterion)) {
        const RegionMinimum m = minimize_on_region(cost, 0.0, out.alpha_max, interval, options.search);
        out.alpha = m.alpha;
        out.beta = m.beta;
        out.cost = m.value;
        return out;
    }
    OvershootOptions ov;
    ov.tolerance = options.overshoot_tolerance;
    auto curve = [&](double a) { return detail::minimize_over_beta(cost, interval, a, options.search.beta_grid); };
    auto no_overshoot = [&](double a) {
        const detail::ScalarMinimum m = curve(a);
        return std::isfinite(m.value) && estimator_overshoot(sampled, estimator, a, m.x, ov).within_tolerance;
    };
    const int n = options.search.alpha_grid;
    double without = -1, with = out.alpha_max;
    for (int i = 1; i < n; ++i) {
        const double a = out.alpha_max * (1 - static_cast<double>(i) / n);
        if (no_overshoot(a)) {
            without = a;
            break;
        }
        with = a;
    }
    if (without < 0) {
        throw InvalidParameter(fn, "overshoot_tolerance", options.overshoot_tolerance,
                               "a tolerance met somewhere on the optimal curve (none found on the scan)");
    }
    while (with - without > options.alpha_tolerance * out.alpha_max) {
        const double mid = (with + without) / 2;
        (no_overshoot(mid) ? without : with) = mid;
    }
    const detail::ScalarMinimum m = curve(without);
    out.alpha = without;
    out.beta = m.x;
    out.cost = m.value;
    return out;
}
#else
    ;
#endif

}  // namespace hapticopt
