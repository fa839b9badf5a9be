// SPDX-License-Identifier: Apache-2.0
// The characteristic polynomial of the sampled-data loop, which is affine in the wall gains:
//
//   p(z) = P_0(z) + alpha P_alpha(z) + beta P_beta(z).
//
// With Phi = exp(A_p) the plant's one-period transition, g_a and g_b the responses (x, x') at the
// end of the period to a unit force acting on the first and second segment (g_a = 0 for integer
// d), D(z) = det(z I - Phi) and q(z) = [z - Phi_22, Phi_12] (g_a + z g_b), the loop
// x = P(z) (F - f) closed by C(z) = alpha + beta (1 - 1/z) and z^-n gives
//
//   p(z) = z^(n+2) D(z) + q(z) ((alpha + beta) z - beta),     degree n + 4,
//
// divided by z for integer d (then q(0) = 0), degree n + 3. Its roots are the non-zero
// eigenvalues of the loop transition M (closed_loop.hpp); the tests check this.
#pragma once

#include <Eigen/Core>

#include "sampled_plant.hpp"

namespace hapticopt {

template <typename Scalar>
struct AffineCharacteristicPolynomial {
  using Coefficients = Eigen::Matrix<Scalar, Eigen::Dynamic, 1>;  ///< ascending powers of z
  Coefficients base;    ///< P_0
  Coefficients alpha;   ///< P_alpha
  Coefficients beta;    ///< P_beta

  int degree() const { return static_cast<int>(base.size()) - 1; }

  /// Coefficients (ascending) of p(z) at the given gains; leading coefficient 1.
  Coefficients at(Scalar a, Scalar b) const { return base + a * alpha + b * beta; }
};

template <typename Scalar>
AffineCharacteristicPolynomial<Scalar> characteristic_polynomial(
    const SampledPlant<Scalar>& plant) {
  using Vec2 = Eigen::Matrix<Scalar, 2, 1>;
  using Mat2 = Eigen::Matrix<Scalar, 2, 2>;
  Mat2 phi;
  Vec2 ga = Vec2::Zero();
  Vec2 gb;
  if (plant.segment_count() == 1) {
    const auto& e = plant.segment(0).exp;
    phi = e.template topLeftCorner<2, 2>();
    gb = -e.template block<2, 1>(0, 2);
  } else {
    const auto& ea = plant.segment(0).exp;
    const auto& eb = plant.segment(1).exp;
    const Mat2 phi_b = eb.template topLeftCorner<2, 2>();
    phi = phi_b * ea.template topLeftCorner<2, 2>();
    ga = -phi_b * ea.template block<2, 1>(0, 2);
    gb = -eb.template block<2, 1>(0, 2);
  }
  // q(z) = q0 + q1 z + q2 z^2
  const Scalar q2 = gb(0);
  const Scalar q1 = ga(0) - phi(1, 1) * gb(0) + phi(0, 1) * gb(1);
  const Scalar q0 = -phi(1, 1) * ga(0) + phi(0, 1) * ga(1);
  const Scalar d1 = -(phi(0, 0) + phi(1, 1));
  const Scalar d0 = phi(0, 0) * phi(1, 1) - phi(0, 1) * phi(1, 0);

  const int n = plant.whole_delay();
  const int degree = n + 4;
  using Coefficients = typename AffineCharacteristicPolynomial<Scalar>::Coefficients;
  Coefficients p0 = Coefficients::Zero(degree + 1);
  Coefficients pa = Coefficients::Zero(degree + 1);
  Coefficients pb = Coefficients::Zero(degree + 1);
  p0(n + 2) = d0;
  p0(n + 3) = d1;
  p0(n + 4) = 1;
  // alpha: q(z) z ; beta: q(z) (z - 1)
  pa(1) = q0;
  pa(2) = q1;
  pa(3) = q2;
  pb(0) = -q0;
  pb(1) = q0 - q1;
  pb(2) = q1 - q2;
  pb(3) = q2;
  if (plant.segment_count() == 1) {  // q0 = 0: divide by z
    return {p0.tail(degree), pa.tail(degree), pb.tail(degree)};
  }
  return {p0, pa, pb};
}

}  // namespace hapticopt
