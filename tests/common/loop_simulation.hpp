// SPDX-License-Identifier: Apache-2.0
// An independent model of the rendered scalar loop for the tests: a time-stepping simulation in physical units,
// written without hapticopt. A free mass m (b = k = 0) starts at rest at x = 1 mm; at each tick j the position is
// sampled, the velocity estimated by the loop's difference equation (backward, low-pass, window of N), and the wall
// force f_j = K x_j + B v_j acts against x during [jT + t_d, (j + 1)T + t_d) (delay d = n + phi periods: the period
// [j, j + 1) sees f_{j-n-1} for phi T, then f_{j-n}; no force before t = 0); the mass moves exactly under each
// constant force (x += v tau - u tau^2 / 2m). excursion_ratio_with_arm adds an arm: m x'' + b_H x' + k_H x = -f,
// integrated over each constant-force interval by classical Runge-Kutta with 16 steps per period (local error
// O((omega h)^5) with omega h <= sqrt(k_H / m) T / 16 = 2e-3 for the arms of the tests, k_H / m <= 1000 s^-2, and
// b_H h / m <= 1.3e-3: ~1e-14 relative per step, far below the growth or decay a verdict over thousands of periods
// reads).
#pragma once

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <deque>

namespace loop_simulation {

enum class Estimator { Backward, LowPass, Window };

struct Velocity {
    Estimator kind = Estimator::Backward;
    double cutoff = 0.0;  // low-pass: normalised cutoff nu = f_c T
    int window = 1;       // window: N periods (<= 1000)
};

// The mass m held by the arm (k_arm, b_arm), m x'' + b_arm x' + k_arm x = -u, moved over tau by classical Runge-Kutta
// with 16 steps (header comment: its error).
inline void move_with_arm(double& x, double& v, double u, double tau, double m, double k_arm, double b_arm) {
    auto acceleration = [&](double xx, double vv) { return (-u - k_arm * xx - b_arm * vv) / m; };
    constexpr int kSteps = 16;
    const double h = tau / kSteps;
    for (int i = 0; i < kSteps; ++i) {
        const double a1 = acceleration(x, v);
        const double x2 = x + 0.5 * h * v, v2 = v + 0.5 * h * a1, a2 = acceleration(x2, v2);
        const double x3 = x + 0.5 * h * v2, v3 = v + 0.5 * h * a2, a3 = acceleration(x3, v3);
        const double x4 = x + h * v3, v4 = v + h * a3, a4 = acceleration(x4, v4);
        x += h / 6.0 * (v + 2.0 * v2 + 2.0 * v3 + v4);
        v += h / 6.0 * (a1 + 2.0 * a2 + 2.0 * a3 + a4);
    }
}

// The loop's ticks with the plant's motion under a force u held for tau given by move(x, v, u, tau): max |x| over the
// last tenth of `ticks` periods divided by max |x| over the first tenth; HUGE_VAL once |x| passes 1 m (a million
// times the start: grown).
template <class Move>
double excursion_ratio_of(double K, double B, double T, double delay_periods, const Velocity& e, int ticks, Move move) {
    const int n = static_cast<int>(std::floor(delay_periods));
    const double phi = delay_periods - n;
    double x = 1e-3, v = 0.0;
    std::deque<double> samples(1001, x);  // x_j, x_{j-1}, ...: at rest before t = 0
    double low_pass = 0.0;
    std::deque<double> forces(static_cast<std::size_t>(n + 2), 0.0);  // f_j, f_{j-1}, ...
    const double lambda = e.kind == Estimator::LowPass ? std::exp(-2.0 * 3.14159265358979323846 * e.cutoff) : 0.0;
    double first = 0.0, last = 0.0;
    for (int j = 0; j < ticks; ++j) {
        samples.push_front(x);
        samples.pop_back();
        double velocity = 0.0;
        switch (e.kind) {
            case Estimator::Backward:
                velocity = (samples[0] - samples[1]) / T;
                break;
            case Estimator::LowPass:
                low_pass = lambda * low_pass + (1.0 - lambda) * (samples[0] - samples[1]) / T;
                velocity = low_pass;
                break;
            case Estimator::Window:
                velocity = (samples[0] - samples[static_cast<std::size_t>(e.window)]) / (e.window * T);
                break;
        }
        forces.push_front(K * samples[0] + B * velocity);
        forces.pop_back();
        if (phi > 0.0) move(x, v, forces[static_cast<std::size_t>(n + 1)], phi * T);
        move(x, v, forces[static_cast<std::size_t>(n)], (1.0 - phi) * T);
        if (j < ticks / 10) first = std::max(first, std::abs(x));
        if (j >= ticks - ticks / 10) last = std::max(last, std::abs(x));
        if (!(std::abs(x) < 1.0)) return HUGE_VAL;
    }
    return last / first;
}

// The free mass m, moved exactly under each constant force.
inline double excursion_ratio(double m, double K, double B, double T, double delay_periods, const Velocity& e,
                              int ticks) {
    return excursion_ratio_of(K, B, T, delay_periods, e, ticks, [m](double& x, double& v, double u, double tau) {
        x += v * tau - u * tau * tau / (2.0 * m);
        v -= u * tau / m;
    });
}

// The same loop with the arm (k_H, b_H) on the mass (header comment); the arm's spring rests at the wall's x = 0,
// as the wall's does: the loop's equilibrium is x = 0.
inline double excursion_ratio_with_arm(double m, double k_arm, double b_arm, double K, double B, double T,
                                       double delay_periods, const Velocity& e, int ticks) {
    return excursion_ratio_of(K, B, T, delay_periods, e, ticks, [=](double& x, double& v, double u, double tau) {
        move_with_arm(x, v, u, tau, m, k_arm, b_arm);
    });
}

}  // namespace loop_simulation
