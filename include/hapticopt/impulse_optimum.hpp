// SPDX-License-Identifier: Apache-2.0
// Optimal curves and points of the collision criteria C_I0, C_I1, C_I2 (impulse_costs.hpp).
//
// Definitions, as for the step criteria (optimum.hpp): the optimal
// curve of C_Ip is beta_opt(alpha) = argmin over the stable beta interval of C_Ip(alpha, beta); the
// CIp point is the global minimum of C_Ip over the exact stable region. The cost exists (is finite)
// exactly on the stable region, so a minimum exists wherever the cost grows towards the region's
// boundary (it does: the sums diverge there). Towards alpha -> -gamma (the wall goes soft) C_I1 and
// C_I2 grow, but C_I0 does not: its infimum lies on that edge (measured for d = 0, 1: the pure
// damper, which dissipates the kinetic energy fastest and leaves the device at rest inside the wall,
// where with alpha + gamma -> 0 the spring energy counts for nothing). The CI0 "optimum" is then
// reported with on_region_edge = true: the criterion alone does not define a useful wall; C_I1 and
// C_I2 (time-weighted, so a slow return costs) have interior minima.
// Search (region_minimum.hpp): coarse grid over the exact region (StabilityRegion::beta_range), Brent
// over beta and over alpha. Tests: tests/beyond/test_beyond.cpp (no point of a fine grid of the
// region is better). Also reports the penetration depth at the optimum.
#pragma once

#include "config.hpp"
#include "impulse_costs.hpp"
#include "region_minimum.hpp"
#include "stability_region.hpp"

namespace hapticopt {

struct ImpulseOptimum {
    ImpulseCriterion criterion = ImpulseCriterion::CI2;
    double alpha = 0;
    double beta = 0;
    double cost = 0;                     ///< C_Ip at the point
    double penetration = 0;              ///< max_t x(t) / (v0 T) at the point
    double alpha_max = 0;                ///< of the stable region
    bool on_region_edge = false;         ///< alpha within 1e-6 (alpha_max - alpha_min) of alpha_min
    bool penetration_converged = false;  ///< proven stop reached within kPenetrationPeriods
    static constexpr long long kPenetrationPeriods = 100000;
};

class ImpulseOptimizer {
  public:
    HAPTICOPT_DEFERRED
    explicit ImpulseOptimizer(const NormalizedPlant& plant, const RegionSearchOptions& options = {})
        : region_(plant), sampled_(plant), options_(options) {}

    const StabilityRegion& region() const { return region_; }
    const SampledPlant<double>& sampled_plant() const { return sampled_; }

    /// C_I<index>(alpha, beta), +inf when unstable.
    HAPTICOPT_DEFERRED
    double cost(int index, double alpha, double beta) const { return impulse_costs(sampled_, alpha, beta)[index]; }

    /// beta_opt(alpha) of C_I<index>; alpha in (-gamma, alpha_max].
    HAPTICOPT_DEFERRED
    double optimal_beta(int index, double alpha) const {
        auto c = [&](double a, double b) { return cost(index, a, b); };
        auto interval = [&](double a) { return region_.beta_range(a); };
        return detail::minimize_over_beta(c, interval, alpha, options_.beta_grid).x;
    }

    HAPTICOPT_DEFERRED
    ImpulseOptimum optimum(ImpulseCriterion criterion) const {
        const int index = energy_index(criterion);
        auto c = [&](double a, double b) { return cost(index, a, b); };
        auto interval = [&](double a) { return region_.beta_range(a); };
        const RegionMinimum m = minimize_on_region(c, region_.alpha_min(), region_.alpha_max(), interval, options_);
        ImpulseOptimum out;
        out.criterion = criterion;
        out.alpha = m.alpha;
        out.beta = m.beta;
        out.cost = m.value;
        const PenetrationResult pen = penetration(sampled_, m.alpha, m.beta, ImpulseOptimum::kPenetrationPeriods);
        out.penetration = pen.depth;
        out.penetration_converged = pen.converged;
        out.alpha_max = region_.alpha_max();
        out.on_region_edge = m.alpha - region_.alpha_min() < 1e-6 * (region_.alpha_max() - region_.alpha_min());
        return out;
    }

  private:
    StabilityRegion region_;
    SampledPlant<double> sampled_;
    RegionSearchOptions options_;
};

/// The optimum of one collision criterion for a normalised plant.
HAPTICOPT_FUNC ImpulseOptimum optimal_point(ImpulseCriterion criterion, const NormalizedPlant& plant,
                                            const RegionSearchOptions& options = {})
#if HAPTICOPT_DEFINITIONS
{
    return ImpulseOptimizer(plant, options).optimum(criterion);
}
#else
    ;
#endif

}  // namespace hapticopt
