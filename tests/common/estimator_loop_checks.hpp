// SPDX-License-Identifier: Apache-2.0
// Two ways the tests judge a loop with the library's velocity estimator: the library's own loop matrix (its spectral
// radius, hapticopt::stability) and the independent time-stepping simulation (loop_simulation.hpp) given the same
// estimator.
#pragma once

#include <hapticopt/hapticopt.hpp>

#include "common/loop_simulation.hpp"

namespace estimator_loop_checks {

// The spectral radius of the loop matrix with gains (alpha, beta), the estimator e.
inline double radius(const hapticopt::NormalizedPlant& plant, const hapticopt::VelocityEstimator& e, double alpha,
                     double beta) {
    const hapticopt::NormalizedGains g{alpha, beta};
    return e.kind == hapticopt::VelocityEstimatorKind::backward ? hapticopt::stability(plant, g).spectral_radius
                                                                : hapticopt::stability(plant, g, e).spectral_radius;
}

// loop_simulation::excursion_ratio with the library's estimator e.
inline double excursion_ratio(double m, double K, double B, double T, double delay_periods,
                              const hapticopt::VelocityEstimator& e, int ticks) {
    loop_simulation::Velocity v;
    if (e.kind == hapticopt::VelocityEstimatorKind::lowpass) v = {loop_simulation::Estimator::LowPass, e.cutoff, 1};
    if (e.kind == hapticopt::VelocityEstimatorKind::window) v = {loop_simulation::Estimator::Window, 0.0, e.window};
    return loop_simulation::excursion_ratio(m, K, B, T, delay_periods, v, ticks);
}

}  // namespace estimator_loop_checks
