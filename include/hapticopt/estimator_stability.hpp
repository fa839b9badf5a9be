// SPDX-License-Identifier: Apache-2.0
// Stability of the wall with its velocity estimator (velocity_estimator.hpp, the loop of estimator_loop.hpp).
//
// Stability: the characteristic polynomial. With p(z) = P_0 + alpha P_alpha + beta P_beta of the backward
// loop (characteristic_polynomial.hpp; P_alpha = q(z) z, P_beta = q(z)(z - 1)) the controller
// alpha + beta (1 - 1/z) becomes alpha + beta B(1/z) / A(1/z); multiplying by At(z) = z^L A(1/z),
// L = max(nb - 1, na), and writing Bt(z) = z^L B(1/z):
//   p_est(z) = P_0 At + alpha P_alpha At + beta P_alpha Bt,
// (for the backward difference p_est = z p: one extra root at 0). Schur-Cohn on p_est in double, recomputed
// in long double where its margin is below 1e-4, as loop_verdict does (loop_schur_form.hpp). The spectral
// radius reported is the largest eigenvalue modulus of the loop matrix (complex Schur form).
#pragma once

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <limits>

#include "characteristic_polynomial.hpp"
#include "config.hpp"
#include "estimator_loop.hpp"
#include "loop_schur_form.hpp"
#include "parameters.hpp"
#include "sampled_plant.hpp"
#include "schur_cohn.hpp"
#include "stability.hpp"
#include "estimator_types.hpp"

namespace hapticopt {

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

/// The estimator's transfer in z, D(z) T = Bt(z) / At(z) with At monic of degree l = max(nb - 1, na) (ascending
/// coefficients): the backward difference gives At = z, Bt = z - 1.
template <typename Scalar>
struct EstimatorTransferPolynomials {
    Eigen::Matrix<Scalar, Eigen::Dynamic, 1> at;
    Eigen::Matrix<Scalar, Eigen::Dynamic, 1> bt;
};

template <typename Scalar>
EstimatorTransferPolynomials<Scalar> estimator_transfer_polynomials(const VelocityEstimator& estimator) {
    using Coefficients = Eigen::Matrix<Scalar, Eigen::Dynamic, 1>;
    const EstimatorCoefficients<Scalar> co = estimator_coefficients<Scalar>(estimator);
    const int nb = static_cast<int>(co.b.size());
    const int na = static_cast<int>(co.a.size());
    const int l = std::max(nb - 1, na);
    EstimatorTransferPolynomials<Scalar> t{Coefficients::Zero(l + 1), Coefficients::Zero(l + 1)};
    t.at(l) = 1;
    for (int k = 1; k <= na; ++k) t.at(l - k) = -co.a[static_cast<std::size_t>(k - 1)];
    for (int i = 0; i < nb; ++i) t.bt(l - i) = co.b[static_cast<std::size_t>(i)];
    return t;
}

/// p_est(z) = P_0 At + alpha P_alpha At + beta P_alpha Bt (header comment) from the backward loop's p(z).
template <typename Scalar>
AffineCharacteristicPolynomial<Scalar> estimator_characteristic_polynomial(
    const AffineCharacteristicPolynomial<Scalar>& base, const VelocityEstimator& estimator) {
    const EstimatorTransferPolynomials<Scalar> t = estimator_transfer_polynomials<Scalar>(estimator);
    AffineCharacteristicPolynomial<Scalar> p;
    p.base = detail::poly_product(base.base, t.at);
    p.alpha = detail::poly_product(base.alpha, t.at);
    p.beta = detail::poly_product(base.alpha, t.bt);
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

}  // namespace hapticopt
