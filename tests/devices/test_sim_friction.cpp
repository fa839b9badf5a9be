// SPDX-License-Identifier: Apache-2.0
// The simulated device's Coulomb friction (devices/sim_device.hpp, model at the head): a block sliding on dry
// friction against the closed forms of constant deceleration and acceleration, sticking below the friction, and a
// damped, spring-held case with sticking and slipping against an independent fine time-stepping written here.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <stdexcept>
#include <string>
#include <vector>

#include "devices/sim_device.hpp"
#include "devices/zoh_plant.hpp"

namespace hapticd::sim_friction_test {

SimDeviceConfig friction_base(double mass, double friction, double delay = 0.0) {
    SimDeviceConfig c;
    c.capabilities.axes = 1;
    c.capabilities.max_force = 100.0;
    c.capabilities.inherent_delay = delay;
    c.plant = {mass, 0.0, 0.0};
    c.period = 1e-3;
    c.coulomb_friction = {friction, 0.0, 0.0};
    return c;
}

// The device's exact (noise-free) position and velocity at t = j T, j = 0 .. n - 1; `force(j)` is written at tick j.
template <class Force>
void run(SimDevice& dev, int n, Force force, std::vector<double>& x, std::vector<double>& v) {
    ASSERT_EQ(dev.open(), DeviceStatus::Ok);
    for (int j = 0; j < n; ++j) {
        AxisVector p{};
        ASSERT_EQ(dev.read_position(p), DeviceStatus::Ok);
        x.push_back(dev.true_position(0));
        v.push_back(dev.true_velocity(0));
        ASSERT_EQ(dev.write_force({force(j), 0.0, 0.0}), DeviceStatus::Ok);
    }
}

// The series matrix exponential (no allocation) against the closed form of the ZOH step: the free mass
// (Phi = [1 h; 0 1], Gamma = [h^2 / (2 m); h / m]) and damped oscillators (x_e = u / k; with sigma = b / (2 m),
// omega_d^2 = k / m - sigma^2, s = sin(omega_d h) / omega_d, c = cos(omega_d h): Phi = e^{-sigma h} [c + sigma s,
// s; -(k / m) s, c - sigma s], Gamma = [(1 - Phi_00) / k; -Phi_10 / k]). Tolerance: the series is accurate
// norm-wise, its rounding grown by the S squarings (S = 0 for the mild plants, 15 for the stiff one): 64 eps 2^S
// of the largest entry of [Phi Gamma].
TEST(SimDeviceFriction, SeriesExponentialMatchesTheClosedForm) {
    for (const PlantParameters p :
         {PlantParameters{0.3, 0.0, 0.0}, PlantParameters{0.3, 4.0, 200.0}, PlantParameters{0.065, 2.0, 1e6}}) {
        for (double h : {0.0, 1e-7, 2.5e-4, 1e-3}) {
            ZohStep exact;
            if (p.stiffness == 0.0) {
                exact.phi = {1.0, h, 0.0, 1.0};
                exact.gamma = {h * h / (2 * p.mass), h / p.mass};
            } else {
                const double sigma = p.damping / (2 * p.mass), w0 = p.stiffness / p.mass;
                const double wd = std::sqrt(w0 - sigma * sigma);
                const double sn = std::sin(wd * h) / wd, cs = std::cos(wd * h), e = std::exp(-sigma * h);
                exact.phi = {e * (cs + sigma * sn), e * sn, -e * w0 * sn, e * (cs - sigma * sn)};
                exact.gamma = {(1 - exact.phi[0]) / p.stiffness, -exact.phi[2] / p.stiffness};
            }
            const ZohStep b = discretize_series(p, h);
            const double a_norm = h * std::max(1.0, (p.stiffness + p.damping + 1.0) / p.mass);
            const double squarings = a_norm > 0.5 ? std::ceil(std::log2(a_norm / 0.5)) : 0.0;
            double norm = 0.0;
            for (double v : exact.phi) norm = std::max(norm, std::abs(v));
            for (double v : exact.gamma) norm = std::max(norm, std::abs(v));
            const double tol = 64 * 2.2e-16 * std::exp2(squarings) * norm;
            for (int i = 0; i < 4; ++i) EXPECT_NEAR(b.phi[i], exact.phi[i], tol) << p.stiffness << " " << h;
            for (int i = 0; i < 2; ++i) EXPECT_NEAR(b.gamma[i], exact.gamma[i], tol) << p.stiffness << " " << h;
        }
    }
}

// A block of m = 0.3 kg sent at v0 = 0.1 m/s (Push scenario, no hand, no force) on f_c = 0.7 N decelerates at
// f_c / m while it slides, x(t) = v0 t - f_c t^2 / (2 m), and stops at t_s = m v0 / f_c = 42.857 ms (inside a
// period) after v0^2 m / (2 f_c) = 2.142857 mm, where it stays (no force pushes it). The device integrates the same
// motion exactly, with the stop time found by bisection to rounding: tolerance 1e-12 of the distance (positions
// of order 1e-3 m after ~100 exact steps agree to ~1e-18 m; the margin covers the stop time, located to ~1e-19 s).
TEST(SimDeviceFriction, SlidingBlockDeceleratesAtFrictionOverMassAndStopsAtTheClosedFormDistance) {
    const double m = 0.3, fc = 0.7, v0 = 0.1, start = 0.002;
    auto c = friction_base(m, fc);
    c.scenario.kind = Scenario::Push;
    c.scenario.push_speed = v0;
    c.scenario.push_distance = start;
    SimDevice dev(c);
    std::vector<double> x, v;
    const auto no_force = [](int) { return 0.0; };
    run(dev, 100, no_force, x, v);
    const double ts = m * v0 / fc, distance = v0 * v0 * m / (2 * fc);
    for (std::size_t j = 0; j < x.size(); ++j) {
        const double t = static_cast<double>(j) * 1e-3;
        const double travelled = t < ts ? v0 * t - fc * t * t / (2 * m) : distance;
        EXPECT_NEAR(x[j] - (-start), travelled, 1e-12 * distance) << j;
        EXPECT_NEAR(v[j], t < ts ? v0 - fc / m * t : 0.0, 1e-12 * v0) << j;
    }
    EXPECT_EQ(v.back(), 0.0);  // at rest exactly, not creeping
}

// A push below the friction (hand's hold force and the written force, together 0.65 N in either direction against
// f_c = 0.7 N) never moves the resting handle: the position is exactly the initial one. The same pushes 0.05 N
// above f_c accelerate it at (F - f_c) / m from t = 0: x = (F - f_c) t^2 / (2 m), exact up to rounding (1e-12
// relative, as for the free mass of test_sim_device.cpp).
TEST(SimDeviceFriction, PushBelowFrictionNeverMovesAndAboveItAcceleratesAtTheExcess) {
    const double m = 0.3, fc = 0.7;
    for (double direction : {1.0, -1.0}) {
        for (double written : {0.35, 0.4}) {
            auto c = friction_base(m, fc, 0.5e-3);  // a fractional delay: two sub-intervals per period
            c.scenario.kind = Scenario::Hold;
            c.scenario.direction = direction;
            c.scenario.hold_distance = 0.0;
            c.scenario.hold_force = 0.3;
            SimDevice dev(c);
            std::vector<double> x, v;
            const auto constant = [&](int) { return direction * written; };
            run(dev, 400, constant, x, v);
            const double total = 0.3 + written;
            for (std::size_t j = 0; j < x.size(); ++j) {
                const double t = static_cast<double>(j) * 1e-3;
                if (total < fc) {
                    ASSERT_EQ(x[j], 0.0) << j;
                    ASSERT_EQ(v[j], 0.0) << j;
                    continue;
                }
                // Until the written force arrives (t_d = 0.5 ms) only the hold force acts, 0.3 N < f_c: at rest.
                const double td = 0.5e-3, a = (total - fc) / m;
                const double expected = t > td ? direction * a * (t - td) * (t - td) / 2 : 0.0;
                EXPECT_NEAR(x[j], expected, 1e-12 * std::abs(expected) + 1e-18) << direction << " " << j;
            }
            if (total > fc) {
                EXPECT_GT(direction * x.back(), 0.0);
            }
        }
    }
}

// The independent reference: explicit midpoint steps of h with the friction -s f_c while sliding in direction s,
// sticking while at rest with |u - k x| <= f_c, and a sign change of v inside a step ending it at rest at the
// linearly interpolated position. Its error is O(h^2) while sliding, and each stop or start (decided only at step
// boundaries, the stop instant interpolated) is off by at most h in time while |v| <= a h: O(h^2) in position per
// event, a bounded number of events per forcing cycle. Its error at h / 2 is therefore about a third of its change
// from h to h / 2 (at most that change while the order is not yet asymptotic).
struct Reference {
    double m, b, k, fc, delay, period;
    std::vector<double> written;
    double hold;

    [[nodiscard]] std::vector<double> positions(int substeps) const {
        const double h = period / substeps;
        double x = 0.0, v = 0.0;
        std::vector<double> out{0.0};
        const auto n = static_cast<long>(written.size());
        const long delay_steps = std::lround(delay / h);
        for (long j = 0; j + 1 < n; ++j) {
            for (int i = 0; i < substeps; ++i) {
                const long step = j * substeps + i - delay_steps;  // written force of tick floor(step / substeps)
                const double wall = step < 0 ? 0.0 : written[static_cast<std::size_t>(step / substeps)];
                const double u = hold + wall;
                double s = v > 0 ? 1.0 : (v < 0 ? -1.0 : 0.0);
                if (s == 0.0) {
                    const double net = u - k * x;
                    if (std::abs(net) <= fc) continue;
                    s = net > 0 ? 1.0 : -1.0;
                }
                auto acc = [&](double xx, double vv) { return (u - k * xx - b * vv - s * fc) / m; };
                const double a1 = acc(x, v);
                const double xm = x + v * h / 2, vm = v + a1 * h / 2;
                const double a2 = acc(xm, vm);
                const double xn = x + vm * h, vn = v + a2 * h;
                if (s * vn <= 0.0) {
                    const double frac = v == 0.0 ? 0.0 : v / (v - vn);
                    x += frac * (xn - x);
                    v = 0.0;
                } else {
                    x = xn;
                    v = vn;
                }
            }
            out.push_back(x);
        }
        return out;
    }
};

// m = 0.3 kg held by the hand (b_H = 4 N s/m, k_H = 200 N/m) on f_c = 0.9 N, a 0.2 N hold force and a written force
// 1.2 sin(2 pi 3 t) N delayed by 1.5 periods: the handle sticks and slips several times per cycle. The device
// against the midpoint reference at h = T / 2000 and T / 4000: max |device - reference(T / 4000)| over 600 ticks
// <= 4 max |reference(T / 2000) - reference(T / 4000)| + 1e-12 m (the reference's own error is at most that change,
// above; 4 for margin; 1e-12 m for the device's rounding over 600 exact steps of a motion of a few mm). The motion
// is checked to have both sticking and sliding ticks, so that the comparison covers both.
TEST(SimDeviceFriction, DampedSpringHeldCaseMatchesFineTimeStepping) {
    const double m = 0.3, fc = 0.9, T = 1e-3, delay = 1.5e-3;
    auto c = friction_base(m, fc, delay);
    c.scenario.kind = Scenario::Hold;
    c.scenario.hold_distance = 0.0;
    c.scenario.hold_force = 0.2;
    c.scenario.hand.damping = 4.0;
    c.scenario.hand.stiffness = 200.0;
    SimDevice dev(c);
    const int n = 600;
    auto force = [&](int j) { return 1.2 * std::sin(2 * M_PI * 3.0 * j * T); };
    std::vector<double> x, v;
    run(dev, n, force, x, v);
    Reference ref{m, 4.0, 200.0, fc, delay, T, {}, 0.2};
    for (int j = 0; j < n; ++j) ref.written.push_back(force(j));
    const std::vector<double> coarse = ref.positions(2000), fine = ref.positions(4000);
    double deviation = 0.0, estimate = 0.0, scale = 0.0;
    int stuck = 0, sliding = 0;
    for (int j = 0; j < n; ++j) {
        deviation = std::max(deviation, std::abs(x[j] - fine[j]));
        estimate = std::max(estimate, std::abs(coarse[j] - fine[j]));
        scale = std::max(scale, std::abs(fine[j]));
        (j > 0 && x[j] == x[j - 1] ? stuck : sliding) += 1;
    }
    std::printf(
        "friction: max |device - reference| %.3g m, reference's change T/2000 -> T/4000 %.3g m, motion "
        "%.3g m; %d ticks stuck, %d sliding\n",
        deviation, estimate, scale, stuck, sliding);
    EXPECT_LE(deviation, 4 * estimate + 1e-12);
    EXPECT_GT(stuck, 50);
    EXPECT_GT(sliding, 50);
    EXPECT_GT(scale, 1e-3);
}

TEST(SimDeviceFriction, InvalidFrictionIsRefusedNamingTheParameter) {
    auto negative = friction_base(0.3, -0.1);
    EXPECT_THROW(SimDevice{negative}, std::invalid_argument);
    auto nan = friction_base(0.3, std::nan(""));
    EXPECT_THROW(SimDevice{nan}, std::invalid_argument);
    auto coupled = friction_base(0.3, 0.1);
    coupled.capabilities.axes = 2;
    coupled.mass_matrix = std::array<AxisVector, kMaxAxes>{AxisVector{0.3, 0.02, 0.0}, AxisVector{0.02, 0.3, 0.0},
                                                           AxisVector{0.0, 0.0, 0.3}};
    try {
        SimDevice dev(coupled);
        ADD_FAILURE() << "accepted coulomb_friction with a coupled mass matrix";
    } catch (const std::invalid_argument& e) {
        EXPECT_NE(std::string(e.what()).find("SimDevice: coulomb_friction[0]"), std::string::npos) << e.what();
    }
    coupled.coulomb_friction = {};  // without friction the coupled matrix is simulated
    EXPECT_NO_THROW(SimDevice{coupled});
}

}  // namespace hapticd::sim_friction_test
