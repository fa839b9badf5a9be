// SPDX-License-Identifier: Apache-2.0
// Coulomb friction and encoder quantisation (include/hapticopt/limit_cycles.hpp) against an independent
// time-stepping simulation written here: a mass with viscous damping and Coulomb friction (stick and slip
// handled event by event: the exact motion under a constant force between events, v = 0 crossings located
// in closed form, sticking while the applied force is within the friction limit), the encoder rounding
// x(jT) to the step q, the wall force K y_j + B v_j held for one period and delayed by d periods, v_j the
// velocity estimate written out as its difference equation (backward (y_j - y_{j-1}) / T; low-pass
// v_j = lambda v_{j-1} + (1 - lambda)(y_j - y_{j-1}) / T, lambda = exp(-2 pi nu); window (y_j - y_{j-N}) / (N T),
// y_{j-i} = y_0 before the start). It shares no code with the header.
#include <gtest/gtest.h>

#include <cmath>
#include <complex>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <utility>
#include <sys/wait.h>
#include <hapticopt/hapticopt.hpp>
#include <limits>
#include <vector>

#include "common/test_paths.hpp"

namespace hapticopt::limit_cycle_test {

struct Device {
    double mass = 0.3, damping = 0, friction = 0, period = 1e-3;
    int delay = 0;
    double stiffness = 0, wall_damping = 0, step = 20e-6, push = 0;
    double cutoff = 0;  ///< low-pass nu = f_c T when > 0
    int window = 0;     ///< window N when > 0; neither: the backward difference
};

struct Motion {
    double amplitude = 0;        ///< half the peak-to-peak of x(t) over the observed window [m]
    double fundamental = 0;      ///< amplitude of x's Fourier component at `frequency` over the window [m]
    double frequency = 0;        ///< upward crossings of the window mean per second [Hz]
    double mean = 0;             ///< mean of x over the window [m]
    double start_amplitude = 0;  ///< half the peak-to-peak over the first `window` periods after the kick [m]
    bool at_rest = false;        ///< no motion at all over the window
};

/// Exact motion under constant acceleration a and viscous rate c = b/m for time t.
inline void advance_free(double& x, double& v, double a, double c, double t) {
    if (c * t < 1e-9) {
        x += v * t + 0.5 * a * t * t;
        v += a * t;
        return;
    }
    const double e = std::exp(-c * t), terminal = a / c;
    x += terminal * t + (v - terminal) * (1 - e) / c;
    v = terminal + (v - terminal) * e;
}

/// Time until v reaches 0 under a, c (infinity if it does not).
inline double time_to_stop(double v, double a, double c) {
    if (v == 0) return 0;
    if (c == 0) return (a * v < 0) ? -v / a : std::numeric_limits<double>::infinity();
    const double terminal = a / c;
    if (terminal * v >= 0) return std::numeric_limits<double>::infinity();
    return -std::log(-terminal / (v - terminal)) / c;
}

/// Advances (x, v) by t under the applied force `applied` (everything but friction and viscous damping).
inline void advance(const Device& s, double& x, double& v, double applied, double t) {
    const double c = s.damping / s.mass;
    while (t > 0) {
        if (v == 0) {
            if (std::abs(applied) <= s.friction) return;  // sticks for the rest of the interval
            const double a = (applied - std::copysign(s.friction, applied)) / s.mass;
            // leave rest: a tiny time step of slip in the direction of the applied force
            const double h = std::min(t, 1e-9 * s.period);
            advance_free(x, v, a, c, h);
            t -= h;
            continue;
        }
        const double a = (applied - std::copysign(s.friction, v)) / s.mass;
        const double stop = time_to_stop(v, a, c);
        if (stop >= t) {
            advance_free(x, v, a, c, t);
            return;
        }
        advance_free(x, v, a, c, stop);
        v = 0;
        t -= stop;
    }
}

/// Runs `periods` periods from x(0) = x0, x'(0) = v0 (y_{-1} = y_0) and observes the last `window` periods on
/// a grid of `sub` points a period.
inline Motion simulate(const Device& s, double x0, double v0, int periods, int window, int sub = 40) {
    auto quantise = [&](double x) { return s.step * std::round(x / s.step); };
    std::vector<double> forces;
    double x = x0, v = v0, y_prev = quantise(x0);
    std::vector<double> history(static_cast<std::size_t>(std::max(s.window, 1)), y_prev);  // y_{j-N} .. y_{j-1}
    const double lambda = std::exp(-2 * 3.14159265358979323846 * s.cutoff);
    double estimate = 0;
    std::vector<double> trace;
    trace.reserve(static_cast<std::size_t>(window) * sub);
    double first_lo = x0, first_hi = x0;
    bool moved = false;
    for (int j = 0; j < periods; ++j) {
        const double y = quantise(x);
        if (s.window > 0) {
            estimate = (y - history.front()) / (s.window * s.period);
            history.erase(history.begin());
            history.push_back(y);
        } else if (s.cutoff > 0) {
            estimate = lambda * estimate + (1 - lambda) * (y - y_prev) / s.period;
        }
        forces.push_back(s.window > 0 || s.cutoff > 0 ? s.stiffness * y + s.wall_damping * estimate
                                                      : s.stiffness * y + s.wall_damping * (y - y_prev) / s.period);
        y_prev = y;
        const double wall = j >= s.delay ? forces[static_cast<std::size_t>(j - s.delay)] : 0.0;
        for (int k = 0; k < sub; ++k) {
            const double before = x;
            advance(s, x, v, s.push - wall, s.period / sub);
            if (j < window) {
                first_lo = std::min(first_lo, x);
                first_hi = std::max(first_hi, x);
            }
            if (j >= periods - window) {
                trace.push_back(x);
                if (x != before) moved = true;
            }
        }
    }
    Motion m;
    m.start_amplitude = (first_hi - first_lo) / 2;
    double lo = trace[0], hi = trace[0], sum = 0;
    for (double p : trace) {
        lo = std::min(lo, p);
        hi = std::max(hi, p);
        sum += p;
    }
    m.mean = sum / static_cast<double>(trace.size());
    m.amplitude = (hi - lo) / 2;
    m.at_rest = !moved;
    if (m.at_rest || m.amplitude == 0) return m;
    const double band = 0.1 * m.amplitude;
    const double dt = s.period / sub;
    int crossings = 0;
    double first = -1, last = -1;
    bool below = trace[0] < m.mean - band;
    for (std::size_t i = 1; i < trace.size(); ++i) {
        if (below && trace[i] > m.mean + band) {
            below = false;
            ++crossings;
            if (first < 0) first = static_cast<double>(i) * dt;
            last = static_cast<double>(i) * dt;
        } else if (!below && trace[i] < m.mean - band) {
            below = true;
        }
    }
    if (crossings >= 2) m.frequency = (crossings - 1) / (last - first);
    if (m.frequency > 0) {  // Fourier component over the whole cycles between the first and last crossing
        const auto i0 = static_cast<std::size_t>(first / dt), i1 = static_cast<std::size_t>(last / dt);
        double re = 0, im = 0;
        for (std::size_t i = i0; i < i1; ++i) {
            const double t = static_cast<double>(i) * dt, w = 2 * 3.14159265358979323846 * m.frequency;
            re += (trace[i] - m.mean) * std::cos(w * t);
            im += (trace[i] - m.mean) * std::sin(w * t);
        }
        m.fundamental = 2 * std::hypot(re, im) / static_cast<double>(i1 - i0);
    }
    return m;
}

inline LimitCycleLoop loop_of(const Device& s) {
    LimitCycleLoop l;
    l.plant = PhysicalPlant{s.mass, s.damping, 0.0, s.period, s.delay * s.period};
    l.gains = WallGains{s.stiffness, s.wall_damping};
    l.coulomb_friction = s.friction;
    l.position_step = s.step;
    l.external_force = s.push;
    if (s.window > 0) l.estimator = VelocityEstimator::moving_window(s.window);
    if (s.cutoff > 0) l.estimator = VelocityEstimator::low_pass(s.cutoff);
    return l;
}

// The paper's C_E2 optimum (Table III, d = 0: alpha 0.2474, beta 0.7445; Table IV, d = 1: 0.0582, 0.3796,
// gamma = delta = 0) on a Falcon-like device: m = 0.3 kg, T = 1 ms, q = 20 um, b = 0.
// d = 6: the C_E2 optimum of optimal_point (gamma = delta = 0), alpha 0.004664, beta 0.1123 (K 1399 N/m,
// B 33.7 N s/m).
inline Device tuned(int d, double friction, double fraction) {
    Device s;
    s.delay = d;
    double alpha = d == 0 ? 0.2474 : 0.0582, beta = d == 0 ? 0.7445 : 0.3796;
    if (d == 6) {
        const Optimum o = optimal_point(Criterion::CE2, NormalizedPlant{0, 0, 6});
        alpha = o.alpha;
        beta = o.beta;
    }
    s.stiffness = alpha * s.mass / (s.period * s.period);
    s.wall_damping = beta * s.mass / s.period;
    s.friction = friction;
    s.push = s.stiffness * s.step * (100 + fraction);  // F / (K q) = 100 + fraction
    return s;
}

// Prints the table of docs/limit-cycles.md and checks the rows inside the DF's hypothesis, chosen before
// measuring: symmetric chatter (the push half-way between two levels, r = 1/2), Coulomb friction present and
// too weak to hold any rest (quantised_rest_exists false), so the mass slides through the cycle.
// Tolerances. Frequency: a periodic orbit of the sampled loop lasts a whole number P of periods (or a
// rational one), the DF's theta is continuous; the measured frequency must lie between 1/(ceil(P) T) and
// 1/(floor(P) T), P = 1/(f_DF T), widened by 1 % for the crossing count over a finite window (about 500
// cycles: 0.2 %). Amplitude (fundamental of x): 20 %. The DF drops the harmonics: the quantiser's output
// is close to a square wave (third harmonic 1/3 of the fundamental) and the mass attenuates the third
// harmonic 9 times more than the fundamental, about 4 % of distortion; the rest of the 20 % is for the
// sampling of the quantiser's input (the duty cycle is realised in whole periods), which the DF does not model.
TEST(LimitCycles, PredictionAgainstSimulation) {
    std::printf(
        "| d | f_c [N] | r | rest exists | DF: A [um] | DF: f [Hz] | DF stable | sim: A_peak [um] | "
        "sim: A_fund [um] | sim: f [Hz] | sim at rest |\n");
    int checked = 0;
    for (int d : {0, 1, 6}) {
        for (double fc : {0.0, 0.1, 0.3, 1.0, 3.0}) {
            for (double r : {0.5, 0.25}) {
                const Device s = tuned(d, fc, r);
                const bool rest = quantised_rest_exists(s.push, s.stiffness, s.friction, s.step);
                const auto p = predict_limit_cycle(loop_of(s));
                const Motion m = simulate(s, s.push / s.stiffness + 3 * s.step, 0, 6000, 2000);
                std::printf("| %d | %.1f | %.2f | %s | %.2f | %.1f | %s | %.2f | %.2f | %.1f | %s |\n", d, fc, r,
                            rest ? "yes" : "no", p.predicted ? p.cycle.amplitude * 1e6 : 0.0,
                            p.predicted ? p.cycle.frequency : 0.0, p.predicted ? (p.cycle.stable ? "yes" : "no") : "-",
                            m.amplitude * 1e6, m.fundamental * 1e6, m.frequency, m.at_rest ? "yes" : "no");
                // Without a rest the motion cannot stop: a check of the condition and of the simulation.
                if (!rest) {
                    EXPECT_FALSE(m.at_rest) << "d " << d << " f_c " << fc << " r " << r;
                }
                if (!(r == 0.5 && fc > 0 && !rest)) continue;
                ++checked;
                ASSERT_TRUE(p.predicted);
                EXPECT_TRUE(p.cycle.stable);
                const double periods = 1 / (p.cycle.frequency * s.period);
                EXPECT_GE(m.frequency, 0.99 / (std::ceil(periods) * s.period)) << "d " << d << " f_c " << fc;
                EXPECT_LE(m.frequency, 1.01 / (std::floor(periods) * s.period)) << "d " << d << " f_c " << fc;
                EXPECT_NEAR(m.fundamental, p.cycle.amplitude, 0.2 * p.cycle.amplitude) << "d " << d << " f_c " << fc;
            }
        }
    }
    EXPECT_EQ(checked, 3);  // d = 0: f_c 0.1, 0.3; d = 1: f_c 0.1
}

// Without friction and with the push half-way between levels the DF is the relay's: A = (2 q / pi) |G| at
// the phase crossover. Reference computed here independently: the ZOH pulse transfer of a free mass,
// P(z) = T^2 (z + 1) / (2 m (z - 1)^2) (Franklin, Powell, Workman, "Digital Control of Dynamic Systems", the
// double integrator), G = z^-d P(z) (K + B (1 - 1/z) / T), its crossover by bisection of Im G.
TEST(LimitCycles, FrictionlessRelayMatchesClosedForm) {
    for (int d : {0, 1, 3}) {
        Device s = tuned(d == 0 ? 0 : 1, 0.0, 0.5);
        s.delay = d;
        if (d == 3) {  // a stable wall at d = 3 (the C_E2 gains of d = 1 are not)
            s.stiffness = 0.01 * s.mass / (s.period * s.period);
            s.wall_damping = 0.2 * s.mass / s.period;
            s.push = s.stiffness * s.step * 100.5;
        }
        auto g = [&](double theta) {
            const std::complex<double> z = std::polar(1.0, theta);
            const std::complex<double> p = s.period * s.period * (z + 1.0) / (2 * s.mass * (z - 1.0) * (z - 1.0));
            return std::pow(z, -d) * p * (s.stiffness + s.wall_damping * (1.0 - 1.0 / z) / s.period);
        };
        double best_gain = 0, best_theta = 0;
        const int n = 4096;
        for (int i = 1; i < n; ++i) {
            double lo = 3.14159265358979323846 * i / n, hi = 3.14159265358979323846 * (i + 1) / n;
            if ((g(lo).imag() > 0) == (g(hi).imag() > 0)) continue;
            for (int it = 0; it < 100; ++it) {
                const double mid = (lo + hi) / 2;
                ((g(mid).imag() > 0) == (g(lo).imag() > 0) ? lo : hi) = mid;
            }
            const double re = g(lo).real();
            if (re < 0 && -re > best_gain) {
                best_gain = -re;
                best_theta = lo;
            }
        }
        const double amplitude = 2 * s.step / 3.14159265358979323846 * best_gain;
        const auto p = predict_limit_cycle(loop_of(s));
        ASSERT_TRUE(p.predicted) << "d " << d;
        // 1e-6 relative: the header's amplitude bisection stops at 1e-12 relative and its balance residual
        // at 1e-6 (|h| < 1e-6 is accepted); the crossover is bisected to 1e-13 rad.
        EXPECT_NEAR(p.cycle.amplitude, amplitude, 1e-6 * amplitude) << "d " << d;
        EXPECT_NEAR(p.cycle.theta, best_theta, 1e-9) << "d " << d;
        EXPECT_NEAR(p.cycle.mean_position, (100.5) * s.step, 1e-9 * s.step) << "d " << d;  // on the threshold
    }
}

// Abbott-Okamura (B = 0, d = 0) against the simulation. Where K <= max(2b/T, 2 f_c/q) and the start is slow
// (kicks up to 0.005 m/s, a quarter of a count per period; pushes at a level, a quarter and half-way between
// levels) the motion does not grow, and with friction it ends within one count: no sustained oscillation
// larger than the quantisation (a sub-count chatter remains where no rest exists, see quantised_rest_exists).
// Where the condition fails a sustained or growing motion is found. And the measured limit of the Coulomb
// mode: a fast start (0.05 m/s, 2.5 counts per period) on a wall with b = 0 that satisfies K <= 2 f_c / q
// grows without bound (the held force's energy gain per period grows with the square of the motion per
// period, the Coulomb loss only linearly).
TEST(LimitCycles, AbbottOkamuraAgainstSimulation) {
    struct Case {
        double stiffness, damping, friction;
    };
    const Case passive[] = {{20000, 0, 0.3}, {29000, 0, 0.3}, {3000, 2, 0.01}, {3900, 2, 0.05}};
    auto device = [](const Case& c, double fraction) {
        Device s;
        s.stiffness = c.stiffness;
        s.damping = c.damping;
        s.friction = c.friction;
        s.push = c.stiffness * s.step * (50 + fraction);
        return s;
    };
    for (const Case& c : passive) {
        EXPECT_TRUE(abbott_okamura_passivity(c.stiffness, c.damping, c.friction, 20e-6, 1e-3).passive);
        for (double r : {0.0, 0.25, 0.5}) {
            for (double kick : {0.0, 0.001, 0.005}) {
                const Device s = device(c, r);
                const Motion m = simulate(s, s.push / s.stiffness + 2.3 * s.step, kick, 8000, 500);
                EXPECT_LE(m.amplitude, m.start_amplitude) << "K " << c.stiffness << " b " << c.damping << " f_c "
                                                          << c.friction << " r " << r << " kick " << kick;
                EXPECT_LT(m.amplitude, s.step) << "K " << c.stiffness << " b " << c.damping << " f_c " << c.friction
                                               << " r " << r << " kick " << kick;
            }
        }
    }
    {  // the Coulomb mode violated: no rest half-way between levels, a sustained chatter
        const Case c{45000, 0, 0.3};
        EXPECT_FALSE(abbott_okamura_passivity(c.stiffness, c.damping, c.friction, 20e-6, 1e-3).passive);
        const Device s = device(c, 0.5);
        const Motion m = simulate(s, s.push / s.stiffness + 2.3 * s.step, 0.001, 8000, 500);
        EXPECT_FALSE(m.at_rest);
        EXPECT_GT(m.amplitude, 0.1 * s.step);
    }
    {  // the viscous mode violated (K T / 2 = 3 > b = 2): a large motion grows
        const Case c{6000, 2, 0.01};
        EXPECT_FALSE(abbott_okamura_passivity(c.stiffness, c.damping, c.friction, 20e-6, 1e-3).passive);
        const Device s = device(c, 0.5);
        const Motion m = simulate(s, s.push / s.stiffness, 0.05, 3000, 300);
        EXPECT_GT(m.amplitude, 10 * m.start_amplitude);
    }
    {  // the measured limit of the Coulomb mode: a fast start grows although K <= 2 f_c / q
        const Case c{20000, 0, 0.3};
        EXPECT_TRUE(abbott_okamura_passivity(c.stiffness, c.damping, c.friction, 20e-6, 1e-3).passive);
        const Device s = device(c, 0.5);
        const Motion m = simulate(s, s.push / s.stiffness, 0.05, 3000, 300);
        EXPECT_GT(m.amplitude, 10 * m.start_amplitude);
    }
}

// The CE2 optimum of optimal_point(Criterion::CE2, plant, estimator) (gamma = delta = 0), as tabulated in
// docs/velocity-estimation.md ("alpha_max and the CE2 optimum per estimator"), on the Falcon-like device
// above. Estimators: low-pass nu = 0.02 and 0.1 (20 and 100 Hz at 1 kHz), windows 5 and 15. Coulomb friction
// as a fraction of K q (the wall's force per count): below 1/2 no rest holds a push half-way between levels.
struct EstimatorCase {
    const char* name;
    double cutoff;
    int window;
    int delay;
    double alpha, beta;
};
inline const EstimatorCase kEstimatorCases[] = {
    {"lowpass:0.02", 0.02, 0, 0, 0.00887858, 0.160849}, {"lowpass:0.1", 0.1, 0, 0, 0.0747747, 0.419876},
    {"window:5", 0, 5, 0, 0.031198, 0.238747},          {"window:15", 0, 15, 0, 0.00467425, 0.0897551},
    {"lowpass:0.02", 0.02, 0, 1, 0.00464357, 0.107497}, {"lowpass:0.1", 0.1, 0, 1, 0.0265711, 0.249125},
    {"window:5", 0, 5, 1, 0.0159384, 0.179724},         {"window:15", 0, 15, 1, 0.00346339, 0.0793856},
    {"lowpass:0.02", 0.02, 0, 6, 0.0012874, 0.0549007}, {"lowpass:0.1", 0.1, 0, 6, 0.00348768, 0.0942289},
    {"window:5", 0, 5, 6, 0.00287685, 0.0833798},       {"window:15", 0, 15, 6, 0.00126107, 0.0516488},
};

inline Device tuned_with(const EstimatorCase& c, double friction_per_count, double fraction) {
    Device s;
    s.delay = c.delay;
    s.cutoff = c.cutoff;
    s.window = c.window;
    s.stiffness = c.alpha * s.mass / (s.period * s.period);
    s.wall_damping = c.beta * s.mass / s.period;
    s.friction = friction_per_count * s.stiffness * s.step;
    s.push = s.stiffness * s.step * (100 + fraction);
    return s;
}

// The loop transfer written out here (integer d): G(z) = z^-d P(z) (K + B D(z)), P the ZOH pulse transfer of
// 1 / (m s^2 + b s), a = b / m, e = exp(-a T): P(z) = (T / (z - 1) - (1 - e) / (a (z - e))) / b, and
// T^2 (z + 1) / (2 m (z - 1)^2) as b -> 0 (Franklin, Powell, Workman, "Digital Control of Dynamic Systems",
// the ZOH equivalent of a first-order lag times an integrator); D(z) the estimator's transfer (low-pass
// (1 - lambda)(1 - 1/z) / (T (1 - lambda / z)), window (1 - z^-N) / (N T), backward (1 - 1/z) / T).
inline std::complex<double> loop_transfer(const Device& s, double damping, double theta) {
    const std::complex<double> z = std::polar(1.0, theta);
    const double T = s.period;
    std::complex<double> p;
    if (damping * T / s.mass < 1e-9) {
        p = T * T * (z + 1.0) / (2 * s.mass * (z - 1.0) * (z - 1.0));
    } else {
        const double a = damping / s.mass, e = std::exp(-a * T);
        p = (T / (z - 1.0) - (1 - e) / (a * (z - e))) / damping;
    }
    std::complex<double> d = (1.0 - 1.0 / z) / T;
    if (s.cutoff > 0) {
        const double lambda = std::exp(-2 * 3.14159265358979323846 * s.cutoff);
        d = (1 - lambda) * (1.0 - 1.0 / z) / (T * (1.0 - lambda / z));
    } else if (s.window > 0) {
        d = (1.0 - std::pow(z, -s.window)) / (s.window * T);
    }
    return std::pow(z, -s.delay) * p * (s.stiffness + s.wall_damping * d);
}

/// What the DF leaves out of the phase: the sampled quantiser switches at the first sample after its input
/// crosses a threshold; as a sequence its edge lies half-way between that sample and the one before, up to
/// half a period from the crossing either way, so the phase of its output's fundamental is uncertain by up to
/// +-theta/2 (theta = w T), depending on where the samples fall, which the continuous DF averages out. The band of
/// theta where arg(-G) is within +-theta*/2 of the crossover theta* (b_eq held at the DF cycle's), and |G| over that
/// band relative to |G(theta*)|: with one threshold crossed the relay's balance gives A = (2 q / pi) |G|, so the
/// amplitude moves with |G|.
struct PhaseBand {
    double theta_lo = 0, theta_hi = 0, gain_lo = 1, gain_hi = 1, phase_at_crossover = 0;
};

inline PhaseBand phase_band(const Device& s, const PredictedLimitCycle& c) {
    constexpr double pi = 3.14159265358979323846;
    const double damping = s.damping + c.equivalent_damping;
    auto phase = [&](double theta) { return std::arg(-loop_transfer(s, damping, theta)); };
    PhaseBand band;
    band.phase_at_crossover = phase(c.theta);
    const double half = c.theta / 2, step = c.theta / 400;
    auto edge = [&](double direction, double limit) {  // first theta from theta* where |arg(-G)| >= half
        double inside = c.theta;
        for (double t = c.theta + direction * step; direction > 0 ? t < limit : t > limit; t += direction * step) {
            if (std::abs(phase(t)) >= half) {
                double lo = inside, hi = t;
                for (int i = 0; i < 60; ++i) {
                    const double mid = (lo + hi) / 2;
                    (std::abs(phase(mid)) >= half ? hi : lo) = mid;
                }
                return lo;
            }
            inside = t;
        }
        return limit;
    };
    band.theta_lo = edge(-1, step);
    band.theta_hi = edge(+1, pi);
    const double g0 = std::abs(loop_transfer(s, damping, c.theta));
    band.gain_lo = band.gain_hi = 1;
    for (int i = 0; i <= 100; ++i) {
        const double t = band.theta_lo + (band.theta_hi - band.theta_lo) * i / 100;
        const double ratio = std::abs(loop_transfer(s, damping, t)) / g0;
        band.gain_lo = std::min(band.gain_lo, ratio);
        band.gain_hi = std::max(band.gain_hi, ratio);
    }
    return band;
}

// The estimator's describing function against the simulation with the estimator's difference equation, on
// the rows inside the DF's hypothesis chosen by the rule of PredictionAgainstSimulation before measuring:
// push half-way between two levels, Coulomb friction present and too weak to hold any rest (f_c = 0.1 and
// 0.3 K q), so the mass slides through the cycle. Prints the rows of docs/limit-cycles.md ("With a velocity
// estimator"; the other rows: EstimatorLimitCycleTable).
// Tolerances. Frequency: the filtered walls' cycles last 6 to 60 periods, where the whole-period bracket of
// PredictionAgainstSimulation is narrower than the DF's own phase error; the bracket is taken over the
// phase band (PhaseBand): the measured frequency between 1/(ceil(P_lo) T) and 1/(floor(P_hi) T),
// P = 2 pi / theta at the band's ends, widened by 1 % for the finite window. Amplitude (fundamental of x):
// the DF amplitude times the band's |G| ratios, widened by 20 % (PredictionAgainstSimulation's budget for
// the dropped harmonics and the sampled duty cycle).
TEST(LimitCycles, EstimatorPredictionAgainstSimulation) {
    constexpr double pi = 3.14159265358979323846;
    std::printf(
        "| estimator | d | f_c / (K q) | DF: A [um] | DF: f [Hz] | band f [Hz] | band A [um] | sim: A_fund [um] | "
        "sim: f [Hz] |\n");
    int checked = 0;
    for (const EstimatorCase& c : kEstimatorCases) {
        for (double fc : {0.1, 0.3}) {
            const Device s = tuned_with(c, fc, 0.5);
            const std::string row =
                std::string(c.name) + " d " + std::to_string(c.delay) + " f_c " + std::to_string(fc);
            ASSERT_FALSE(quantised_rest_exists(s.push, s.stiffness, s.friction, s.step)) << row;
            const auto p = predict_limit_cycle(loop_of(s));
            ASSERT_TRUE(p.predicted) << row;
            const Motion m = simulate(s, s.push / s.stiffness + 3 * s.step, 0, 6000, 2000);
            const PhaseBand band = phase_band(s, p.cycle);
            const double f_lo = 0.99 / (std::ceil(2 * pi / band.theta_lo) * s.period);
            const double f_hi = 1.01 / (std::floor(2 * pi / band.theta_hi) * s.period);
            const double a_lo = 0.8 * band.gain_lo * p.cycle.amplitude, a_hi = 1.2 * band.gain_hi * p.cycle.amplitude;
            std::printf("| %s | %d | %.1f | %.2f | %.1f | %.1f - %.1f | %.2f - %.2f | %.2f | %.1f |\n", c.name, c.delay,
                        fc, p.cycle.amplitude * 1e6, p.cycle.frequency, f_lo, f_hi, a_lo * 1e6, a_hi * 1e6,
                        m.fundamental * 1e6, m.frequency);
            ++checked;
            // the library's crossover against the transfer written out here: arg(-G) = 0 to the bisection's
            // 1e-13 rad in theta times the phase slope (below 1e3 here)
            EXPECT_NEAR(band.phase_at_crossover, 0.0, 1e-9) << row;
            EXPECT_TRUE(p.cycle.stable) << row;
            EXPECT_FALSE(m.at_rest) << row;
            EXPECT_GE(m.frequency, f_lo) << row;
            EXPECT_LE(m.frequency, f_hi) << row;
            EXPECT_GE(m.fundamental, a_lo) << row;
            EXPECT_LE(m.fundamental, a_hi) << row;
        }
    }
    EXPECT_EQ(checked, 24);
}

// Frictionless, push half-way: the relay's A = (2 q / pi) |G| at the phase crossover with the largest |G|,
// G from loop_transfer (written out here, not the library's polynomials), crossover by a 4096-point scan and
// bisection of Im G. Tolerances as in FrictionlessRelayMatchesClosedForm (the header's bisections).
TEST(LimitCycles, EstimatorFrictionlessRelayMatchesClosedForm) {
    constexpr double pi = 3.14159265358979323846;
    for (const EstimatorCase& c : kEstimatorCases) {
        const Device s = tuned_with(c, 0.0, 0.5);
        auto g = [&](double theta) { return loop_transfer(s, 0.0, theta); };
        double best_gain = 0, best_theta = 0;
        const int n = 4096;
        for (int i = 1; i < n; ++i) {
            double lo = pi * i / n, hi = pi * (i + 1) / n;
            if ((g(lo).imag() > 0) == (g(hi).imag() > 0)) continue;
            for (int it = 0; it < 100; ++it) {
                const double mid = (lo + hi) / 2;
                ((g(mid).imag() > 0) == (g(lo).imag() > 0) ? lo : hi) = mid;
            }
            const double re = g(lo).real();
            if (re < 0 && -re > best_gain) {
                best_gain = -re;
                best_theta = lo;
            }
        }
        const double amplitude = 2 * s.step / pi * best_gain;
        const auto p = predict_limit_cycle(loop_of(s));
        ASSERT_TRUE(p.predicted) << c.name << " d " << c.delay;
        EXPECT_NEAR(p.cycle.amplitude, amplitude, 1e-6 * amplitude) << c.name << " d " << c.delay;
        EXPECT_NEAR(p.cycle.theta, best_theta, 1e-9) << c.name << " d " << c.delay;
        EXPECT_NEAR(p.cycle.mean_position, 100.5 * s.step, 1e-9 * s.step) << c.name << " d " << c.delay;
    }
}

// The default estimator is the backward difference, and two estimators equal to it through the estimator's
// polynomial p_est (window N = 1: D = (1 - 1/z) / T exactly; low-pass nu = 6: lambda = exp(-12 pi) = 4e-17)
// give its cycle: 1e-9 relative (the root bisection stops at 1e-12 relative, the balance residual |h| at
// 1e-6 is accepted but the same h is evaluated at the same amplitudes up to the rounding of the longer
// polynomial; the friction's b_eq makes h depend on the crossover, bisected to 1e-13 rad).
TEST(LimitCycles, BackwardEquivalentEstimatorsGiveTheBackwardCycle) {
    EXPECT_EQ(LimitCycleLoop{}.estimator.kind, VelocityEstimatorKind::backward);
    for (const auto& [d, fc] : {std::pair<int, double>{0, 0.1}, {1, 0.1}, {6, 0.0}}) {
        const Device s = tuned(d, fc, 0.5);
        const auto backward = predict_limit_cycle(loop_of(s));
        ASSERT_TRUE(backward.predicted) << "d " << d << " f_c " << fc;
        for (const VelocityEstimator& e : {VelocityEstimator::moving_window(1), VelocityEstimator::low_pass(6)}) {
            LimitCycleLoop l = loop_of(s);
            l.estimator = e;
            const auto p = predict_limit_cycle(l);
            ASSERT_EQ(p.cycles.size(), backward.cycles.size()) << "d " << d << " f_c " << fc;
            EXPECT_NEAR(p.cycle.amplitude, backward.cycle.amplitude, 1e-9 * backward.cycle.amplitude)
                << "d " << d << " f_c " << fc;
            EXPECT_NEAR(p.cycle.theta, backward.cycle.theta, 1e-9) << "d " << d << " f_c " << fc;
            EXPECT_EQ(p.cycle.stable, backward.cycle.stable) << "d " << d << " f_c " << fc;
        }
    }
}

// The whole table of docs/limit-cycles.md ("With a velocity estimator"): every estimator and delay with
// f_c / (K q) = 0, 0.1, 0.3, 1 and the push half-way (r = 0.5) or a quarter (r = 0.25) between levels
// (about 12 s). Checks only what holds on every row: where no quantised rest exists the motion does not stop.
TEST(LimitCycles, EstimatorLimitCycleTable) {
    std::printf(
        "| estimator | d | K [N/m] | B [N s/m] | f_c / (K q) | r | rest exists | DF: A [um] | DF: f [Hz] | DF stable | "
        "sim: A_peak [um] | sim: A_fund [um] | sim: f [Hz] | sim at rest |\n");
    for (const EstimatorCase& c : kEstimatorCases) {
        for (double fc : {0.0, 0.1, 0.3, 1.0}) {
            for (double r : {0.5, 0.25}) {
                const Device s = tuned_with(c, fc, r);
                const bool rest = quantised_rest_exists(s.push, s.stiffness, s.friction, s.step);
                const auto p = predict_limit_cycle(loop_of(s));
                const Motion m = simulate(s, s.push / s.stiffness + 3 * s.step, 0, 6000, 2000);
                std::printf(
                    "| %s | %d | %.1f | %.2f | %.1f | %.2f | %s | %.2f | %.1f | %s | %.2f | %.2f | %.1f | %s |\n",
                    c.name, c.delay, s.stiffness, s.wall_damping, fc, r, rest ? "yes" : "no",
                    p.predicted ? p.cycle.amplitude * 1e6 : 0.0, p.predicted ? p.cycle.frequency : 0.0,
                    p.predicted ? (p.cycle.stable ? "yes" : "no") : "-", m.amplitude * 1e6, m.fundamental * 1e6,
                    m.frequency, m.at_rest ? "yes" : "no");
                if (!rest) {
                    EXPECT_FALSE(m.at_rest) << c.name << " d " << c.delay << " f_c " << fc << " r " << r;
                }
            }
        }
    }
}

TEST(LimitCycles, ConditionValues) {
    const auto a = abbott_okamura_passivity(29000, 2, 0.3, 20e-6, 1e-3);
    EXPECT_DOUBLE_EQ(a.viscous_bound, 4000);
    EXPECT_NEAR(a.coulomb_bound, 30000, 1e-9);
    EXPECT_NEAR(a.stiffness_bound, 30000, 1e-9);
    EXPECT_TRUE(a.passive);
    EXPECT_FALSE(abbott_okamura_passivity(30000.01, 2, 0.3, 20e-6, 1e-3).passive);
    // rest: |F - K n q| <= f_c; K q = 1 N here
    EXPECT_TRUE(quantised_rest_exists(10.3, 50000, 0.31, 20e-6));
    EXPECT_FALSE(quantised_rest_exists(10.5, 50000, 0.49, 20e-6));
    EXPECT_TRUE(quantised_rest_exists(10.5, 50000, 0.51, 20e-6));
    EXPECT_TRUE(quantised_rest_exists(-3.0, 50000, 1e-3, 20e-6));  // a level, up to rounding of K q
    // with a physical spring k = 10000 N/m (k q = 0.2 N): at level n the wall and spring give n + 0.2 x / q
    // [N] with x / q in [n - 1/2, n + 1/2], i.e. [1.2 n - 0.1, 1.2 n + 0.1]; F = 10.5 N lies 0.2 N below n = 9
    EXPECT_TRUE(quantised_rest_exists(10.8, 50000, 0.0, 20e-6, 10000));
    EXPECT_FALSE(quantised_rest_exists(10.5, 50000, 0.19, 20e-6, 10000));
    EXPECT_TRUE(quantised_rest_exists(10.5, 50000, 0.21, 20e-6, 10000));
}

TEST(LimitCycles, InvalidParametersAreNamed) {
    auto expect_named = [](auto&& call, const std::string& parameter) {
        try {
            call();
            ADD_FAILURE() << "no exception for " << parameter;
        } catch (const InvalidParameter& e) {
            EXPECT_EQ(e.parameter(), parameter);
            EXPECT_NE(std::string(e.what()).find("hapticopt::"), std::string::npos);
        }
    };
    LimitCycleLoop good = loop_of(tuned(0, 0.1, 0.5));
    auto with = [&](auto change) {
        LimitCycleLoop l = good;
        change(l);
        return [l] { predict_limit_cycle(l); };
    };
    expect_named(with([](LimitCycleLoop& l) { l.position_step = 0; }), "position_step");
    expect_named(with([](LimitCycleLoop& l) { l.coulomb_friction = -1; }), "coulomb_friction");
    expect_named(with([](LimitCycleLoop& l) { l.gains.stiffness = 0; }), "gains.stiffness");
    expect_named(with([](LimitCycleLoop& l) { l.plant.stiffness = -1; }), "stiffness");
    expect_named(with([](LimitCycleLoop& l) { l.external_force = NAN; }), "external_force");
    expect_named(with([](LimitCycleLoop& l) { l.plant.mass = 0; }), "mass");
    expect_named(with([](LimitCycleLoop& l) { l.plant.time_delay = 2; }), "time_delay");
    expect_named(with([](LimitCycleLoop& l) { l.estimator.kind = VelocityEstimatorKind::lowpass; }), "cutoff");
    expect_named(with([](LimitCycleLoop& l) { l.estimator = {VelocityEstimatorKind::window, 0, 1001}; }), "window");
    expect_named([] { abbott_okamura_passivity(1, 0, 0, -1, 1e-3); }, "position_step");
    expect_named([] { quantised_rest_exists(1, 1, -0.1, 1e-6); }, "coulomb_friction");
}

#ifdef HAPTICOPT_CLI
inline std::string run_cli(const std::string& arguments, int* status) {
    const std::string command = std::string(HAPTICOPT_CLI) + " limit-cycle " + arguments + " 2>&1";
    FILE* pipe = popen(command.c_str(), "r");
    std::string out;
    char buffer[4096];
    while (pipe && std::fgets(buffer, sizeof buffer, pipe)) out += buffer;
    const int raw = pipe ? pclose(pipe) : -1;
    *status = raw >= 0 && WIFEXITED(raw) ? WEXITSTATUS(raw) : -1;
    return out;
}

inline double json_number(const std::string& text, const std::string& key) {
    const auto at = text.find("\"" + key + "\":");
    return at == std::string::npos ? NAN : std::strtod(text.c_str() + at + key.size() + 3, nullptr);
}

// The subcommand prints the library's prediction (the JSON's numbers with 17 digits: equal to the last bit)
// and refuses invalid values with exit code 3 and a message naming the option and its range.
TEST(LimitCycles, CommandLine) {
    const Device s = tuned(0, 0.1, 0.5);
    const auto p = predict_limit_cycle(loop_of(s));
    int status = 0;
    char push[64];
    std::snprintf(push, sizeof push, "%.17g", s.push);
    const std::string out = run_cli(std::string("--alpha 0.2474 --beta 0.7445 --mass 0.3 --period 1e-3 "
                                                "--position-resolution 20e-6 --coulomb-friction 0.1 --json --push ") +
                                        push,
                                    &status);
    ASSERT_EQ(status, 0) << out;
    EXPECT_EQ(json_number(out, "amplitude"), p.cycle.amplitude) << out;
    EXPECT_EQ(json_number(out, "frequency"), p.cycle.frequency) << out;
    EXPECT_NE(out.find("\"rest_exists\":false"), std::string::npos) << out;
    {  // --velocity: the describing function with the estimator; no Colgate-Schenkel verdict
        const EstimatorCase& c = kEstimatorCases[11];  // window:15, d = 6
        const Device w = tuned_with(c, 0.1, 0.5);
        const auto pw = predict_limit_cycle(loop_of(w));
        char line[512];
        std::snprintf(line, sizeof line,
                      "--alpha %.17g --beta %.17g --delay 6 --mass 0.3 --period 1e-3 --position-resolution 20e-6 "
                      "--coulomb-friction %.17g --push %.17g --velocity window:15 --json",
                      c.alpha, c.beta, w.friction, w.push);
        const std::string filtered = run_cli(line, &status);
        ASSERT_EQ(status, 0) << filtered;
        // the CLI rebuilds K and B from alpha and beta (m alpha / T^2): the same doubles as tuned_with
        EXPECT_EQ(json_number(filtered, "amplitude"), pw.cycle.amplitude) << filtered;
        EXPECT_EQ(json_number(filtered, "frequency"), pw.cycle.frequency) << filtered;
        EXPECT_NE(filtered.find("\"colgate_schenkel_passive\":null"), std::string::npos) << filtered;
        EXPECT_NE(filtered.find("\"kind\":\"window\""), std::string::npos) << filtered;
    }
    const std::string bad = run_cli("--alpha 0.2 --beta 0.7 --mass 0.3 --period 1e-3 --position-resolution 0", &status);
    EXPECT_EQ(status, 3) << bad;
    EXPECT_NE(bad.find("--position-resolution = 0 is invalid; accepted range: finite and > 0"), std::string::npos)
        << bad;
    const std::string negative = run_cli(
        "--alpha 0.2 --beta 0.7 --mass 0.3 --period 1e-3 --position-resolution 2e-5 --coulomb-friction -1", &status);
    EXPECT_EQ(status, 3) << negative;
    EXPECT_NE(negative.find("--coulomb-friction = -1 is invalid"), std::string::npos) << negative;
}
#endif

}  // namespace hapticopt::limit_cycle_test
