// SPDX-License-Identifier: Apache-2.0
// Coulomb friction and encoder quantisation in the sampled-data wall: the known passivity conditions and a
// describing-function prediction of the limit cycles they cause.
//
// The loop (physical units): m x'' + b x' + f_c sgn(x') + k x = F - f(t), F a constant push; the encoder
// reports y_j = q round(x(jT) / q) (a rounding quantiser, step q); the wall force f_j = K y_j + B v_j, v_j the
// velocity estimate of velocity_estimator.hpp in physical units (v = D(z) y: the backward difference
// (y_j - y_{j-1}) / T, the default; the low-pass v_j = lambda v_{j-1} + (1 - lambda)(y_j - y_{j-1}) / T; the
// window (y_j - y_{j-N}) / (N T)), is held for one period and delayed by t_d = d T (sampled_plant.hpp: f_j acts
// during [jT + t_d, (j + 1) T + t_d)). At rest in a sticking state the friction force is anything in [-f_c, f_c].
// Every estimator has D(1) = 0 (its coefficients on y sum to 0): a constant y gives v -> 0, so items 3 and
// the mean equation of item 4 hold for all three. Items 1 and 2 are conditions on the backward difference
// (item 1) or on B = 0 (item 2, where no estimator enters the force); neither says anything about a filtered
// wall with B != 0, and this header states none for it.
//
// 1. Colgate-Schenkel passivity (J. E. Colgate and G. G. Schenkel, J. Robotic Systems 14(1), 1997), b > K T/2 +
//    |B| for d = 0, with the delay z^-d: passivity.hpp (passivity_margin, is_passive). It sees neither q nor
//    f_c, so it is not repeated here.
//
// 2. Abbott-Okamura passivity (J. J. Abbott and A. M. Okamura, "Effects of position quantization and sampling
//    rate on virtual-wall passivity", IEEE Trans. Robotics 21(5), 952-964, 2005): a pure spring wall (B = 0)
//    rendered through a zero-order hold without further delay (d = 0) on a mass with viscous damping b and
//    Coulomb friction f_c, position measured by an encoder of step q, no assumption on the user, any sampling
//    period T. Their main result, a necessary and sufficient condition for passivity, is
//      K <= max(2 b / T, 2 f_c / q),
//    two decoupled modes: above 2 b / T the sampled spring can grow energy (instability); above 2 f_c / q the
//    quantised spring can release more energy per count than friction dissipates (active "buzz"). The paper
//    states no condition for B != 0 or d > 0; abbott_okamura_passivity() takes neither. The formula is
//    given as the paper's main result is commonly quoted; only its abstract (the model and the two modes) was
//    checked against the source here. Measured in this model (tests/beyond/test_limit_cycles.cpp): slow
//    starts (up to a quarter count per period) never grow and end within one count wherever the bound holds;
//    but with b = 0 and K <= 2 f_c / q a fast start (2.5 counts per period) grows without bound. The held
//    force gains about K (dx)^2 / 2 per period in which x moves by dx, Coulomb friction takes f_c |dx|: the
//    Coulomb bound protects motions of about one count per period, faster ones need the viscous bound.
//
// 3. Rest of the quantised wall (this header; follows from the model above). With k = 0 a sticking rest at a
//    level y = n q holds the push iff |F - K n q| <= f_c (the damper term is zero at rest, for every estimator:
//    D(1) = 0). Write F / (K q) = n0 + r, n0 integer, 0 <= r < 1: a rest exists iff K q min(r, 1 - r) <= f_c;
//    for every F iff K q / 2 <= f_c, i.e. K <= 2 f_c / q, Abbott-Okamura's Coulomb bound. Where no rest exists
//    the trajectory cannot settle: a bounded motion then never stops (a sustained oscillation, the chatter
//    between two counts). quantised_rest_exists().
//
// 4. Describing-function (DF) prediction, in the manner of N. Diolaiti, G. Niemeyer, F. Barbagli and
//    J. K. Salisbury, "Stability of haptic rendering: discretization, quantization, time delay, and Coulomb
//    effects", IEEE Trans. Robotics 22(2), 256-268, 2006, which analyses quantisation and Coulomb friction by
//    describing functions (the construction below is this library's). predict_limit_cycle(). Assumed: the position is
//    x(t) = x0 + A sin wt; every other harmonic is filtered out by the mass (the DF hypothesis). Then
//    - the quantiser is replaced by its dual-input DF: the mean of its output, M(x0, A), and the gain of its
//      fundamental, N(x0, A) = (2 q / (pi A)) sum_i sqrt(1 - u_i^2), u_i = (c_i - x0) / A over the thresholds
//      c_i = (i + 1/2) q with |u_i| < 1 (each threshold adds a pulse of height q whose fundamental is in phase
//      with the input: N is real, no phase lag). Bias x0 = 0: the familiar (4 q / (pi A)) sum sqrt(1 - ((2i -
//      1) q / (2A))^2), 0 for A < q/2, at most 4/pi. A threshold at x0: the relay 2 q / (pi A), unbounded as
//      A -> 0 (the two-count chatter);
//    - Coulomb friction is replaced by its DF on the velocity A w sin, the equivalent viscous damping
//      b_eq = 4 f_c / (pi A w), added to b (sliding all the time: a cycle with sticking phases is outside
//      the DF hypothesis);
//    - the mean x0 follows from the balance of the cycle's mean forces: k x0 + K M(x0, A) = F (the damper's
//      and the friction's means vanish over a symmetric cycle, the damper's for every estimator because its
//      DC gain D(1) is 0; where an interval of x0 balances, its middle);
//    - the linear part is exact: the loop transfer of the sampled loop with plant damping b + b_eq(A, w),
//      G(z) = (alpha P_alpha(z) + beta P_beta(z)) / P_0(z) from the characteristic polynomial p = P_0 +
//      alpha P_alpha + beta P_beta (characteristic_polynomial.hpp), the ZOH, the delay (integer or fractional)
//      and the backward difference included, evaluated at z = e^{j theta}, theta = w T. With a low-pass or a
//      window estimator the controller K + B D(z) replaces K + B (1 - z^-1) / T: G = (alpha P_alpha At +
//      beta P_alpha Bt) / (P_0 At), the polynomial p_est of estimator_characteristic_polynomial
//      (estimator_stability.hpp; At, Bt the estimator's denominator and numerator in z). The backward
//      difference keeps the polynomial p itself (p_est = z p, the same G). The sampling of the
//      quantiser's input is not modelled: N is the continuous-time DF, an average over the phase of the samples
//      relative to the thresholds (poor when a cycle lasts only a few periods).
//    Harmonic balance 1 + N(x0(A), A) G(e^{j theta}; b + b_eq(A, theta)) = 0: theta is a phase crossover of G
//    (Im G = 0, Re G < 0), and N |G| = 1. For each A on a logarithmic grid (1e-3 q .. 1e3 q, 40 points a decade)
//    the crossover with the largest |G| (the smallest gain margin) is found by a scan of theta in (0, pi]
//    (64 (d + 2 + L) points, L = 0 for the backward difference, 1 for the low-pass, N for the window: the
//    window's numerator 1 - z^-N has N zeros on the circle, so its G turns N times more) and bisection of Im G;
//    h(A) = 1 - N |G| changes sign at a cycle, located by bisection in A. The cycle's stability is the amplitude
//    form of Loeb's criterion: it attracts when the equivalent linear loop (gains N alpha, N beta; damping
//    b + b_eq at the cycle's theta) is unstable (Schur-Cohn, schur_cohn.hpp) just below A and stable just above
//    it (A (1 -+ 1e-3)).
//    The DF is an approximation; its accuracy against a time-stepping simulation with stick-slip friction
//    and real rounding is measured in tests/beyond/test_limit_cycles.cpp and tabulated in
//    docs/limit-cycles.md, with where it holds and where it does not.
//    Cost: 241 grid amplitudes plus ~40 bisection steps per cycle. Each amplitude solves the bias once (Illinois
//    regula falsi on k x0 + K M(x0, A) - F, scalar_search.hpp, ~10 evaluations of M, each a sum over the 2 A / q
//    crossed thresholds) and scans 64 (d + 2 + L) frequencies plus ~45 bisection steps per crossover; each
//    transfer evaluation is G from the factors (LimitCycleLinearPart: O(L)), and when f_c > 0 it re-discretises the
//    plant at b + b_eq (the free mass by free_mass_exponential's closed form, a plant with a spring by the series).
//    Measured (tests/benchmarks/core_benchmarks.cpp, CPU, load 4): backward difference d = 0, 1, 6, f_c = 0 / 0.3 N:
//    12-16 / 15-19, 18 / 21-38, 19-28 / 29-30 ms (BM_PredictLimitCycle); d = 6, f_c = 0 / 0.3 K q: low-pass
//    nu = 0.02 24-25 / 32-34 ms, window 15 59-76 / 74-95 ms (BM_PredictLimitCycleEstimator).
#pragma once

#include <algorithm>
#include <cmath>
#include <complex>
#include <limits>
#include <utility>
#include <vector>

#include "characteristic_polynomial.hpp"
#include "config.hpp"
#include "errors.hpp"
#include "estimator_stability.hpp"
#include "parameters.hpp"
#include "sampled_plant.hpp"
#include "scalar_search.hpp"
#include "schur_cohn.hpp"
#include "estimator_types.hpp"

namespace hapticopt {

/// Abbott-Okamura 2005 (header comment, item 2): a spring wall K behind a ZOH (B = 0, d = 0) on a mass with
/// viscous damping b and Coulomb friction f_c, encoder step q, period T is passive iff K <= max(2b/T, 2f_c/q).
/// B = 0: the velocity estimator does not enter; for a wall with B != 0 (any estimator) it states nothing.
struct AbbottOkamuraPassivity {
    double viscous_bound = 0;    ///< 2 b / T [N/m]
    double coulomb_bound = 0;    ///< 2 f_c / q [N/m]
    double stiffness_bound = 0;  ///< max of the two [N/m]
    bool passive = false;        ///< 0 <= K <= stiffness_bound
};

/// Abbott-Okamura's condition (header comment, item 2). Throws InvalidParameter naming the parameter for
/// K, b, f_c < 0 or non-finite, and q, T <= 0 or non-finite. Cost: O(1).
inline AbbottOkamuraPassivity abbott_okamura_passivity(double stiffness, double damping, double coulomb_friction,
                                                       double position_step, double period) {
    const char* f = "hapticopt::abbott_okamura_passivity";
    detail::require_non_negative(f, "stiffness", stiffness);
    detail::require_non_negative(f, "damping", damping);
    detail::require_non_negative(f, "coulomb_friction", coulomb_friction);
    detail::require_positive(f, "position_step", position_step);
    detail::require_positive(f, "period", period);
    AbbottOkamuraPassivity out;
    out.viscous_bound = 2 * damping / period;
    out.coulomb_bound = 2 * coulomb_friction / position_step;
    out.stiffness_bound = std::max(out.viscous_bound, out.coulomb_bound);
    out.passive = stiffness <= out.stiffness_bound;
    return out;
}

/// Whether the quantised wall can hold the push F at rest (header comment, item 3): some level n q and some
/// position x with round(x / q) = n and |F - K n q - k x| <= f_c (k: the physical spring, default 0; with
/// k = 0 simply |F - K n q| <= f_c). Throws InvalidParameter naming the parameter for K <= 0, f_c < 0, q <= 0,
/// k < 0 or a non-finite F. Cost: O(1) (the levels within 3 of F / ((K + k) q)).
inline bool quantised_rest_exists(double external_force, double stiffness, double coulomb_friction,
                                  double position_step, double physical_stiffness = 0.0) {
    const char* f = "hapticopt::quantised_rest_exists";
    detail::require_finite(f, "external_force", external_force);
    detail::require_positive(f, "stiffness", stiffness);
    detail::require_non_negative(f, "coulomb_friction", coulomb_friction);
    detail::require_positive(f, "position_step", position_step);
    detail::require_non_negative(f, "physical_stiffness", physical_stiffness);
    const double q = position_step, k = physical_stiffness;
    const double centre = std::round(external_force / ((stiffness + k) * q));
    for (double n = centre - 3; n <= centre + 3; n += 1) {
        // F - K n q - k x over the bin x in [(n - 1/2) q, (n + 1/2) q]
        const double base = external_force - stiffness * n * q - k * n * q;
        const double lo = base - k * q / 2, hi = base + k * q / 2;
        if (lo <= coulomb_friction && hi >= -coulomb_friction) return true;
    }
    return false;
}

/// The loop of predict_limit_cycle (header comment, item 4), physical units.
struct LimitCycleLoop {
    PhysicalPlant plant;          ///< m, b (viscous), k, T, t_d (any t_d >= 0, at most 1000 T)
    WallGains gains{0, 0};        ///< K > 0, B [N/m, N s/m]
    double coulomb_friction = 0;  ///< f_c [N], >= 0
    double position_step = 0;     ///< q [m], > 0
    double external_force = 0;    ///< F [N], the constant push that sets the mean position
    /// The wall's velocity estimate (header comment; the low-pass cutoff nu = (cutoff frequency) T is
    /// normalised, the window N in periods). The describing function applies to all three; the Abbott-Okamura condition
    /// (abbott_okamura_passivity) is for B = 0 and says nothing about this field.
    VelocityEstimator estimator = VelocityEstimator::backward_difference();
};

/// One solution of the harmonic balance.
struct PredictedLimitCycle {
    double amplitude = 0;           ///< A [m], amplitude of the position's fundamental
    double frequency = 0;           ///< w / (2 pi) [Hz]
    double theta = 0;               ///< w T [rad], in (0, pi]
    double mean_position = 0;       ///< x0 [m]
    double describing_gain = 0;     ///< N(x0, A) of the quantiser
    double equivalent_damping = 0;  ///< b_eq = 4 f_c / (pi A w) [N s/m]
    bool stable = false;            ///< attracts (Loeb's criterion, amplitude form)
};

struct LimitCyclePrediction {
    bool predicted = false;                   ///< some cycle found (stable or not)
    PredictedLimitCycle cycle;                ///< the largest stable cycle, else the largest one
    std::vector<PredictedLimitCycle> cycles;  ///< all, by increasing amplitude
    /// A sticking rest holds the push (quantised_rest_exists). Then the DF's cycle, which assumes sliding
    /// throughout, may coexist with the rest or not exist at all (docs/limit-cycles.md, measured).
    bool rest_exists = false;
    /// The equivalent loop is unstable at the largest amplitude examined (1e3 q): large motions grow (the
    /// wall is outside the linear stable region with friction negligible).
    bool grows_at_large_amplitude = false;
};

namespace detail {

/// Mean output M and fundamental gain N of the rounding quantiser for x0 + A sin (header comment, item 4).
inline std::pair<double, double> quantiser_dual_input(double x0, double amplitude, double q) {
    constexpr double pi = 3.14159265358979323846;
    const double lo = x0 - amplitude, hi = x0 + amplitude;
    // thresholds c_i = (i + 1/2) q in (lo, hi)
    const double first = std::floor(lo / q - 0.5) + 1;  // smallest i with c_i > lo (up to rounding)
    double mean = q * std::round(lo / q);               // output level below every crossed threshold
    double gain = 0;
    for (double i = first;; i += 1) {
        const double c = (i + 0.5) * q;
        if (!(c < hi)) break;
        if (!(c > lo)) continue;
        const double u = (c - x0) / amplitude;
        mean += q * std::acos(u) / pi;  // fraction of the cycle above c
        gain += std::sqrt(std::max(0.0, 1 - u * u));
    }
    return {mean, amplitude > 0 ? 2 * q * gain / (pi * amplitude) : 0.0};
}

/// The mean position x0 balancing k x0 + K M(x0, A) = F (middle of the interval of solutions).
inline double limit_cycle_bias(double k, double stiffness, double force, double amplitude, double q) {
    auto g = [&](double x0) { return k * x0 + stiffness * quantiser_dual_input(x0, amplitude, q).first - force; };
    const double centre = force / (k + stiffness);
    const double reach = q + amplitude + std::abs(centre) * 1e-12;
    double lo = centre - reach, hi = centre + reach;
    while (g(lo) > 0) lo -= reach;  // g is non-decreasing; these loops end within a step or two
    while (g(hi) < 0) hi += reach;
    // 1e-14 of the reach, but not below the spacing of doubles there (a bisection would not end before its cap)
    const double tol =
        std::max(1e-14 * reach, 4 * std::numeric_limits<double>::epsilon() * std::max(std::abs(lo), std::abs(hi)));
    const double g_lo = g(lo), g_hi = g(hi);
    if (g_lo < 0 && g_hi > 0) {  // a sign change: Illinois (scalar_search.hpp), ~10 evaluations instead of ~90
        const IllinoisBracket r = illinois_bracket(g, lo, hi, g_lo, g_hi, tol);
        if (r.bracketed) return (r.a + r.b) / 2;
    }
    // g == 0 met exactly: the zero set may be an interval (g flat); its ends by bisection, the middle
    const auto left = bisect([&](double x) { return g(x) >= 0; }, lo, hi, tol, 200);  // first x with g >= 0
    const auto right = bisect([&](double x) { return g(x) > 0; }, lo, hi, tol, 200);  // first x with g > 0
    return (left.second + right.second) / 2;
}

/// Loop transfer G(e^{j theta}) = (alpha P_alpha + beta P_beta) / P_0 and the polynomial, for damping delta;
/// with a low-pass or window estimator the polynomial is p_est (estimator_characteristic_polynomial).
/// The transfer is evaluated from the polynomials' factors, not from their coefficients: with the plant's
/// D(z), q(z) (plant_polynomial_factors), P_0 = z^(n+2) D, P_alpha = z q, and the estimator's At, Bt
/// (estimator_transfer_polynomials; At = z, Bt = z - 1 for the backward difference),
///   G(z) = q(z) (alpha At(z) + beta Bt(z)) / (z^(n+1) D(z) At(z)),
/// O(l) per evaluation (l the estimator's order) instead of the products of polynomials of degree n + 4 + l.
struct LimitCycleLinearPart {
    LimitCycleLinearPart(const NormalizedPlant& p, double a, double b, const VelocityEstimator& e)
        : plant(p), alpha(a), beta(b), estimator(e), controller(estimator_transfer_polynomials<double>(e)) {}

    NormalizedPlant plant;
    double alpha, beta;
    VelocityEstimator estimator;
    EstimatorTransferPolynomials<double> controller;

    NormalizedPlant with_damping(double delta) const {
        NormalizedPlant p = plant;
        p.delta = delta;
        return p;
    }

    AffineCharacteristicPolynomial<double> polynomial(double delta) const {
        AffineCharacteristicPolynomial<double> backward =
            characteristic_polynomial(plant_transitions<double>(with_damping(delta)));
        if (estimator.kind == VelocityEstimatorKind::backward) return backward;
        return estimator_characteristic_polynomial(backward, estimator);
    }

    /// The plant's factors at damping delta; the free mass (gamma = 0) by the closed-form exponential.
    PlantPolynomialFactors<double> factors(double delta) const {
        const NormalizedPlant p = with_damping(delta);
        if (p.gamma == 0) {
            return plant_polynomial_factors(plant_transitions_with<double>(
                p, [delta](double length) { return free_mass_exponential(delta, length); }));
        }
        return plant_polynomial_factors(plant_transitions<double>(p));
    }

    static std::complex<double> horner(const Eigen::VectorXd& c, std::complex<double> z) {
        std::complex<double> v = 0;
        for (Eigen::Index i = c.size() - 1; i >= 0; --i) v = v * z + c(i);
        return v;
    }

    std::complex<double> transfer(const PlantPolynomialFactors<double>& f, double theta) const {
        const std::complex<double> z = std::polar(1.0, theta);
        const std::complex<double> q = (f.q[2] * z + f.q[1]) * z + f.q[0];
        const std::complex<double> d = (z + f.d[1]) * z + f.d[0];
        const std::complex<double> at = horner(controller.at, z);
        const std::complex<double> shift = std::polar(1.0, (f.whole_delay + 1) * theta);
        return q * (alpha * at + beta * horner(controller.bt, z)) / (shift * d * at);
    }
};

}  // namespace detail

/// The describing-function prediction of header comment item 4. Throws InvalidParameter naming the parameter
/// for an invalid plant (mass, period > 0; damping, stiffness, time_delay >= 0; time_delay <= 1000 period),
/// gains.stiffness K <= 0, a non-finite gains.damping B, coulomb_friction < 0, position_step <= 0, a
/// non-finite external_force, or an invalid estimator ("cutoff": finite and > 0; "window": 1 .. 1000).
HAPTICOPT_FUNC LimitCyclePrediction predict_limit_cycle(const LimitCycleLoop& loop)
#if HAPTICOPT_DEFINITIONS
{
    const char* f = "hapticopt::predict_limit_cycle";
    validate(loop.plant, f);
    detail::require_in_range(f, "time_delay", loop.plant.time_delay, 0.0, false, 1000 * loop.plant.period,
                             "0 <= time_delay <= 1000 period");
    detail::require_positive(f, "gains.stiffness", loop.gains.stiffness);
    detail::require_finite(f, "gains.damping", loop.gains.damping);
    detail::require_non_negative(f, "coulomb_friction", loop.coulomb_friction);
    detail::require_positive(f, "position_step", loop.position_step);
    detail::require_finite(f, "external_force", loop.external_force);
    validate(loop.estimator, f);

    constexpr double pi = 3.14159265358979323846;
    const double m = loop.plant.mass, T = loop.plant.period, q = loop.position_step;
    const NormalizedPlant base = normalize(loop.plant);
    const NormalizedGains gains = normalize(loop.gains, m, T);
    const detail::LimitCycleLinearPart linear{base, gains.alpha, gains.beta, loop.estimator};
    const double friction = loop.coulomb_friction * T * T / m;  // normalised f_c
    auto delta_at = [&](double amplitude, double theta) {
        return base.delta + (friction > 0 ? 4 * friction / (pi * amplitude * theta) : 0.0);
    };
    const auto fixed = linear.factors(base.delta);  // used when f_c = 0
    auto transfer = [&](double amplitude, double theta) {
        return friction > 0 ? linear.transfer(linear.factors(delta_at(amplitude, theta)), theta)
                            : linear.transfer(fixed, theta);
    };

    struct Crossover {
        double theta = 0;
        double gain = 0;  // |G| = -Re G at the crossover; 0: none
    };
    const int order = loop.estimator.kind == VelocityEstimatorKind::window    ? loop.estimator.window
                      : loop.estimator.kind == VelocityEstimatorKind::lowpass ? 1
                                                                              : 0;
    const int scan = 64 * (static_cast<int>(std::ceil(base.delay)) + 2 + order);
    auto crossover = [&](double amplitude) {
        Crossover best;
        auto consider = [&](double theta) {
            const std::complex<double> g = transfer(amplitude, theta);
            if (g.real() < 0 && -g.real() > best.gain) best = {theta, -g.real()};
        };
        double prev_theta = pi / scan;
        double prev = transfer(amplitude, prev_theta).imag();
        for (int i = 2; i <= scan; ++i) {
            const double theta = pi * i / scan;
            const double im = transfer(amplitude, theta).imag();
            if ((im > 0) != (prev > 0)) {
                const auto b = detail::bisect([&](double t) { return transfer(amplitude, t).imag() > 0; }, prev_theta,
                                              theta, 1e-13, 100);
                consider((b.first + b.second) / 2);
            }
            prev = im;
            prev_theta = theta;
        }
        consider(pi);  // G(-1) is real
        return best;
    };
    auto balance = [&](double amplitude, Crossover* where = nullptr) {  // h(A) = 1 - N |G|
        const double x0 =
            detail::limit_cycle_bias(base.gamma, gains.alpha, loop.external_force * T * T / m, amplitude, q);
        const double n = detail::quantiser_dual_input(x0, amplitude, q).second;
        if (n == 0) return 1.0;
        const Crossover c = crossover(amplitude);
        if (where) *where = c;
        return 1 - n * c.gain;
    };
    auto equivalent_stable = [&](double amplitude, double theta) {
        const double x0 =
            detail::limit_cycle_bias(base.gamma, gains.alpha, loop.external_force * T * T / m, amplitude, q);
        const double n = detail::quantiser_dual_input(x0, amplitude, q).second;
        const auto p = linear.polynomial(delta_at(amplitude, theta));
        return schur_cohn<double>(p.at(n * gains.alpha, n * gains.beta)).stable;
    };

    LimitCyclePrediction out;
    const int per_decade = 40;
    const double a_min = 1e-3 * q;
    const int points = 6 * per_decade + 1;
    auto grid = [&](int i) { return a_min * std::pow(10.0, static_cast<double>(i) / per_decade); };
    double prev_a = grid(0);
    double prev_h = balance(prev_a);
    for (int i = 1; i < points; ++i) {
        const double a = grid(i);
        const double h = balance(a);
        if ((h > 0) != (prev_h > 0)) {
            const auto b = detail::bisect([&](double x) { return balance(x) > 0; }, prev_a, a, 1e-12 * a, 200);
            const double root = (b.first + b.second) / 2;
            Crossover c;
            const double residual = balance(root, &c);
            // A jump of h across 0 (a change of the dominant crossover or of the bias) is no solution.
            if (std::abs(residual) < 1e-6 && c.gain > 0) {
                PredictedLimitCycle cycle;
                cycle.amplitude = root;
                cycle.theta = c.theta;
                cycle.frequency = c.theta / (2 * pi * T);
                const double x0 =
                    detail::limit_cycle_bias(base.gamma, gains.alpha, loop.external_force * T * T / m, root, q);
                cycle.mean_position = x0;
                cycle.describing_gain = detail::quantiser_dual_input(x0, root, q).second;
                cycle.equivalent_damping = friction > 0 ? 4 * loop.coulomb_friction * T / (pi * root * c.theta) : 0.0;
                cycle.stable =
                    !equivalent_stable(root * (1 - 1e-3), c.theta) && equivalent_stable(root * (1 + 1e-3), c.theta);
                out.cycles.push_back(cycle);
            }
        }
        prev_a = a;
        prev_h = h;
    }
    {
        Crossover c;
        const double h = balance(grid(points - 1), &c);
        out.grows_at_large_amplitude = h < 0 || !equivalent_stable(grid(points - 1), c.gain > 0 ? c.theta : pi / 2);
    }
    out.rest_exists = quantised_rest_exists(loop.external_force, loop.gains.stiffness, loop.coulomb_friction, q,
                                            loop.plant.stiffness);
    out.predicted = !out.cycles.empty();
    if (out.predicted) {
        out.cycle = out.cycles.back();
        for (auto it = out.cycles.rbegin(); it != out.cycles.rend(); ++it) {
            if (it->stable) {
                out.cycle = *it;
                break;
            }
        }
    }
    return out;
}
#else
    ;
#endif

}  // namespace hapticopt
