// Passivity of the sampled-data wall: the Colgate-Schenkel condition, and the best passive gains.
//
// J. E. Colgate and G. G. Schenkel, "Passivity of a class of sampled-data systems: application to
// haptic interfaces", J. Robotic Systems 14(1), 37-47, 1997: a virtual wall K + B (1 - z^-1) / T behind
// a zero-order hold, rendered by a device with physical damping b, is passive iff
//   b > K T / 2 + |B|,        normalised (Table I):   delta > alpha / 2 + |beta|.
// We use this delay-free form as it stands (no delay-aware variant): for d = 0 it is the paper's
// condition; for d > 0 the same inequality is reported but does not prove passivity (the extra delay
// is not part of Colgate and Schenkel's model). Hulin et al. 2011 remark that their optima violate it.
//
// Passivity margin (normalised, dimensionless):  mu = delta - alpha / 2 - |beta|;  passive iff mu > 0.
// In physical units the margin is mu m / T = b - K T / 2 - |B|  [N s/m]. With delta = 0 (no physical
// damping) no gains are passive; the passive set is the triangle 0 <= alpha < 2 delta,
// |beta| < delta - alpha / 2, inside the stable region (tests/beyond check both facts).
//
// Best passive gains: the minimum of a criterion over the stable part of that triangle, by the
// search of region_minimum.hpp with the b interval clipped to the triangle; none when delta = 0.
// Cost: a few thousand cost evaluations.
#pragma once

#include <algorithm>
#include <cmath>
#include <optional>

#include "impulse_costs.hpp"
#include "region_minimum.hpp"
#include "stability_region.hpp"

namespace hapticopt {

/// mu = delta - alpha / 2 - |beta| (header comment); > 0 iff passive.
inline double passivity_margin(const NormalizedPlant& plant, const NormalizedGains& gains) {
  validate(plant, "hapticopt::passivity_margin");
  validate(gains, "hapticopt::passivity_margin");
  return plant.delta - gains.alpha / 2 - std::abs(gains.beta);
}

/// Colgate-Schenkel: b > K T / 2 + |B|.
inline bool is_passive(const NormalizedPlant& plant, const NormalizedGains& gains) {
  return passivity_margin(plant, gains) > 0;
}

/// Physical margin b - K T / 2 - |B| [N s/m]; > 0 iff passive.
inline double passivity_margin(const PhysicalPlant& plant, const WallGains& gains) {
  validate(plant, "hapticopt::passivity_margin");
  detail::require_finite("hapticopt::passivity_margin", "stiffness", gains.stiffness);
  detail::require_finite("hapticopt::passivity_margin", "damping", gains.damping);
  return plant.damping - gains.stiffness * plant.period / 2 - std::abs(gains.damping);
}

/// The stable beta interval at alpha clipped to the passive triangle (empty: hi <= lo).
inline std::pair<double, double> passive_beta_range(const StabilityRegion& region, double alpha) {
  const double half = region.plant().delta - alpha / 2;
  if (!(half > 0) || !(alpha > region.alpha_min()) || alpha > region.alpha_max()) return {0.0, 0.0};
  const auto [lo, hi] = region.beta_range(alpha);
  return {std::max(lo, -half), std::min(hi, half)};
}

struct PassiveOptimum {
  double alpha = 0;
  double beta = 0;
  double cost = 0;
  double margin = 0;  ///< passivity margin there (>= 0; ~0 when the optimum is on the edge)
};

/// The minimum of cost(alpha, beta) over the stable passive gains; nullopt when there are none
/// (delta = 0, or the triangle misses the stable region).
template <typename Cost>
std::optional<PassiveOptimum> passive_minimum(const StabilityRegion& region, Cost&& cost,
                                              const RegionSearchOptions& options = {}) {
  const double a0 = std::max(0.0, region.alpha_min());
  const double a1 = std::min(2 * region.plant().delta, region.alpha_max());
  if (!(a1 > a0)) return std::nullopt;
  auto interval = [&](double a) { return passive_beta_range(region, a); };
  const RegionMinimum m = minimize_on_region(cost, a0, a1, interval, options);
  if (!std::isfinite(m.value)) return std::nullopt;
  return PassiveOptimum{m.alpha, m.beta, m.value,
                        passivity_margin(region.plant(), NormalizedGains{m.alpha, m.beta})};
}

/// Best passive gains for the step criterion C_E<index> (index 0..2).
inline std::optional<PassiveOptimum> passive_optimum(int index, const NormalizedPlant& plant,
                                                     const RegionSearchOptions& options = {}) {
  detail::require_in_range("hapticopt::passive_optimum", "index", index, 0, false, 2, "0, 1 or 2");
  const StabilityRegion region(plant);
  const SampledPlant<double> sampled(plant);
  auto c = [&](double a, double b) {
    const EnergyCosts e = energy_costs(sampled, a, b);
    return index == 0 ? e.ce0 : index == 1 ? e.ce1 : e.ce2;
  };
  return passive_minimum(region, c, options);
}

/// Best passive gains for the collision criterion C_I<index> (index 0..2).
inline std::optional<PassiveOptimum> passive_impulse_optimum(int index, const NormalizedPlant& plant,
                                                             const RegionSearchOptions& options = {}) {
  detail::require_in_range("hapticopt::passive_impulse_optimum", "index", index, 0, false, 2, "0, 1 or 2");
  const StabilityRegion region(plant);
  const SampledPlant<double> sampled(plant);
  auto c = [&](double a, double b) { return impulse_costs(sampled, a, b)[index]; };
  return passive_minimum(region, c, options);
}

}  // namespace hapticopt
