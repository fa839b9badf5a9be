// SPDX-License-Identifier: Apache-2.0
// Exact zero-order-hold discretisation of the mass-damper-spring plant  m x'' + b x' + k x = u.
#pragma once

#include <array>

namespace hapticd {

struct PlantParameters {
    double mass = 1.0;       // kg (kg m^2)
    double damping = 0.0;    // N s/m
    double stiffness = 0.0;  // N/m
};

// One exact step of length h with u constant over the step:
//   [x; v](t+h) = Phi [x; v](t) + Gamma u,   [Phi Gamma; 0 1] = expm([A B; 0 0] h),
//   A = [0 1; -k/m -b/m], B = [0; 1/m].
struct ZohStep {
    std::array<double, 4> phi{1.0, 0.0, 0.0, 1.0};  // row-major 2x2
    std::array<double, 2> gamma{0.0, 0.0};

    void apply(double& x, double& v, double u) const noexcept {
        const double xn = phi[0] * x + phi[1] * v + gamma[0] * u;
        const double vn = phi[2] * x + phi[3] * v + gamma[1] * u;
        x = xn;
        v = vn;
    }
};

// Computed once at start-up (allocates inside Eigen; not for the real-time path).
// Preconditions (checked by the caller's configuration validation): mass > 0, damping >= 0,
// stiffness >= 0, h >= 0, all finite.
ZohStep discretize(const PlantParameters& plant, double h);

// The same step without allocation, for the real-time path (the simulated device's Coulomb friction needs the
// motion over arbitrary sub-intervals): expm of the 3x3 matrix above by scaling and squaring, the scaled matrix's
// infinity norm <= 1/2 and its Taylor series to the 20th power (remainder below 0.5^21 / 21! ~ 1e-26 relative
// before squaring). Agrees with discretize() to rounding (tests/devices/test_sim_device.cpp). Same preconditions.
ZohStep discretize_series(const PlantParameters& plant, double h) noexcept;

}  // namespace hapticd
