// SPDX-License-Identifier: Apache-2.0
// Stability of the sampled-data wall: all roots of the characteristic polynomial
// (characteristic_polynomial.hpp) strictly inside the unit circle.
//
// The verdict is the Schur-Cohn recursion on the polynomial's coefficients (schur_cohn.hpp), recomputed
// in long double wherever its margin in double is below 1e-4 (loop_verdict in loop_schur_form.hpp).
// Rounding of the coefficients and of the recursion can then move the decision only within ~1e-13 of the
// boundary in (alpha, beta), relative to max(1, |alpha|, |beta|): tested at 1e-10 on both sides of the
// exact d = 0 boundary point alpha_max = 12 - 8 sqrt(2), beta = 2 sqrt(2) - 2, and by the stress test
// (tests/stress, 10^6 random and adversarial sets including negative damping and d up to 50) against
// long double eigenvalues of the loop matrix with a band of 3x that accuracy. The report adds the
// Schur-Cohn margin and the spectral radius from the loop matrix's eigenvalues as a second opinion.
#pragma once

#include "config.hpp"
#include "loop_schur_form.hpp"

namespace hapticopt {

struct StabilityReport {
    bool stable = false;  ///< Schur-Cohn verdict (and alpha + gamma > 0)
    double margin = 0;    ///< min (1 - |k_i|) of the deciding Schur-Cohn recursion (schur_cohn.hpp; <= 0 unstable)
    double spectral_radius = 0;  ///< max |eigenvalue| of the loop transition M
    bool refined = false;        ///< verdict recomputed in long double (|margin| < 1e-4 in double)
};

HAPTICOPT_FUNC StabilityReport stability(const NormalizedPlant& plant, const NormalizedGains& gains)
#if HAPTICOPT_DEFINITIONS
{
    validate(gains, "hapticopt::stability");
    const SampledPlant<double> sampled(plant);
    StabilityReport report;
    const LoopVerdict<double> verdict = loop_verdict(sampled, gains.alpha, gains.beta);
    report.stable = verdict.stable;
    report.margin = verdict.margin;
    report.refined = verdict.refined;
    report.spectral_radius =
        loop_schur_form(make_closed_loop(sampled, gains.alpha, gains.beta).transition).spectral_radius;
    return report;
}
#else
    ;
#endif

HAPTICOPT_FUNC bool is_stable(const NormalizedPlant& plant, const NormalizedGains& gains)
#if HAPTICOPT_DEFINITIONS
{
    validate(gains, "hapticopt::is_stable");
    return loop_is_stable(SampledPlant<double>(plant), gains.alpha, gains.beta);
}
#else
    ;
#endif

}  // namespace hapticopt
