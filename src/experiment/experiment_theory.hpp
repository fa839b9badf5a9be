// SPDX-License-Identifier: Apache-2.0
// The analysis side of the experiments (hapticopt): the stability boundary and the optimal curves for the
// profile's plant, in physical units (K = alpha m / T^2, B = beta m / T; eq. 3). One Eigen-heavy TU.
#pragma once

#include <memory>
#include <utility>
#include <vector>

namespace hapticd::experiment {

struct TheoryPlant {
    double mass = 0.3;        // m, kg
    double damping = 0.0;     // b, N s/m
    double stiffness = 0.0;   // k, N/m
    double period = 1e-3;     // T, s
    double time_delay = 0.0;  // total loop delay (device + buffer), s
};

struct TheoryCosts {
    double ce0 = 0.0, ce1 = 0.0, ce2 = 0.0, overshoot = 0.0;
};

class Theory {
  public:
    // Throws hapticopt::InvalidParameter for an invalid plant.
    explicit Theory(const TheoryPlant& plant);
    ~Theory();
    Theory(const Theory&) = delete;
    Theory& operator=(const Theory&) = delete;

    [[nodiscard]] const TheoryPlant& plant() const noexcept;
    [[nodiscard]] double k_scale() const noexcept;  // alpha -> K
    [[nodiscard]] double b_scale() const noexcept;  // beta -> B
    // Largest stable K (alpha_max) and the B where it is reached.
    [[nodiscard]] double max_stiffness() const;
    [[nodiscard]] double damping_at_max_stiffness() const;
    // Largest B of the region (its polygon's maximum beta), and the smallest.
    [[nodiscard]] std::pair<double, double> damping_extent() const;
    // The stiffness where the loop loses stability at damping B, raising K from 0 (bisection on the
    // Schur-Cohn verdict to 1e-12 relative); 0 when no K > 0 is stable at B.
    [[nodiscard]] double boundary_stiffness(double B) const;
    // The stable B interval at stiffness K (0 < K <= max_stiffness()).
    [[nodiscard]] std::pair<double, double> stable_damping(double K) const;
    [[nodiscard]] bool is_stable(double K, double B) const;
    [[nodiscard]] double spectral_radius(double K, double B) const;
    // Optimal B of C_E<index> (0..2) at stiffness K: the library's optimal curve (WallOptimizer::optimal_beta).
    [[nodiscard]] double optimal_damping(int index, double K) const;
    [[nodiscard]] TheoryCosts costs(double K, double B, double overshoot_tolerance = 1e-12) const;
    // The CE2 optimum (K, B): the return gains between trials.
    [[nodiscard]] std::pair<double, double> ce2_optimum() const;
    // The closed boundary (complex branch, the tip, alpha = -gamma) in (K, B), as drawn by hapticopt plot.
    [[nodiscard]] std::vector<std::pair<double, double>> boundary_polyline(int points = 400) const;

  private:
    struct Impl;
    std::unique_ptr<Impl> impl_;
};

}  // namespace hapticd::experiment
