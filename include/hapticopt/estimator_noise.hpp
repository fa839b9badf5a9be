// SPDX-License-Identifier: Apache-2.0
// The force noise that position quantisation causes through the wall's velocity estimator
// (velocity_estimator.hpp, the loop of estimator_loop.hpp; normalised units m = T = 1).
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
#pragma once

#include <cmath>
#include <complex>
#include <limits>

#include "config.hpp"
#include "errors.hpp"
#include "estimator_loop.hpp"
#include "estimator_stability.hpp"
#include "loop_schur_form.hpp"
#include "parameters.hpp"
#include "stein_equation.hpp"
#include "estimator_types.hpp"

namespace hapticopt {

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

}  // namespace hapticopt
