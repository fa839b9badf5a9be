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
  Matrix3<Scalar> exp;                 ///< exp(A h)
  std::array<Matrix3<Scalar>, 3> gramian;  ///< Z_0(h), Z_1(h), Z_2(h)
};

/// exp(A h) and Z_p(h), p = 0..2, for symmetric Q; h >= 0. The end-to-end accuracy of the costs
/// built on it is measured in tests/core/energy_costs_test.cpp (long double and time-stepping
/// references); the doubling steps multiply by exp(A h0), whose norm stays near 1 here.
template <typename Scalar>
ExponentialIntegrals<Scalar> exponential_integrals(const Matrix3<Scalar>& A,
                                                   const Matrix3<Scalar>& Q, Scalar h) {
  using std::ceil;
  using std::log2;
  using std::max;
  const Scalar norm = A.cwiseAbs().colwise().sum().maxCoeff() * h;
  int doublings = 0;
  if (norm > Scalar(0.5)) doublings = static_cast<int>(ceil(log2(norm / Scalar(0.5))));
  Scalar h0 = std::ldexp(h, -doublings);

  // Taylor series on [0, h0].
  const Scalar eps = std::numeric_limits<Scalar>::epsilon();
  Matrix3<Scalar> term = Matrix3<Scalar>::Identity();  // (A h0)^n / n!
  Matrix3<Scalar> phi = term;
  Matrix3<Scalar> d = Q;  // D_n h0^n / n!
  std::array<Matrix3<Scalar>, 3> z;
  for (int p = 0; p < 3; ++p) z[static_cast<std::size_t>(p)] = d / Scalar(p + 1);
  for (int n = 1; n < 60; ++n) {
    term = term * A * (h0 / Scalar(n));
    d = (A.transpose() * d + d * A) * (h0 / Scalar(n));
    phi += term;
    for (int p = 0; p < 3; ++p) z[static_cast<std::size_t>(p)] += d / Scalar(n + p + 1);
    const Scalar size = max(term.cwiseAbs().maxCoeff(), d.cwiseAbs().maxCoeff());
    const Scalar scale = max(Scalar(1), z[0].cwiseAbs().maxCoeff());
    if (size <= eps * scale * Scalar(1e-3)) break;
  }
  for (int p = 0; p < 3; ++p) z[static_cast<std::size_t>(p)] *= std::pow(h0, Scalar(p + 1));

  // Doubling.
  for (int i = 0; i < doublings; ++i) {
    const Matrix3<Scalar> s0 = z[0];
    const Matrix3<Scalar> s1 = z[1] + h0 * z[0];
    const Matrix3<Scalar> s2 = z[2] + Scalar(2) * h0 * z[1] + h0 * h0 * z[0];
    z[0] += phi.transpose() * s0 * phi;
    z[1] += phi.transpose() * s1 * phi;
    z[2] += phi.transpose() * s2 * phi;
    phi = phi * phi;
    h0 *= Scalar(2);
  }
  return ExponentialIntegrals<Scalar>{phi, z};
}

/// exp(A h) alone, by the same scaling, Taylor series and squaring.
template <typename Scalar>
Matrix3<Scalar> exponential(const Matrix3<Scalar>& A, Scalar h) {
  const Scalar norm = A.cwiseAbs().colwise().sum().maxCoeff() * h;
  int squarings = 0;
  if (norm > Scalar(0.5)) squarings = static_cast<int>(std::ceil(std::log2(norm / Scalar(0.5))));
  const Matrix3<Scalar> scaled = A * std::ldexp(h, -squarings);
  Matrix3<Scalar> term = Matrix3<Scalar>::Identity();
  Matrix3<Scalar> result = term;
  for (int n = 1; n < 60 && term.cwiseAbs().maxCoeff() > Scalar(0); ++n) {
    term = term * scaled / Scalar(n);
    result += term;
    if (term.cwiseAbs().maxCoeff() <= std::numeric_limits<Scalar>::epsilon() * Scalar(1e-3)) break;
  }
  for (int i = 0; i < squarings; ++i) result = result * result;
  return result;
}

}  // namespace hapticopt
