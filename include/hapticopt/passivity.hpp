// SPDX-License-Identifier: Apache-2.0
// Passivity of the sampled-data wall with an integer loop delay: the Colgate-Schenkel condition with
// H(z) = z^-d (K + B (1 - z^-1) / T), its exact maximum over frequency, the passive set, and the best
// passive gains.
//
// Source. J. E. Colgate and G. G. Schenkel, "Passivity of a class of sampled-data systems: application
// to haptic interfaces", J. Robotic Systems 14(1), 37-47, 1997: a discrete environment H(z) behind a
// zero-order hold, rendered by a device with physical damping b, is passive iff
//   b > (T / 2) / (1 - cos wT) * Re{ (1 - e^{-jwT}) H(e^{jwT}) }      for 0 <= w <= pi / T.
// Here H is the analysed wall with the loop delay as z^-d (sampled_plant.hpp: the force computed at jT acts
// from jT + d T for one period; d = 0 still has the hold).
//
// Normalised (Table I: alpha = K T^2/m, beta = B T/m, delta = b T/m) with theta = wT, multiplying by T/m:
//   delta > R(theta) = Re{ (1 - e^{-j theta}) e^{-j d theta} (alpha + beta (1 - e^{-j theta})) }
//                      / (2 (1 - cos theta)).
// Derivation of the closed form (checked in tests/beyond/test_passivity.cpp against the complex form):
//   Re{(1 - e^{-j theta}) e^{-j d theta}}   = cos d theta - cos (d + 1) theta,
//   Re{(1 - e^{-j theta})^2 e^{-j d theta}} = (cos d theta - cos (d+1) theta) - (cos (d+1) theta - cos (d+2) theta),
//   (cos n theta - cos (n+1) theta) / (2 (1 - cos theta)) = D_n(theta) / 2,  D_n = 1 + 2 sum_{k=1..n} cos k theta
//   (the Dirichlet kernel: both sides equal sin((2n+1) theta/2) / (2 sin(theta/2))), hence
//   R(theta) = alpha D_d(theta) / 2 - beta cos((d + 1) theta)
//            = alpha / 2 + alpha sum_{k=1..d} T_k(c) - beta T_{d+1}(c),   c = cos theta,
// a Chebyshev series of degree d + 1 in c in [-1, 1] (the 0/0 at theta = 0 is removable).
//   d = 0:  R = alpha/2 - beta c, max = alpha/2 + |beta|  (Colgate-Schenkel's b > K T/2 + |B|);
//   d = 1, beta = 0:  R = alpha (1 + 2c)/2, max at c = 1: passive iff alpha < delta / (d + 1/2);
//   any d: R(theta = 0) = alpha (d + 1/2) - beta (the low-frequency condition b + B > K (t_d + T/2)), and the
//   mean of R over theta in [0, pi] is alpha/2, so a passive wall has alpha < 2 delta.
// Stiffness sign: the frequency condition does not see the pole of K/(1 - z^-1) at z = 1; a negative K
// (alpha < 0) stores unbounded negative energy and is never passive. The margin folds this in (below).
//
// Method (exact maximum). max_{theta in [0, pi]} R = max_{c in [-1, 1]} p(c), p the Chebyshev series above.
// The maximum is at c = +-1 or at a zero of p' where p' changes sign. The zeros of p^{(k)} are bracketed
// by the derivative cascade: p^{(d+1)} is constant; between consecutive sign-changing zeros of p^{(k+1)}
// (and +-1) p^{(k)} is monotone, so it has at most one sign change there, found by bisection down to
// adjacent doubles. A zero of p^{(k+1)} without a sign change leaves p^{(k)} monotone across it, so missing
// one cannot lose a zero. Values and derivatives by Clenshaw's recurrence on the Chebyshev coefficients
// (derivative coefficients by c'_{k-1} = c'_{k+1} + 2k c_k).
// Error bound (reported as `error_bound`): the bisection brackets of the zeros of p' have width w_i, on
// which p' is monotone, so the maximum inside exceeds p(midpoint) by at most w_i/2 max(|p'(lo_i)|,
// |p'(hi_i)|); plus a rounding allowance of 8 (d + 2)^2 u sum |c_k| for Clenshaw's recurrence (its error
// grows at most quadratically with the degree). The tests check the bound against an independent fine grid
// of the complex form.
// Cost: O(d^3) flops with ~60 bisection steps per bracket.
//
// Fractional delay d: not covered. The force then switches inside a period and H is not a rational
// function of z; every function here throws InvalidParameter naming `delay` rather than report the integer
// answer. Delays within 1e-9 of an integer (rounding of t_d / T) are taken as that integer. Integer delays
// up to kMaxPassivityDelay = 1000 periods (1 s at 1 kHz): the maximum is checked at d = 1000 against a long
// double maximum of the direct complex form (tests/beyond/test_passivity.cpp); beyond, InvalidParameter.
//
// Passivity margin (normalised, dimensionless):  mu = delta - max_theta R(theta) for alpha >= 0, and
// min(delta - max R, alpha) for alpha < 0;  passive iff mu > 0. Physical: mu m / T [N s/m]
// (= b - max_theta R(theta; K T, B), independent of m). d = 0: mu = delta - alpha/2 - |beta| exactly.
// Passive implies stable when alpha + gamma > 0 (tested on a dense sample, d = 0..6, delta <= 0.5,
// gamma <= 0.05); at alpha = gamma = 0 the loop is a free damped mass: passive, marginally stable.
//
// The passive set {alpha >= 0, mu > 0} is convex (max R is a maximum of functions linear in (alpha, beta)).
// At fixed alpha, g(beta) = max R is convex and 1-Lipschitz (|T_{d+1}| <= 1); the beta interval is found by
// Brent on g (minimum) and bisection of g = delta on each side; the largest passive alpha by bisection on
// the convex h(alpha) = min_beta g (h(0) = 0, h(alpha) >= alpha/2), so alpha < 2 delta.
// Best passive gains: the minimum of a criterion over the stable passive set, by the search of
// region_minimum.hpp; none when delta = 0. Cost: a few thousand cost and passive-interval evaluations.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <optional>
#include <utility>
#include <vector>

#include "config.hpp"
#include "impulse_costs.hpp"
#include "region_minimum.hpp"
#include "stability_region.hpp"

namespace hapticopt {

/// Largest integer delay (periods) the passivity functions accept (header comment).
inline constexpr int kMaxPassivityDelay = 1000;

namespace detail {

inline constexpr double kPassivityPi = 3.14159265358979323846;

/// sum_{k < n} a[k] T_k(c) by Clenshaw's recurrence.
inline double chebyshev_value(const double* a, int n, double c) {
    double b1 = 0, b2 = 0;
    for (int k = n - 1; k >= 1; --k) {
        const double b0 = a[k] + 2 * c * b1 - b2;
        b2 = b1;
        b1 = b0;
    }
    return n > 0 ? a[0] + c * b1 - b2 : 0.0;
}

/// Chebyshev coefficients of the derivative of sum_{k<n} a[k] T_k (n - 1 of them; n >= 1).
inline std::vector<double> chebyshev_derivative(const std::vector<double>& a) {
    const int n = static_cast<int>(a.size());
    std::vector<double> b(static_cast<std::size_t>(std::max(n - 1, 1)), 0.0);
    if (n <= 1) return b;
    double next = 0, next2 = 0;  // b_{k+1}, b_{k+2} in the recurrence b_{k-1} = b_{k+1} + 2 k a_k
    for (int k = n - 1; k >= 1; --k) {
        const double value = next2 + 2.0 * k * a[static_cast<std::size_t>(k)];
        b[static_cast<std::size_t>(k - 1)] = value;
        next2 = next;
        next = value;
    }
    b[0] /= 2;
    return b;
}

struct ChebyshevBracket {
    double lo, hi;
};

/// Brackets [lo, hi] of the sign changes on [-1, 1] of the series derivative[order] (derivative[k] holds the
/// Chebyshev coefficients of the k-th derivative of one polynomial, k = 0 .. size - 1), by the derivative cascade:
/// from k = size - 2 down to `order`, the zeros of derivative k + 1 cut [-1, 1] into pieces on which derivative k is
/// monotone, and each piece with a sign change is bisected down to adjacent doubles (an exact zero at an
/// interior cut is kept as [c, c]). `next_order` (optional) receives the brackets of derivative order + 1's sign
/// changes, the extrema of derivative `order`. Cost: O(size^3) coefficient operations plus 64 bisection steps per zero.
inline std::vector<ChebyshevBracket> chebyshev_cascade_zeros(const std::vector<std::vector<double>>& derivative,
                                                             int order,
                                                             std::vector<ChebyshevBracket>* next_order = nullptr) {
    auto value = [&](int k, double c) {
        const auto& d = derivative[static_cast<std::size_t>(k)];
        return chebyshev_value(d.data(), static_cast<int>(d.size()), c);
    };
    std::vector<ChebyshevBracket> zeros;
    for (int k = static_cast<int>(derivative.size()) - 2; k >= order; --k) {
        if (k == order && next_order != nullptr) *next_order = zeros;
        std::vector<double> cuts{-1.0};
        for (const ChebyshevBracket& z : zeros) cuts.push_back((z.lo + z.hi) / 2);
        cuts.push_back(1.0);
        std::vector<ChebyshevBracket> next;
        for (std::size_t i = 0; i + 1 < cuts.size(); ++i) {
            double lo = cuts[i], hi = cuts[i + 1];
            const double vlo = value(k, lo), vhi = value(k, hi);
            if (!(hi > lo) || vlo == 0 || vhi == 0 || (vlo > 0) == (vhi > 0)) {
                if (vlo == 0 && i > 0) next.push_back({lo, lo});  // an exact zero at an interior cut
                continue;
            }
            const bool lo_positive = vlo > 0;
            for (int it = 0; it < 200; ++it) {
                const double mid = (lo + hi) / 2;
                if (!(mid > lo && mid < hi)) break;
                const double v = value(k, mid);
                if (v == 0) {
                    lo = hi = mid;
                    break;
                }
                ((v > 0) == lo_positive ? lo : hi) = mid;
            }
            next.push_back({lo, hi});
        }
        zeros = std::move(next);
    }
    return zeros;
}

/// The integer delay of `plant`, or InvalidParameter naming `delay` when it is fractional or above
/// kMaxPassivityDelay.
inline int integer_delay(double delay, const char* function) {
    require_non_negative(function, "delay", delay);
    const double whole = std::round(delay);
    if (!(std::abs(delay - whole) <= 1e-9 * std::max(1.0, whole)) || whole > kMaxPassivityDelay) {
        throw InvalidParameter(function, "delay", delay,
                               "an integer number of periods 0..1000 (the passivity condition with a fractional "
                               "delay, where the force switches inside a period, is not covered; its maximum is "
                               "verified up to 1000)");
    }
    return static_cast<int>(whole);
}

}  // namespace detail

/// What the CLI and bindings print when passivity_is_covered() is false.
inline constexpr const char* kPassivityNotCovered =
    "passivity with a fractional delay (the force switches inside a period) is not covered; integer delays of "
    "0..1000 periods only";

/// Whether the passivity functions cover this plant's delay (an integer number of periods, header).
inline bool passivity_is_covered(const NormalizedPlant& plant) {
    try {
        detail::integer_delay(plant.delay, "hapticopt::passivity_is_covered");
        return true;
    } catch (const InvalidParameter&) {
        return false;
    }
}

/// Chebyshev coefficients of R(c) = alpha/2 + alpha sum_{k=1..d} T_k(c) - beta T_{d+1}(c) (header).
inline std::vector<double> passivity_condition_coefficients(const NormalizedGains& gains, int delay) {
    std::vector<double> a(static_cast<std::size_t>(delay) + 2, gains.alpha);
    a[0] = gains.alpha / 2;
    a.back() = -gains.beta;
    return a;
}

/// R(theta) of the header (closed form), the right-hand side of delta > R.
inline double passivity_condition(const NormalizedGains& gains, double delay, double theta) {
    validate(gains, "hapticopt::passivity_condition");
    const int d = detail::integer_delay(delay, "hapticopt::passivity_condition");
    detail::require_in_range("hapticopt::passivity_condition", "theta", theta, 0.0, false, detail::kPassivityPi,
                             "0 <= theta <= pi");
    const auto a = passivity_condition_coefficients(gains, d);
    return detail::chebyshev_value(a.data(), static_cast<int>(a.size()), std::cos(theta));
}

struct PassivityConditionMaximum {
    double value = 0;        ///< max over 0 <= theta <= pi of R(theta)
    double theta = 0;        ///< where (one maximiser)
    double error_bound = 0;  ///< |value - exact maximum| <= error_bound (header comment)
};

/// The exact maximum of R over frequency by the derivative cascade (header comment).
HAPTICOPT_FUNC PassivityConditionMaximum passivity_condition_maximum(const NormalizedGains& gains, double delay)
#if HAPTICOPT_DEFINITIONS
{
    validate(gains, "hapticopt::passivity_condition_maximum");
    const int d = detail::integer_delay(delay, "hapticopt::passivity_condition_maximum");
    const int n = d + 2;  // number of coefficients, degree d + 1
    std::vector<std::vector<double>> derivative(static_cast<std::size_t>(n));
    derivative[0] = passivity_condition_coefficients(gains, d);
    for (std::size_t k = 1; k < derivative.size(); ++k) derivative[k] = detail::chebyshev_derivative(derivative[k - 1]);
    auto value = [&](int k, double c) {
        const auto& a = derivative[static_cast<std::size_t>(k)];
        return detail::chebyshev_value(a.data(), static_cast<int>(a.size()), c);
    };
    // Zeros (with a sign change) of p' by the cascade from p^{(degree - 1)}.
    const std::vector<detail::ChebyshevBracket> zeros = detail::chebyshev_cascade_zeros(derivative, 1);
    double sum_abs = 0;
    for (double a : derivative[0]) sum_abs += std::abs(a);
    const double u = std::numeric_limits<double>::epsilon() / 2;
    PassivityConditionMaximum best;
    best.value = value(0, 1.0);
    best.theta = 0.0;
    double bracket_error = 0;
    auto consider = [&](double c) {
        const double v = value(0, c);
        if (v > best.value) {
            best.value = v;
            best.theta = std::acos(std::clamp(c, -1.0, 1.0));
        }
    };
    consider(-1.0);
    for (const detail::ChebyshevBracket& z : zeros) {
        consider((z.lo + z.hi) / 2);
        const double slope = std::max(std::abs(value(1, z.lo)), std::abs(value(1, z.hi)));
        bracket_error = std::max(bracket_error, (z.hi - z.lo) / 2 * slope);
    }
    best.error_bound = bracket_error + 8.0 * (d + 2) * (d + 2) * u * sum_abs;
    return best;
}
#else
    ;
#endif

/// mu = delta - max R (alpha >= 0), min(delta - max R, alpha) (alpha < 0); > 0 iff passive. Throws
/// InvalidParameter for a fractional delay (header comment).
HAPTICOPT_FUNC double passivity_margin(const NormalizedPlant& plant, const NormalizedGains& gains)
#if HAPTICOPT_DEFINITIONS
{
    validate(plant, "hapticopt::passivity_margin");
    validate(gains, "hapticopt::passivity_margin");
    detail::integer_delay(plant.delay, "hapticopt::passivity_margin");
    const double mu = plant.delta - passivity_condition_maximum(gains, plant.delay).value;
    return gains.alpha < 0 ? std::min(mu, gains.alpha) : mu;
}
#else
    ;
#endif

/// Colgate-Schenkel with the delay: delta > max_theta R(theta) and alpha >= 0.
HAPTICOPT_FUNC bool is_passive(const NormalizedPlant& plant, const NormalizedGains& gains)
#if HAPTICOPT_DEFINITIONS
{
    return passivity_margin(plant, gains) > 0;
}
#else
    ;
#endif

/// Physical margin [N s/m] = passivity_margin(normalised) m / T; > 0 iff passive.
HAPTICOPT_FUNC double passivity_margin(const PhysicalPlant& plant, const WallGains& gains)
#if HAPTICOPT_DEFINITIONS
{
    validate(plant, "hapticopt::passivity_margin");
    detail::require_finite("hapticopt::passivity_margin", "stiffness", gains.stiffness);
    detail::require_finite("hapticopt::passivity_margin", "damping", gains.damping);
    const NormalizedPlant np = normalize(plant);
    return passivity_margin(np, normalize(gains, plant.mass, plant.period)) * plant.mass / plant.period;
}
#else
    ;
#endif

/// The open beta interval (lo, hi) of passive gains at alpha (empty: hi <= lo; alpha < 0: empty).
HAPTICOPT_FUNC std::pair<double, double> passive_beta_interval(const NormalizedPlant& plant, double alpha)
#if HAPTICOPT_DEFINITIONS
{
    validate(plant, "hapticopt::passive_beta_interval");
    detail::require_finite("hapticopt::passive_beta_interval", "alpha", alpha);
    const double d = detail::integer_delay(plant.delay, "hapticopt::passive_beta_interval");
    if (alpha < 0 || !(plant.delta > 0)) return {0.0, 0.0};
    auto g = [&](double beta) { return passivity_condition_maximum({alpha, beta}, d).value; };
    // g(beta) >= |beta| - alpha (d + 1/2), so the interval lies inside |beta| < delta + alpha (d + 1/2).
    const double reach = plant.delta + alpha * (d + 0.5);
    const detail::ScalarMinimum m = detail::minimize_scalar(g, -reach, reach, 1e-15 * reach);
    if (!(m.value < plant.delta)) return {0.0, 0.0};
    auto passive = [&](double beta) { return g(beta) < plant.delta; };
    const auto lo = detail::bisect(passive, -reach, m.x, 0.0, 80);
    const auto hi = detail::bisect(passive, m.x, reach, 0.0, 80);
    return {lo.second, hi.first};  // the passive ends of the brackets
}
#else
    ;
#endif

struct PassiveAlphaLimit {
    double alpha = 0;  ///< sup of the passive alpha (open: alpha < this)
    double beta = 0;   ///< the beta of that tip
};

/// The largest passive alpha over all beta, and its beta (bisection on h(alpha) = min_beta max R).
HAPTICOPT_FUNC PassiveAlphaLimit largest_passive_alpha(const NormalizedPlant& plant)
#if HAPTICOPT_DEFINITIONS
{
    validate(plant, "hapticopt::largest_passive_alpha");
    const double d = detail::integer_delay(plant.delay, "hapticopt::largest_passive_alpha");
    if (!(plant.delta > 0)) return {};
    auto h = [&](double alpha) {
        const double reach = plant.delta + alpha * (d + 0.5);
        auto g = [&](double beta) { return passivity_condition_maximum({alpha, beta}, d).value; };
        return detail::minimize_scalar(g, -reach, reach, 1e-15 * reach);
    };
    const auto bracket =
        detail::bisect([&](double a) { return h(a).value < plant.delta; }, 0.0, 2 * plant.delta, 0.0, 80);
    return {bracket.first, h(bracket.first).x};
}
#else
    ;
#endif

struct PassivePoint {
    double alpha;
    double beta;
};

namespace detail {

/// The closed polygon of a passive set whose largest alpha is `top` and whose beta interval at alpha is
/// interval(alpha): `points` alphas per side, clustered at both ends (alpha_i = alpha_top (1 - cos(pi i /
/// (points - 1))) / 2), lower ends left to right, then upper ends right to left; empty when top.alpha <= 0.
template <typename Interval>
std::vector<PassivePoint> passive_outline(const PassiveAlphaLimit& top, int points, Interval&& interval) {
    std::vector<PassivePoint> lower, upper;
    if (!(top.alpha > 0)) return {};
    for (int i = 0; i < points; ++i) {
        const double a = top.alpha * (1 - std::cos(kPassivityPi * i / (points - 1))) / 2;
        if (i == points - 1) {
            lower.push_back({top.alpha, top.beta});
            break;
        }
        const auto [lo, hi] = interval(a);
        if (!(hi > lo)) continue;
        lower.push_back({a, lo});
        upper.push_back({a, hi});
    }
    std::vector<PassivePoint> out = lower;
    for (auto it = upper.rbegin(); it != upper.rend(); ++it) out.push_back(*it);
    return out;
}

}  // namespace detail

/// The passive set's boundary as a closed polygon (counter-clockwise from (0, lo(0))): `points` alphas
/// per side, clustered at both ends (alpha_i = alpha_top (1 - cos(pi i / (points - 1))) / 2); the first
/// point is not repeated at the end. Empty when delta = 0.
HAPTICOPT_FUNC std::vector<PassivePoint> passive_polygon(const NormalizedPlant& plant, int points = 64)
#if HAPTICOPT_DEFINITIONS
{
    detail::require_in_range("hapticopt::passive_polygon", "points", points, 3, false, 1e6, "3 <= points <= 10^6");
    return detail::passive_outline(largest_passive_alpha(plant), points,
                                   [&](double a) { return passive_beta_interval(plant, a); });
}
#else
    ;
#endif

/// The stable beta interval at alpha clipped to the passive set (empty: hi <= lo).
HAPTICOPT_FUNC std::pair<double, double> passive_beta_range(const StabilityRegion& region, double alpha)
#if HAPTICOPT_DEFINITIONS
{
    if (!(alpha > region.alpha_min()) || alpha > region.alpha_max()) return {0.0, 0.0};
    const auto [plo, phi] = passive_beta_interval(region.plant(), alpha);
    if (!(phi > plo)) return {0.0, 0.0};
    const auto [lo, hi] = region.beta_range(alpha);
    return {std::max(lo, plo), std::min(hi, phi)};
}
#else
    ;
#endif

struct PassiveOptimum {
    double alpha = 0;
    double beta = 0;
    double cost = 0;
    double margin = 0;  ///< passivity margin there (>= 0; ~0 when the optimum is on the edge)
};

/// The minimum of cost(alpha, beta) over the stable passive gains; nullopt when there are none
/// (delta = 0, or the passive set misses the stable region).
template <typename Cost>
std::optional<PassiveOptimum> passive_minimum(const StabilityRegion& region, Cost&& cost,
                                              const RegionSearchOptions& options = {}) {
    const double a0 = std::max(0.0, region.alpha_min());
    const double a1 = std::min(largest_passive_alpha(region.plant()).alpha, region.alpha_max());
    if (!(a1 > a0)) return std::nullopt;
    auto interval = [&](double a) { return passive_beta_range(region, a); };
    const RegionMinimum m = minimize_on_region(cost, a0, a1, interval, options);
    if (!std::isfinite(m.value)) return std::nullopt;
    return PassiveOptimum{m.alpha, m.beta, m.value, passivity_margin(region.plant(), NormalizedGains{m.alpha, m.beta})};
}

/// Best passive gains for the step criterion C_E<index> (index 0..2).
HAPTICOPT_FUNC std::optional<PassiveOptimum> passive_optimum(int index, const NormalizedPlant& plant,
                                                             const RegionSearchOptions& options = {})
#if HAPTICOPT_DEFINITIONS
{
    detail::require_in_range("hapticopt::passive_optimum", "index", index, 0, false, 2, "0, 1 or 2");
    detail::integer_delay(plant.delay, "hapticopt::passive_optimum");
    const StabilityRegion region(plant);
    const SampledPlant<double> sampled(plant);
    auto c = [&](double a, double b) {
        const EnergyCosts e = energy_costs(sampled, a, b);
        return index == 0 ? e.ce0 : index == 1 ? e.ce1 : e.ce2;
    };
    return passive_minimum(region, c, options);
}
#else
    ;
#endif

/// Best passive gains for the collision criterion C_I<index> (index 0..2).
HAPTICOPT_FUNC std::optional<PassiveOptimum> passive_impulse_optimum(int index, const NormalizedPlant& plant,
                                                                     const RegionSearchOptions& options = {})
#if HAPTICOPT_DEFINITIONS
{
    detail::require_in_range("hapticopt::passive_impulse_optimum", "index", index, 0, false, 2, "0, 1 or 2");
    detail::integer_delay(plant.delay, "hapticopt::passive_impulse_optimum");
    const StabilityRegion region(plant);
    const SampledPlant<double> sampled(plant);
    auto c = [&](double a, double b) { return impulse_costs(sampled, a, b)[index]; };
    return passive_minimum(region, c, options);
}
#else
    ;
#endif

}  // namespace hapticopt
