// The slower, independent method used to check the closed forms: time-stepping of the loop of
// Fig. 2 with the exact zero-order-hold map of each sub-step (Eigen's unsupported matrix
// exponential, not the library's Taylor code), the wall force from the samples, and composite
// Simpson quadrature of E(t) t^p. It shares no code with the library except NormalizedPlant.
#pragma once

#include <Eigen/Core>
#include <unsupported/Eigen/MatrixFunctions>
#include <array>
#include <cmath>
#include <vector>

namespace hapticopt::testing {

struct SimulatedCosts {
  std::array<double, 3> ce{};  ///< C_E0..2 by Simpson's rule
  double max_sampled_overshoot = 0;  ///< max over the sub-step grid of (x - x_inf)/x_inf
};

/// Simulates the unit step for `periods` periods with `substeps` (even) sub-steps per period;
/// d * substeps must be an integer so the force switches on the grid.
inline SimulatedCosts simulate_step(double gamma, double delta, double d, double alpha, double beta,
                                    int substeps, int periods) {
  const double h = 1.0 / substeps;
  Eigen::Matrix3d a;  // (x, v, force) with v' = -gamma x - delta v + 1 - force
  a << 0, 1, 0, -gamma, -delta, -1, 0, 0, 0;
  Eigen::Matrix4d aug = Eigen::Matrix4d::Zero();  // + the constant input F = 1
  aug.topLeftCorner<3, 3>() = a;
  aug(1, 3) = 1;
  const Eigen::Matrix4d step = (aug * h).exp();
  const double x_inf = 1 / (alpha + gamma);
  const int delay_steps = static_cast<int>(std::lround(d * substeps));
  std::vector<double> forces;  // f_j
  double x_prev_sample = 0;
  Eigen::Vector4d s(0, 0, 0, 1);
  SimulatedCosts out;
  out.max_sampled_overshoot = -1;
  auto energy = [&](const Eigen::Vector4d& v) {
    const double dx = v(0) - x_inf;
    return 0.5 * (alpha + gamma) * dx * dx + 0.5 * v(1) * v(1);
  };
  std::array<double, 3> integral{};
  const long long total = static_cast<long long>(periods) * substeps;
  double e_prev = energy(s);
  for (long long k = 0; k < total; ++k) {
    if (k % substeps == 0) {
      const double x = s(0);
      forces.push_back(alpha * x + beta * (x - x_prev_sample));
      x_prev_sample = x;
    }
    const long long i = (k - delay_steps) >= 0 ? (k - delay_steps) / substeps : -1;  // acting force index
    s(2) = i >= 0 ? forces[static_cast<std::size_t>(i)] : 0.0;
    s = step * s;
    const double e = energy(s);
    // Simpson over pairs of sub-steps: accumulate with weights 1,4,1 on (k-1, k, k+1).
    const double t = static_cast<double>(k + 1) * h;
    const double w = ((k + 1) % 2 == 1) ? 4.0 : 2.0;
    for (int p = 0; p < 3; ++p) integral[static_cast<std::size_t>(p)] += w * e * std::pow(t, p);
    e_prev = e;
    out.max_sampled_overshoot = std::max(out.max_sampled_overshoot, (s(0) - x_inf) / x_inf);
  }
  // Endpoint corrections: t = 0 has weight 1 (E(0) t^p), the last point weight 1 not 2.
  const double e0 = 0.5 / (alpha + gamma);
  const double t_end = static_cast<double>(total) * h;
  integral[0] += e0;
  for (int p = 0; p < 3; ++p) integral[static_cast<std::size_t>(p)] -= e_prev * std::pow(t_end, p);
  for (int p = 0; p < 3; ++p) out.ce[static_cast<std::size_t>(p)] = integral[static_cast<std::size_t>(p)] * h / 3 / e0;
  return out;
}

}  // namespace hapticopt::testing
