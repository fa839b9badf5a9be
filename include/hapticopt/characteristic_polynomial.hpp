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

#include <array>
#include <cstddef>

#include <Eigen/Core>

#include "sampled_plant.hpp"

namespace hapticopt {

template <typename Scalar>
struct AffineCharacteristicPolynomial {
    using Coefficients = Eigen::Matrix<Scalar, Eigen::Dynamic, 1>;  ///< ascending powers of z
    Coefficients base;                                              ///< P_0
    Coefficients alpha;                                             ///< P_alpha
    Coefficients beta;                                              ///< P_beta

    int degree() const { return static_cast<int>(base.size()) - 1; }

    /// Coefficients (ascending) of p(z) at the given gains; leading coefficient 1.
    Coefficients at(Scalar a, Scalar b) const { return base + a * alpha + b * beta; }
};

/// The plant's two factors of p(z) (header comment): D(z) = det(z I - Phi) = d0 + d1 z + z^2 and
/// q(z) = [z - Phi_22, Phi_12] (g_a + z g_b) = q0 + q1 z + q2 z^2, from the segment transitions exp(A length_s)
/// (one segment for integer d, two otherwise). 2x2 products written out.
template <typename Scalar>
struct PlantPolynomialFactors {
    int whole_delay = 0;        ///< n
    std::array<Scalar, 3> q{};  ///< q0, q1, q2 (q0 = 0 for integer d)
    std::array<Scalar, 2> d{};  ///< d0, d1 (D is monic)
};

template <typename Scalar>
PlantPolynomialFactors<Scalar> plant_polynomial_factors(int whole_delay, int segment_count, const Matrix3<Scalar>& ea,
                                                        const Matrix3<Scalar>& eb) {
    Scalar phi[2][2];
    Scalar ga[2] = {0, 0};
    Scalar gb[2];
    if (segment_count == 1) {
        for (int i = 0; i < 2; ++i) {
            for (int j = 0; j < 2; ++j) phi[i][j] = ea(i, j);
            gb[i] = -ea(i, 2);
        }
    } else {
        // phi = Phi_b Phi_a (top-left 2x2 blocks), g_a = -Phi_b a_3, g_b = -b_3 (a_3, b_3: column 2, rows 0..1)
        for (int i = 0; i < 2; ++i) {
            for (int j = 0; j < 2; ++j) phi[i][j] = eb(i, 0) * ea(0, j) + eb(i, 1) * ea(1, j);
            ga[i] = -(eb(i, 0) * ea(0, 2) + eb(i, 1) * ea(1, 2));
            gb[i] = -eb(i, 2);
        }
    }
    PlantPolynomialFactors<Scalar> f;
    f.whole_delay = whole_delay;
    f.q[2] = gb[0];
    f.q[1] = ga[0] - phi[1][1] * gb[0] + phi[0][1] * gb[1];
    f.q[0] = -phi[1][1] * ga[0] + phi[0][1] * ga[1];
    f.d[1] = -(phi[0][0] + phi[1][1]);
    f.d[0] = phi[0][0] * phi[1][1] - phi[0][1] * phi[1][0];
    return f;
}

/// The factors from the plant transitions alone (plant_transitions, sampled_plant.hpp).
template <typename Scalar>
PlantPolynomialFactors<Scalar> plant_polynomial_factors(const PlantTransitions<Scalar>& t) {
    return plant_polynomial_factors<Scalar>(t.whole_delay, t.segment_count, t.exp[0],
                                            t.exp[static_cast<std::size_t>(t.segment_count - 1)]);
}

/// p(z) from the plant's segment transitions exp(A length_s) (one segment for integer d, two
/// otherwise) and the whole delay n.
template <typename Scalar>
AffineCharacteristicPolynomial<Scalar> characteristic_polynomial(int whole_delay, int segment_count,
                                                                 const Matrix3<Scalar>& ea, const Matrix3<Scalar>& eb) {
    const PlantPolynomialFactors<Scalar> f = plant_polynomial_factors<Scalar>(whole_delay, segment_count, ea, eb);
    const Scalar q0 = f.q[0], q1 = f.q[1], q2 = f.q[2], d0 = f.d[0], d1 = f.d[1];

    const int n = whole_delay;
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
    if (segment_count == 1) {  // q0 = 0: divide by z
        return {p0.tail(degree), pa.tail(degree), pb.tail(degree)};
    }
    return {p0, pa, pb};
}

template <typename Scalar>
AffineCharacteristicPolynomial<Scalar> characteristic_polynomial(const SampledPlant<Scalar>& plant) {
    const int count = plant.segment_count();
    return characteristic_polynomial<Scalar>(plant.whole_delay(), count, plant.segment(0).exp,
                                             plant.segment(count - 1).exp);
}

/// p(z) from the plant transitions alone (plant_transitions, sampled_plant.hpp).
template <typename Scalar>
AffineCharacteristicPolynomial<Scalar> characteristic_polynomial(const PlantTransitions<Scalar>& t) {
    return characteristic_polynomial<Scalar>(t.whole_delay, t.segment_count, t.exp[0],
                                             t.exp[static_cast<std::size_t>(t.segment_count - 1)]);
}

}  // namespace hapticopt
