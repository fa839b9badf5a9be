// Stability of the sampled-data wall: all roots of the characteristic polynomial
// (characteristic_polynomial.hpp) strictly inside the unit circle.
//
// The verdict is the Schur-Cohn recursion on the polynomial's coefficients (schur_cohn.hpp): exact
// for the computed coefficients, so it can only be wrong where rounding of those coefficients
// (~1e-16 relative) moves a root across the unit circle, i.e. within ~1e-13 of the boundary in
// (alpha, beta) for the paper's range (tested at 1e-10 on both sides of the exact d = 0 boundary
// point alpha_max = 12 - 8 sqrt(2), beta = 2 sqrt(2) - 2). Outside that range, with negative damping
// (beta < 0), the stress test (tests/stress) measured verdict errors up to ~4e-12 in (alpha, beta)
// against long-double eigenvalues (1e6 random and adversarial sets). The report adds the Schur-Cohn margin
// and the spectral radius from the loop matrix's eigenvalues as an independent second opinion.
#pragma once

#include "loop_schur_form.hpp"

namespace hapticopt {

struct StabilityReport {
  bool stable = false;           ///< Schur-Cohn verdict (and alpha + gamma > 0)
  double margin = 0;             ///< min (1 - |k_i|) of the Schur-Cohn recursion
  double spectral_radius = 0;    ///< max |eigenvalue| of the loop transition M
};

inline StabilityReport stability(const NormalizedPlant& plant, const NormalizedGains& gains) {
  validate(gains, "hapticopt::stability");
  const SampledPlant<double> sampled(plant);
  StabilityReport report;
  const auto test = schur_cohn<double>(characteristic_polynomial(sampled).at(gains.alpha, gains.beta));
  report.stable = test.stable && gains.alpha + plant.gamma > 0;
  report.margin = test.margin;
  report.spectral_radius =
      loop_schur_form(make_closed_loop(sampled, gains.alpha, gains.beta).transition).spectral_radius;
  return report;
}

inline bool is_stable(const NormalizedPlant& plant, const NormalizedGains& gains) {
  validate(gains, "hapticopt::is_stable");
  return loop_is_stable(SampledPlant<double>(plant), gains.alpha, gains.beta);
}

}  // namespace hapticopt
