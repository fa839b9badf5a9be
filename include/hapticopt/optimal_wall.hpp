// SPDX-License-Identifier: Apache-2.0
// The physical answer: from the device (m, b, k), the period T and the loop delay t_d to the
// optimal wall gains K and B of one criterion (eq. 3: K = alpha m / T^2, B = beta m / T).
#pragma once

#include "config.hpp"
#include "optimum.hpp"

namespace hapticopt {

struct WallTuning {
    Criterion criterion = Criterion::CE2;
    PhysicalPlant plant{};         ///< what the tuning was computed for
    NormalizedPlant normalized{};  ///< gamma, delta, d
    double alpha = 0;
    double beta = 0;
    std::optional<double> cost;                                    ///< predicted C_Ex; none for amax and OV
    double K = 0;                                                  ///< N/m
    double B = 0;                                                  ///< N s/m
    double alpha_max = 0;                                          ///< stiffness limit of the region (normalised)
    double K_max = 0;                                              ///< N/m
    double stability_margin() const { return alpha / alpha_max; }  ///< alpha / alpha_max
};

/// Optimal (K, B) for `criterion`; only that criterion is computed. Throws InvalidParameter for
/// invalid physical parameters (message names the parameter and the accepted range).
HAPTICOPT_FUNC WallTuning optimal_wall(Criterion criterion, const PhysicalPlant& plant,
                                       const OptimumOptions& options = {})
#if HAPTICOPT_DEFINITIONS
{
    WallTuning t;
    t.criterion = criterion;
    t.plant = plant;
    t.normalized = normalize(plant);
    const Optimum o = optimal_point(criterion, t.normalized, options);
    t.alpha = o.alpha;
    t.beta = o.beta;
    t.cost = o.cost;
    t.alpha_max = o.alpha_max;
    const WallGains g = to_physical(NormalizedGains{o.alpha, o.beta}, plant.mass, plant.period);
    t.K = g.stiffness;
    t.B = g.damping;
    t.K_max = o.alpha_max * plant.mass / (plant.period * plant.period);
    return t;
}
#else
    ;
#endif

}  // namespace hapticopt
