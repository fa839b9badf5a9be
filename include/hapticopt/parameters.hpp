// SPDX-License-Identifier: Apache-2.0
// Physical and normalised parameters of the haptic loop (Hulin et al., IROS 2011, Table I, eq. 3).
//
//   alpha = K T^2 / m,  beta = B T / m,  gamma = k T^2 / m,  delta = b T / m,  d = t_d / T.
//
// In normalised units m = T = 1 and a force F corresponds to F T^2 / m; the step-response
// criteria (eqs. 6-9) are dimensionless, so they depend on the normalised parameters only.
#pragma once

#include "errors.hpp"

namespace hapticopt {

/// The physical loop: device + human arm (eq. 1), sampling period and total loop delay.
struct PhysicalPlant {
    double mass;              ///< m [kg] (or kg m^2 for a rotary joint), > 0
    double damping = 0.0;     ///< b [N s/m], >= 0
    double stiffness = 0.0;   ///< k [N/m], >= 0
    double period;            ///< T [s], > 0
    double time_delay = 0.0;  ///< t_d [s], >= 0, need not be a multiple of T
};

/// The normalised plant: the parameters that stay in the characteristic equation.
struct NormalizedPlant {
    double gamma = 0.0;  ///< k T^2 / m, >= 0
    double delta = 0.0;  ///< b T / m, >= 0
    double delay = 0.0;  ///< d = t_d / T, >= 0, integer or fractional
};

/// Virtual wall gains in physical units.
struct WallGains {
    double stiffness;  ///< K [N/m]
    double damping;    ///< B [N s/m]
};

/// Virtual wall gains in normalised units.
struct NormalizedGains {
    double alpha;  ///< K T^2 / m
    double beta;   ///< B T / m
};

/// Throws InvalidParameter unless m > 0, T > 0, b >= 0, k >= 0, t_d >= 0, all finite.
inline void validate(const PhysicalPlant& plant, const char* function = "hapticopt::validate") {
    detail::require_positive(function, "mass", plant.mass);
    detail::require_non_negative(function, "damping", plant.damping);
    detail::require_non_negative(function, "stiffness", plant.stiffness);
    detail::require_positive(function, "period", plant.period);
    detail::require_non_negative(function, "time_delay", plant.time_delay);
}

/// Throws InvalidParameter unless gamma, delta, d are finite and >= 0.
inline void validate(const NormalizedPlant& plant, const char* function = "hapticopt::validate") {
    detail::require_non_negative(function, "gamma", plant.gamma);
    detail::require_non_negative(function, "delta", plant.delta);
    detail::require_non_negative(function, "delay", plant.delay);
}

/// Throws InvalidParameter unless alpha and beta are finite (any sign is a valid question to ask;
/// stability is a separate test).
inline void validate(const NormalizedGains& gains, const char* function = "hapticopt::validate") {
    detail::require_finite(function, "alpha", gains.alpha);
    detail::require_finite(function, "beta", gains.beta);
}

/// Table I: gamma = k T^2/m, delta = b T/m, d = t_d/T.
inline NormalizedPlant normalize(const PhysicalPlant& plant) {
    validate(plant, "hapticopt::normalize");
    const double m = plant.mass;
    const double T = plant.period;
    return NormalizedPlant{plant.stiffness * T * T / m, plant.damping * T / m, plant.time_delay / T};
}

/// Table I: alpha = K T^2/m, beta = B T/m.
inline NormalizedGains normalize(const WallGains& gains, double mass, double period) {
    detail::require_positive("hapticopt::normalize", "mass", mass);
    detail::require_positive("hapticopt::normalize", "period", period);
    detail::require_finite("hapticopt::normalize", "stiffness", gains.stiffness);
    detail::require_finite("hapticopt::normalize", "damping", gains.damping);
    return NormalizedGains{gains.stiffness * period * period / mass, gains.damping * period / mass};
}

/// Eq. 3: K = alpha m / T^2, B = beta m / T.
inline WallGains to_physical(const NormalizedGains& gains, double mass, double period) {
    detail::require_positive("hapticopt::to_physical", "mass", mass);
    detail::require_positive("hapticopt::to_physical", "period", period);
    validate(gains, "hapticopt::to_physical");
    return WallGains{gains.alpha * mass / (period * period), gains.beta * mass / period};
}

/// Inverse of normalize(PhysicalPlant) for a given mass and period.
inline PhysicalPlant to_physical(const NormalizedPlant& plant, double mass, double period) {
    detail::require_positive("hapticopt::to_physical", "mass", mass);
    detail::require_positive("hapticopt::to_physical", "period", period);
    validate(plant, "hapticopt::to_physical");
    return PhysicalPlant{mass, plant.delta * mass / period, plant.gamma * mass / (period * period), period,
                         plant.delay * period};
}

}  // namespace hapticopt
