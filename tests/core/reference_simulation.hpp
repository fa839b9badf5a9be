// SPDX-License-Identifier: Apache-2.0
// The slower, independent method used to check the closed forms: time-stepping of the loop of
// Fig. 2 with the exact zero-order-hold map of each sub-step (Eigen's unsupported matrix
// exponential, not the library's Taylor code), the wall force from the samples, and composite
// Simpson quadrature of E(t) t^p. It shares no code with the library except NormalizedPlant.
#pragma once

#include <Eigen/Core>
#include <unsupported/Eigen/MatrixFunctions>
#include <algorithm>
#include <array>
#include <cmath>
#include <vector>

namespace hapticopt::testing {

/// How the loop starts: state at t = 0, the sample before it (for the first damping term), the constant
/// external force, and the position the energy is measured about (E = 1/2 (alpha + gamma)(x - x_ref)^2
/// + 1/2 x'^2). Wall forces before the first sample are zero.
struct LoopStart {
    double x = 0, v = 0, x_previous_sample = 0, force = 0, x_ref = 0;
};

struct SimulatedLoop {
    std::array<double, 3> costs{};     ///< (1/E(0)) int E(t) t^p dt, p = 0..2, by Simpson's rule
    double max_sampled_deviation = 0;  ///< max over the sub-step grid of x - x_ref
    double max_accel = 0;              ///< max over the grid of |x''| (for the O(h^2) bound of a sampled max)
};

/// Simulates the loop for `periods` periods with `substeps` (even) sub-steps per period; d * substeps
/// must be an integer so the force switches on the grid.
inline SimulatedLoop simulate_loop(double gamma, double delta, double d, double alpha, double beta, int substeps,
                                   int periods, const LoopStart& start) {
    const double h = 1.0 / substeps;
    Eigen::Matrix4d aug = Eigen::Matrix4d::Zero();  // (x, v, wall force, external force)
    aug(0, 1) = 1;                                  // v' = -gamma x - delta v - wall + external
    aug(1, 0) = -gamma;
    aug(1, 1) = -delta;
    aug(1, 2) = -1;
    aug(1, 3) = 1;
    const Eigen::Matrix4d step = (aug * h).exp();
    const long long delay_steps = std::llround(d * substeps);
    std::vector<double> forces;  // f_j
    double x_prev_sample = start.x_previous_sample;
    Eigen::Vector4d s(start.x, start.v, 0, start.force);
    SimulatedLoop out;
    out.max_sampled_deviation = start.x - start.x_ref;
    auto energy = [&](const Eigen::Vector4d& v) {
        const double dx = v(0) - start.x_ref;
        return 0.5 * (alpha + gamma) * dx * dx + 0.5 * v(1) * v(1);
    };
    auto accel = [&](const Eigen::Vector4d& v) { return std::abs(-gamma * v(0) - delta * v(1) - v(2) + v(3)); };
    std::array<double, 3> integral{};
    const long long total = static_cast<long long>(periods) * substeps;
    const double e0 = energy(s);
    double e_prev = e0;
    for (long long k = 0; k < total; ++k) {
        if (k % substeps == 0) {
            const double x = s(0);
            forces.push_back(alpha * x + beta * (x - x_prev_sample));
            x_prev_sample = x;
        }
        const long long i = k >= delay_steps ? (k - delay_steps) / substeps : -1;  // acting force index
        s(2) = i >= 0 ? forces[static_cast<std::size_t>(i)] : 0.0;
        out.max_accel = std::max(out.max_accel, accel(s));
        s = step * s;
        out.max_accel = std::max(out.max_accel, accel(s));
        const double e = energy(s);
        // Simpson over pairs of sub-steps: accumulate with weights 1,4,1 on (k-1, k, k+1).
        const double t = static_cast<double>(k + 1) * h;
        const double w = ((k + 1) % 2 == 1) ? 4.0 : 2.0;
        for (int p = 0; p < 3; ++p) integral[static_cast<std::size_t>(p)] += w * e * std::pow(t, p);
        e_prev = e;
        out.max_sampled_deviation = std::max(out.max_sampled_deviation, s(0) - start.x_ref);
    }
    // Endpoint corrections: t = 0 has weight 1 (E(0) t^p), the last point weight 1 not 2.
    const double t_end = static_cast<double>(total) * h;
    integral[0] += e0;
    for (int p = 0; p < 3; ++p) integral[static_cast<std::size_t>(p)] -= e_prev * std::pow(t_end, p);
    for (int p = 0; p < 3; ++p)
        out.costs[static_cast<std::size_t>(p)] = integral[static_cast<std::size_t>(p)] * h / 3 / e0;
    return out;
}

struct SimulatedCosts {
    std::array<double, 3> ce{};        ///< C_E0..2 by Simpson's rule
    double max_sampled_overshoot = 0;  ///< max over the sub-step grid of (x - x_inf)/x_inf
};

/// The unit step of the paper (F = 1 from t = 0, at rest in contact): C_E0..2 and the sampled overshoot.
inline SimulatedCosts simulate_step(double gamma, double delta, double d, double alpha, double beta, int substeps,
                                    int periods) {
    const double x_inf = 1 / (alpha + gamma);
    const SimulatedLoop loop = simulate_loop(gamma, delta, d, alpha, beta, substeps, periods, {0, 0, 0, 1, x_inf});
    return {loop.costs, loop.max_sampled_deviation / x_inf};
}

}  // namespace hapticopt::testing
