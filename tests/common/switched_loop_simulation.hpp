// SPDX-License-Identifier: Apache-2.0
// An independent model of the rendered scalar loop whose gains and plant change from tick to tick, for the tests of
// switching: a time-stepping simulation in physical units, written without hapticopt. At tick j the position x_j is
// sampled, the velocity estimated (backward difference, or the difference over a window of N periods), and the wall
// force f_j = K_j x_j + B_j v_j is computed with the gains of tick j; it acts against x during
// [jT + t_d, (j + 1)T + t_d) (delay d = n + phi periods: the period [j, j + 1) sees f_{j-n-1} for phi T, then
// f_{j-n}; the forces already in flight keep the gains they were computed with). During [j, j + 1) the plant is the
// mass m_j with the arm (k_j, b_j): m x'' + b x' + k x = -f, integrated by classical Runge-Kutta with 16 steps per
// constant-force interval (as loop_simulation.hpp: ~1e-14 relative per step for the tests' arms), exactly when the arm
// is absent. The handle starts at rest at x_0 (the samples before t = 0 are x_0, no force before t = 0).
#pragma once

#include <cmath>
#include <cstddef>
#include <deque>
#include <vector>

#include "common/loop_simulation.hpp"

namespace switched_loop_simulation {

struct Tick {
    double stiffness;  // K [N/m]
    double damping;    // B [N s/m]
    double mass;       // m [kg]
    double arm_stiffness = 0.0;
    double arm_damping = 0.0;
};

// The sampled positions x_0, x_1, ..., x_ticks (one more than the schedule's ticks).
inline std::vector<double> positions(const std::vector<Tick>& schedule, double T, double delay_periods, int window,
                                     double x0) {
    const int n = static_cast<int>(std::floor(delay_periods));
    const double phi = delay_periods - n;
    double x = x0, v = 0.0;
    std::deque<double> samples(static_cast<std::size_t>(window) + 1, x0);
    std::deque<double> forces(static_cast<std::size_t>(n + 2), 0.0);
    std::vector<double> out{x};
    out.reserve(schedule.size() + 1);
    for (const Tick& t : schedule) {
        samples.push_front(x);
        samples.pop_back();
        const double velocity = (samples[0] - samples[static_cast<std::size_t>(window)]) / (window * T);
        forces.push_front(t.stiffness * samples[0] + t.damping * velocity);
        forces.pop_back();
        auto move = [&](double u, double tau) {
            if (t.arm_stiffness == 0.0 && t.arm_damping == 0.0) {
                x += v * tau - u * tau * tau / (2.0 * t.mass);
                v -= u * tau / t.mass;
                return;
            }
            loop_simulation::move_with_arm(x, v, u, tau, t.mass, t.arm_stiffness, t.arm_damping);
        };
        if (phi > 0.0) move(forces[static_cast<std::size_t>(n + 1)], phi * T);
        move(forces[static_cast<std::size_t>(n)], (1.0 - phi) * T);
        out.push_back(x);
    }
    return out;
}

}  // namespace switched_loop_simulation
