// SPDX-License-Identifier: Apache-2.0
// Exact discretisation of a linear ODE over one interval: the matrix exponential and the
// time-weighted Gramian integrals used by the energy criteria.
//
//   Phi(h)  = exp(A h)
//   Z_p(h)  = integral_0^h s^p exp(A^T s) Q exp(A s) ds,   p = 0, 1, 2   (Q symmetric)
//
// Method (Van Loan, "Computing integrals involving the matrix exponential", IEEE TAC 23(3),
// 1978, gives the integrals; we evaluate them without the block-matrix exponential):
//  1. scaling: h0 = h / 2^s with ||A||_1 h0 <= 1/2;
//  2. Taylor series on [0, h0]: with D_0 = Q, D_{n+1} = A^T D_n + D_n A (the derivatives of
//     exp(A^T s) Q exp(A s) at s = 0),  Z_p(h0) = sum_n D_n h0^(n+p+1) / (n! (n+p+1)).
//     The terms decay like 1/n! (||A h0|| <= 1/2), so the series is summed to machine precision;
//  3. doubling s times:  Z_p(2h) = Z_p(h) + Phi(h)^T [ sum_q C(p,q) h^(p-q) Z_q(h) ] Phi(h),
//     Phi(2h) = Phi(h)^2  (every term is a sum of positive-semidefinite parts for Q >= 0, so no
//     cancellation).
// Cost: O(3^3 (terms + s)) flops for a 3x3 A; it runs once per plant, not per gain pair.
#pragma once

#include <Eigen/Core>
#include <array>
#include <cmath>
#include <limits>

namespace hapticopt {

template <typename Scalar>
using Matrix3 = Eigen::Matrix<Scalar, 3, 3>;

template <typename Scalar>
struct ExponentialIntegrals {
    Matrix3<Scalar> exp;                     ///< exp(A h)
    std::array<Matrix3<Scalar>, 3> gramian;  ///< Z_0(h), Z_1(h), Z_2(h)
};

namespace detail {

// 3x3 products and norms written out entry by entry (c_ij = sum_k a_ik b_kj): the same arithmetic as
// Eigen's fixed-size products, at a fraction of their instantiation cost in every translation unit.

/// a b
template <typename Scalar>
Matrix3<Scalar> mul3(const Matrix3<Scalar>& a, const Matrix3<Scalar>& b) {
    Matrix3<Scalar> c;
    for (int j = 0; j < 3; ++j) {
        for (int i = 0; i < 3; ++i) c(i, j) = a(i, 0) * b(0, j) + a(i, 1) * b(1, j) + a(i, 2) * b(2, j);
    }
    return c;
}

/// a^T b
template <typename Scalar>
Matrix3<Scalar> mul3_tn(const Matrix3<Scalar>& a, const Matrix3<Scalar>& b) {
    Matrix3<Scalar> c;
    for (int j = 0; j < 3; ++j) {
        for (int i = 0; i < 3; ++i) c(i, j) = a(0, i) * b(0, j) + a(1, i) * b(1, j) + a(2, i) * b(2, j);
    }
    return c;
}

/// p^T s p
template <typename Scalar>
Matrix3<Scalar> congruence3(const Matrix3<Scalar>& p, const Matrix3<Scalar>& s) {
    return mul3_tn(p, mul3(s, p));
}

/// ||a||_1 = max_j sum_i |a_ij|
template <typename Scalar>
Scalar norm1_3(const Matrix3<Scalar>& a) {
    using std::abs;
    Scalar best = 0;
    for (int j = 0; j < 3; ++j) {
        const Scalar s = abs(a(0, j)) + abs(a(1, j)) + abs(a(2, j));
        if (s > best) best = s;
    }
    return best;
}

/// max_ij |a_ij|
template <typename Scalar>
Scalar max_abs3(const Matrix3<Scalar>& a) {
    using std::abs;
    Scalar best = 0;
    for (int k = 0; k < 9; ++k) {
        if (abs(a.data()[k]) > best) best = abs(a.data()[k]);
    }
    return best;
}

/// a += f b
template <typename Scalar>
void add_scaled3(Matrix3<Scalar>& a, Scalar f, const Matrix3<Scalar>& b) {
    for (int k = 0; k < 9; ++k) a.data()[k] += f * b.data()[k];
}

}  // namespace detail

/// exp(A h) and Z_p(h), p = 0..2, for symmetric Q; h >= 0. The end-to-end accuracy of the costs
/// built on it is measured in tests/core/test_energy_costs.cpp (long double and time-stepping
/// references); the doubling steps multiply by exp(A h0), whose norm stays near 1 here.
template <typename Scalar>
ExponentialIntegrals<Scalar> exponential_integrals(const Matrix3<Scalar>& A, const Matrix3<Scalar>& Q, Scalar h) {
    using std::ceil;
    using std::log2;
    using std::max;
    const Scalar norm = detail::norm1_3(A) * h;
    int doublings = 0;
    if (norm > Scalar(0.5)) doublings = static_cast<int>(ceil(log2(norm / Scalar(0.5))));
    Scalar h0 = std::ldexp(h, -doublings);

    // Taylor series on [0, h0].
    const Scalar eps = std::numeric_limits<Scalar>::epsilon();
    Matrix3<Scalar> term = Matrix3<Scalar>::Identity();  // (A h0)^n / n!
    Matrix3<Scalar> phi = term;
    Matrix3<Scalar> d = Q;  // D_n h0^n / n!
    std::array<Matrix3<Scalar>, 3> z;
    for (int p = 0; p < 3; ++p) {
        z[static_cast<std::size_t>(p)].setZero();
        detail::add_scaled3(z[static_cast<std::size_t>(p)], Scalar(1) / Scalar(p + 1), d);
    }
    for (int n = 1; n < 60; ++n) {
        const Scalar f = h0 / Scalar(n);
        term = detail::mul3(term, A);
        term *= f;
        const Matrix3<Scalar> da = detail::mul3(d, A);
        d = detail::mul3_tn(A, d);
        d += da;
        d *= f;
        phi += term;
        for (int p = 0; p < 3; ++p)
            detail::add_scaled3(z[static_cast<std::size_t>(p)], Scalar(1) / Scalar(n + p + 1), d);
        const Scalar size = max(detail::max_abs3(term), detail::max_abs3(d));
        const Scalar scale = max(Scalar(1), detail::max_abs3(z[0]));
        if (size <= eps * scale * Scalar(1e-3)) break;
    }
    for (int p = 0; p < 3; ++p) z[static_cast<std::size_t>(p)] *= std::pow(h0, Scalar(p + 1));

    // Doubling.
    for (int i = 0; i < doublings; ++i) {
        const Matrix3<Scalar> s0 = z[0];
        Matrix3<Scalar> s1 = z[1];
        detail::add_scaled3(s1, h0, z[0]);
        Matrix3<Scalar> s2 = z[2];
        detail::add_scaled3(s2, Scalar(2) * h0, z[1]);
        detail::add_scaled3(s2, h0 * h0, z[0]);
        z[0] += detail::congruence3(phi, s0);
        z[1] += detail::congruence3(phi, s1);
        z[2] += detail::congruence3(phi, s2);
        phi = detail::mul3(phi, phi);
        h0 *= Scalar(2);
    }
    return ExponentialIntegrals<Scalar>{phi, z};
}

/// exp(A h) alone, by the same scaling, Taylor series and squaring.
template <typename Scalar>
Matrix3<Scalar> exponential(const Matrix3<Scalar>& A, Scalar h) {
    const Scalar norm = detail::norm1_3(A) * h;
    int squarings = 0;
    if (norm > Scalar(0.5)) squarings = static_cast<int>(std::ceil(std::log2(norm / Scalar(0.5))));
    const Scalar scale = std::ldexp(h, -squarings);
    Matrix3<Scalar> term = Matrix3<Scalar>::Identity();
    Matrix3<Scalar> result = term;
    for (int n = 1; n < 60 && detail::max_abs3(term) > Scalar(0); ++n) {
        term = detail::mul3(term, A);
        term *= scale / Scalar(n);
        result += term;
        if (detail::max_abs3(term) <= std::numeric_limits<Scalar>::epsilon() * Scalar(1e-3)) break;
    }
    for (int i = 0; i < squarings; ++i) result = detail::mul3(result, result);
    return result;
}

/// exp(A t) in closed form for the free mass with damping, A = [[0, 1, 0], [0, -delta, -1], [0, 0, 0]] (the
/// normalised plant's augmented matrix with gamma = 0, sampled_plant.hpp):
///   exp(A t) = [[1, E1, -E2], [0, e^(-delta t), -E1], [0, 0, 1]],
///   E1 = integral_0^t e^(-delta u) du = -expm1(-delta t) / delta,   E2 = integral_0^t E1 = (t - E1) / delta,
/// E1 = t and E2 = t^2 / 2 at delta = 0. E2's difference cancels for small delta t: there (|delta t| < 1) the
/// series E2 = t^2 sum_k (-delta t)^k / (k + 2)!, summed until its terms fall below the rounding; elsewhere
/// t - E1 >= t / e loses at most a factor e. A few roundings per entry, against the series' error growing
/// with its 2^s squarings (exponential above). Expects delta >= 0, t >= 0.
template <typename Scalar>
Matrix3<Scalar> free_mass_exponential(Scalar delta, Scalar t) {
    using std::exp;
    using std::expm1;
    const Scalar x = delta * t;
    Scalar e1, e2;
    if (x < Scalar(1)) {
        Scalar term = Scalar(1) / Scalar(2), sum = term;  // x^k / (k + 2)! with alternating sign
        Scalar series1 = Scalar(1), term1 = Scalar(1);    // E1 / t = sum_k (-x)^k / (k + 1)!
        for (int k = 1; k < 40; ++k) {
            term *= -x / Scalar(k + 2);
            term1 *= -x / Scalar(k + 1);
            sum += term;
            series1 += term1;
            if (std::abs(term1) <= std::numeric_limits<Scalar>::epsilon() * Scalar(1e-3)) break;
        }
        e1 = t * series1;
        e2 = t * t * sum;
    } else {
        e1 = -expm1(-x) / delta;
        e2 = (t - e1) / delta;
    }
    Matrix3<Scalar> m;
    m << Scalar(1), e1, -e2, Scalar(0), exp(-x), -e1, Scalar(0), Scalar(0), Scalar(1);
    return m;
}

}  // namespace hapticopt
