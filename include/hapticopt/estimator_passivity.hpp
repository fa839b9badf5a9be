// SPDX-License-Identifier: Apache-2.0
// Colgate-Schenkel passivity (passivity.hpp) of the wall with its velocity estimator (velocity_estimator.hpp):
// H(z) = z^-d (K + B D(z)), D(z) the estimator's transfer function (normalised, T = 1):
//   backward  D = 1 - z^-1
//   window N  D = (1 - z^-N) / N
//   low-pass  D = (1 - lambda)(1 - z^-1) / (1 - lambda z^-1),   lambda = exp(-2 pi nu).
// Condition (Colgate and Schenkel 1997, normalised as in passivity.hpp): delta > R(theta) for 0 <= theta <= pi,
//   R(theta) = Re{ (1 - e^{-j theta}) e^{-j d theta} (alpha + beta D(e^{j theta})) } / (2 (1 - cos theta)).
// The alpha term is passivity.hpp's: alpha D_d(c) / 2 = alpha / 2 + alpha sum_{k=1..d} T_k(c), c = cos theta.
// Write C_n = cos n theta - cos (n + 1) theta = (1 - cos theta) D_n (the Dirichlet identity of passivity.hpp).
// Window: Re{(1 - e^{-j theta})(1 - e^{-j N theta}) e^{-j d theta}} = C_d - C_{d+N} = (1 - cos theta)(D_d - D_{d+N}),
// and (D_d - D_{d+N}) / 2 = -sum_{k=d+1..d+N} cos k theta, so
//   R = alpha D_d / 2 - (beta / N) sum_{k=d+1..d+N} T_k(c),
// a Chebyshev series of degree d + N (N = 1: passivity.hpp's -beta T_{d+1}).
// Low-pass: multiply numerator and denominator by conj(1 - lambda e^{-j theta}); the denominator becomes
// q(c) = |1 - lambda e^{-j theta}|^2 = 1 + lambda^2 - 2 lambda c >= (1 - lambda)^2 > 0, and with
// Re{(1 - e^{-j theta})^2 e^{-j n theta}} / (2 (1 - cos theta)) = (D_n - D_{n+1}) / 2 = -cos (n + 1) theta
// (also for n = -1, where both sides are -1):
//   R = alpha D_d / 2 + beta (1 - lambda)(lambda T_d(c) - T_{d+1}(c)) / q(c) = s(c) / q(c),
//   s = (alpha D_d / 2) q + beta (1 - lambda)(lambda T_d - T_{d+1}),   a Chebyshev series of degree d + 1.
// (lambda -> 0 gives the backward difference.) Every estimator: R(theta = 0) = alpha (d + 1/2) - beta (D(z) ~ 1 - z^-1
// at low frequency), and the mean of R over theta in [0, pi] is alpha / 2 (the beta term has mean 0: for the
// window sum of cos k theta, k >= 1; for the low-pass by the Poisson kernel 1/q = (1 + 2 sum lambda^k cos k theta)
// / (1 - lambda^2), whose products with lambda T_d - T_{d+1} have mean lambda^{d+1} - lambda^{d+1} = 0), so
// a passive wall has alpha < 2 delta whatever the estimator.
//
// Method (exact maximum, the cascade of passivity.hpp generalised to R = s / q with q of degree <= 1, q = 1 for the
// FIR estimators): max R over c in [-1, 1] is at c = +-1 or at a sign change of R' = u / q^2,
// u = s' q - s q' (a Chebyshev series; u = s' for q = 1). The sign changes of u are bracketed by the derivative
// cascade of u (u^{(m)} constant; between consecutive sign-changing zeros of u^{(k+1)} and +-1, u^{(k)} is monotone:
// at most one sign change, bisected to adjacent doubles). Products of Chebyshev series by T_m T_n = (T_{m+n} +
// T_{|m-n|}) / 2; values by Clenshaw's recurrence.
// Error bound (`error_bound`): on a bracket [lo, hi] of a zero of u, u is monotone, so |R'| <= max(|u(lo)|, |u(hi)|)
// / min(q(lo), q(hi))^2 there (q is linear) and the maximum inside exceeds R(midpoint) by at most half the width
// times that; plus a rounding allowance 8 (deg s + 2)^2 u_r times the value's scale: sum |s_k| for the window; for
// the low-pass, whose R is evaluated as alpha D_d / 2 + beta (1 - lambda)(lambda T_d - T_{d+1}) / q with
// q = (1 - lambda)^2 + 2 lambda (1 - c) (no cancellation near c = 1, 1 - lambda by expm1), alpha (d + 1/2) +
// |beta| (1 + lambda) / (1 - lambda); u_r the unit roundoff. Checked in tests/beyond/test_estimator_beyond.cpp
// against a fine theta grid of the complex form; slow low-passes against a long double log-grid search (nu down to
// 1e-6) and the exact R(0). Verified up to degree 200 of s (d + N for the window, d + 1 for the low-pass;
// InvalidParameter naming `delay` beyond): the cascade's coefficients grow like degree^order and lose their digits
// past it. Cost O((d + N)^3) flops (window) or O(d^3) (low-pass), ~60 bisection steps per bracket.
//
// The margin, the passive beta interval and the largest passive alpha as in passivity.hpp: mu = delta - max R
// (alpha >= 0), min(mu, alpha) for alpha < 0. g(beta) = max R is convex in beta (a maximum of affine functions) and
// grows without bound both ways (the beta term has mean 0 and is not identically 0, so it is positive somewhere and
// negative somewhere); the interval's search box |beta| < r starts at delta + alpha (d + 1/2) (R(0) = alpha (d + 1/2) -
// beta bounds the lower end) and doubles until g >= delta at both ends; then Brent on g and bisection on each side.
// The largest passive alpha: bisection on the convex h(alpha) = min_beta g over (0, 2 delta). The backward difference
// goes to passivity.hpp's functions (identical numbers). Integer delays only (passivity.hpp).
// The passive optima (passive_optimum, passive_impulse_optimum with an estimator): the minimum of C_Ep or C_Ip over
// the main stable region (EstimatorStabilityRegion) intersected with the passive beta interval, by
// minimize_on_region (region_minimum.hpp), as passivity.hpp's passive_minimum does for the backward difference.
#pragma once

#include <algorithm>
#include <cmath>
#include <limits>
#include <optional>
#include <utility>
#include <vector>

#include "config.hpp"
#include "estimator_costs.hpp"
#include "estimator_impulse.hpp"
#include "estimator_region.hpp"
#include "passivity.hpp"
#include "estimator_types.hpp"

namespace hapticopt {

namespace detail {

/// Chebyshev series product: sum a_m T_m times sum b_n T_n.
inline std::vector<double> chebyshev_product(const std::vector<double>& a, const std::vector<double>& b) {
    std::vector<double> c(a.size() + b.size() - 1, 0.0);
    for (std::size_t m = 0; m < a.size(); ++m) {
        for (std::size_t n = 0; n < b.size(); ++n) {
            const double h = a[m] * b[n] / 2;
            c[m + n] += h;
            c[m > n ? m - n : n - m] += h;
        }
    }
    return c;
}

/// Brackets [lo, hi] of the sign changes of sum a_k T_k(c) on [-1, 1], by the derivative cascade (header).
inline std::vector<ChebyshevBracket> chebyshev_sign_changes(const std::vector<double>& a) {
    std::vector<std::vector<double>> derivative(std::max<std::size_t>(a.size(), 1));
    derivative[0] = a;
    for (std::size_t k = 1; k < derivative.size(); ++k) derivative[k] = chebyshev_derivative(derivative[k - 1]);
    return chebyshev_cascade_zeros(derivative, 0);
}

/// Largest Chebyshev degree of s (window: d + N; low-pass: d + 1) whose derivative cascade is verified
/// (tests/beyond/test_estimator_beyond.cpp, at this degree against a direct cosine sum): beyond it the cascade's
/// coefficients (growing like degree^order) lose their digits and sign changes can be missed.
inline constexpr int kMaxEstimatorPassivityDegree = 200;

/// The delay as an integer, and the degree of s within kMaxEstimatorPassivityDegree; throws InvalidParameter
/// naming `delay` otherwise.
inline int estimator_passivity_delay(double delay, const VelocityEstimator& estimator, const char* function) {
    const int d = integer_delay(delay, function);
    const int order = estimator.kind == VelocityEstimatorKind::window ? estimator.window : 1;
    if (estimator.kind != VelocityEstimatorKind::backward && d > kMaxEstimatorPassivityDegree - order) {
        throw InvalidParameter(function, "delay", delay,
                               "an integer number of periods with delay + window <= 200 (low-pass: delay <= 199), "
                               "the degree up to which the passivity condition's exact maximum is verified");
    }
    return d;
}

/// R = s / q of the header: Chebyshev coefficients of s and of q (q = {1} for the FIR estimators); for the
/// low-pass also 1 - lambda (by expm1) and lambda, for the cancellation-free forms of the value (below).
struct PassivityRational {
    std::vector<double> s, q;
    std::vector<double> alpha_part, beta_part;  ///< low-pass: alpha D_d / 2 and lambda T_d - T_{d+1}
    double one_minus_lambda = 1.0, lambda = 0.0;
};

inline PassivityRational estimator_passivity_rational(const NormalizedGains& gains, int delay,
                                                      const VelocityEstimator& estimator) {
    std::vector<double> p(static_cast<std::size_t>(delay) + 1, gains.alpha);  // alpha D_d / 2
    p[0] = gains.alpha / 2;
    PassivityRational r;
    if (estimator.kind == VelocityEstimatorKind::lowpass) {
        const double lambda = std::exp(-2.0 * kPassivityPi * estimator.cutoff);
        r.lambda = lambda;
        r.one_minus_lambda = -std::expm1(-2.0 * kPassivityPi * estimator.cutoff);
        r.q = {1 + lambda * lambda, -2 * lambda};
        r.alpha_part = p;
        r.beta_part.assign(static_cast<std::size_t>(delay) + 2, 0.0);
        r.beta_part[static_cast<std::size_t>(delay)] = lambda;
        r.beta_part[static_cast<std::size_t>(delay) + 1] = -1.0;
        r.s = chebyshev_product(p, r.q);
        r.s.resize(static_cast<std::size_t>(delay) + 2, 0.0);
        r.s[static_cast<std::size_t>(delay)] += gains.beta * (1 - lambda) * lambda;
        r.s[static_cast<std::size_t>(delay) + 1] -= gains.beta * (1 - lambda);
        return r;
    }
    const int n = estimator.kind == VelocityEstimatorKind::window ? estimator.window : 1;
    r.q = {1.0};
    r.s = p;
    r.s.resize(static_cast<std::size_t>(delay + n) + 1, 0.0);
    for (int k = delay + 1; k <= delay + n; ++k) r.s[static_cast<std::size_t>(k)] -= gains.beta / n;
    return r;
}

/// R(c) without the cancellations of s / q near c = 1 (slow low-pass: q ~ (1 - lambda)^2): the alpha part
/// alpha D_d / 2 by Clenshaw, the beta part beta (1 - lambda)(lambda T_d - T_{d+1}) / q with
/// q = (1 - lambda)^2 + 2 lambda (1 - c) (1 - c exact near c = 1); the window's R is s itself.
inline double estimator_passivity_value(const PassivityRational& r, double beta, double c) {
    if (r.q.size() == 1) return chebyshev_value(r.s.data(), static_cast<int>(r.s.size()), c);
    const double q = r.one_minus_lambda * r.one_minus_lambda + 2 * r.lambda * (1 - c);
    return chebyshev_value(r.alpha_part.data(), static_cast<int>(r.alpha_part.size()), c) +
           beta * r.one_minus_lambda * chebyshev_value(r.beta_part.data(), static_cast<int>(r.beta_part.size()), c) / q;
}

}  // namespace detail

/// R(theta) of the header with the estimator (closed form s(c) / q(c)), the right-hand side of delta > R.
/// Throws InvalidParameter for non-finite gains, a fractional delay, an invalid estimator or theta outside [0, pi].
inline double passivity_condition(const NormalizedGains& gains, double delay, double theta,
                                  const VelocityEstimator& estimator) {
    const char* fn = "hapticopt::passivity_condition";
    validate(gains, fn);
    validate(estimator, fn);
    const int d = detail::estimator_passivity_delay(delay, estimator, fn);
    detail::require_in_range(fn, "theta", theta, 0.0, false, detail::kPassivityPi, "0 <= theta <= pi");
    const detail::PassivityRational r = detail::estimator_passivity_rational(gains, d, estimator);
    return detail::estimator_passivity_value(r, gains.beta, std::cos(theta));
}

/// The exact maximum over theta in [0, pi] of R with the estimator (header: derivative cascade on u = s' q - s q',
/// with its error bound). The backward difference is passivity_condition_maximum(gains, delay).
HAPTICOPT_FUNC PassivityConditionMaximum passivity_condition_maximum(const NormalizedGains& gains, double delay,
                                                                     const VelocityEstimator& estimator)
#if HAPTICOPT_DEFINITIONS
{
    const char* fn = "hapticopt::passivity_condition_maximum";
    validate(gains, fn);
    validate(estimator, fn);
    const int d = detail::estimator_passivity_delay(delay, estimator, fn);
    if (estimator.kind == VelocityEstimatorKind::backward) return passivity_condition_maximum(gains, delay);
    const detail::PassivityRational r = detail::estimator_passivity_rational(gains, d, estimator);
    std::vector<double> u = detail::chebyshev_product(detail::chebyshev_derivative(r.s), r.q);  // s' q - s q'
    const double dq = r.q.size() > 1 ? r.q[1] : 0.0;
    if (u.size() < r.s.size()) u.resize(r.s.size(), 0.0);
    for (std::size_t k = 0; k < r.s.size(); ++k) u[k] -= r.s[k] * dq;
    auto q_at = [&](double c) {
        return r.q.size() == 1 ? 1.0 : r.one_minus_lambda * r.one_minus_lambda + 2 * r.lambda * (1 - c);
    };
    auto value = [&](double c) { return detail::estimator_passivity_value(r, gains.beta, c); };
    auto u_at = [&](double c) { return detail::chebyshev_value(u.data(), static_cast<int>(u.size()), c); };
    PassivityConditionMaximum best;
    best.value = value(1.0);
    best.theta = 0.0;
    auto consider = [&](double c) {
        const double v = value(c);
        if (v > best.value) {
            best.value = v;
            best.theta = std::acos(std::clamp(c, -1.0, 1.0));
        }
    };
    consider(-1.0);
    double bracket_error = 0;
    for (const detail::ChebyshevBracket& z : detail::chebyshev_sign_changes(u)) {
        consider((z.lo + z.hi) / 2);
        const double qmin = std::min(q_at(z.lo), q_at(z.hi));
        const double slope = std::max(std::abs(u_at(z.lo)), std::abs(u_at(z.hi))) / (qmin * qmin);
        bracket_error = std::max(bracket_error, (z.hi - z.lo) / 2 * slope);
    }
    // Rounding of the value: Clenshaw's 8 (deg + 2)^2 u times the coefficients' sum for the window's s; for the
    // low-pass the alpha part's sum plus the beta part's |beta| (1 - lambda)(1 + lambda) / q_min (q with relative
    // error a few u, q_min = (1 - lambda)^2).
    const double deg = static_cast<double>(r.s.size()) + 1;
    double scale = 0;
    if (r.q.size() == 1) {
        for (double a : r.s) scale += std::abs(a);
    } else {
        scale = std::abs(gains.alpha) * (d + 0.5) + std::abs(gains.beta) * (1 + r.lambda) / r.one_minus_lambda;
    }
    best.error_bound = bracket_error + 8.0 * deg * deg * (std::numeric_limits<double>::epsilon() / 2) * scale;
    return best;
}
#else
    ;
#endif

/// Passivity margin with the estimator: mu = delta - max R (alpha >= 0), min(mu, alpha) (alpha < 0); > 0 iff
/// passive. Throws InvalidParameter for a fractional delay or invalid inputs.
HAPTICOPT_FUNC double passivity_margin(const NormalizedPlant& plant, const NormalizedGains& gains,
                                       const VelocityEstimator& estimator)
#if HAPTICOPT_DEFINITIONS
{
    const char* fn = "hapticopt::passivity_margin";
    validate(plant, fn);
    validate(gains, fn);
    validate(estimator, fn);
    detail::estimator_passivity_delay(plant.delay, estimator, fn);
    if (estimator.kind == VelocityEstimatorKind::backward) return passivity_margin(plant, gains);
    const double mu = plant.delta - passivity_condition_maximum(gains, plant.delay, estimator).value;
    return gains.alpha < 0 ? std::min(mu, gains.alpha) : mu;
}
#else
    ;
#endif

/// Colgate-Schenkel with the delay and the estimator: passivity_margin(plant, gains, estimator) > 0.
HAPTICOPT_FUNC bool is_passive(const NormalizedPlant& plant, const NormalizedGains& gains,
                               const VelocityEstimator& estimator)
#if HAPTICOPT_DEFINITIONS
{
    return passivity_margin(plant, gains, estimator) > 0;
}
#else
    ;
#endif

namespace detail {

/// min_beta g(beta) = max R(alpha, beta) with the search box of the header; returns the minimum and the box r.
template <typename G>
std::pair<ScalarMinimum, double> passive_beta_minimum(G&& g, double delta, double alpha, int delay) {
    double r = delta + alpha * (delay + 0.5);
    if (!(r > 0)) r = 1e-300;
    for (int k = 0; k < 200 && (g(r) < delta || g(-r) < delta); ++k) r *= 2;
    return {minimize_scalar(g, -r, r, 1e-15 * r), r};
}

}  // namespace detail

/// The open beta interval (lo, hi) of passive gains at alpha with the estimator (empty: hi <= lo; alpha < 0 or
/// delta = 0: empty). Header comment for the search. Throws InvalidParameter for a fractional delay.
HAPTICOPT_FUNC std::pair<double, double> passive_beta_interval(const NormalizedPlant& plant, double alpha,
                                                               const VelocityEstimator& estimator)
#if HAPTICOPT_DEFINITIONS
{
    const char* fn = "hapticopt::passive_beta_interval";
    validate(plant, fn);
    validate(estimator, fn);
    detail::require_finite(fn, "alpha", alpha);
    const int d = detail::estimator_passivity_delay(plant.delay, estimator, fn);
    if (estimator.kind == VelocityEstimatorKind::backward) return passive_beta_interval(plant, alpha);
    if (alpha < 0 || !(plant.delta > 0)) return {0.0, 0.0};
    auto g = [&](double beta) { return passivity_condition_maximum({alpha, beta}, d, estimator).value; };
    const auto [m, r] = detail::passive_beta_minimum(g, plant.delta, alpha, d);
    if (!(m.value < plant.delta)) return {0.0, 0.0};
    auto passive = [&](double beta) { return g(beta) < plant.delta; };
    const auto lo = detail::bisect(passive, -r, m.x, 0.0, 80);
    const auto hi = detail::bisect(passive, m.x, r, 0.0, 80);
    return {lo.second, hi.first};
}
#else
    ;
#endif

/// The largest passive alpha over all beta with the estimator, and its beta (bisection on the convex
/// h(alpha) = min_beta max R over (0, 2 delta), header). Zero when delta = 0.
HAPTICOPT_FUNC PassiveAlphaLimit largest_passive_alpha(const NormalizedPlant& plant, const VelocityEstimator& estimator)
#if HAPTICOPT_DEFINITIONS
{
    const char* fn = "hapticopt::largest_passive_alpha";
    validate(plant, fn);
    validate(estimator, fn);
    const int d = detail::estimator_passivity_delay(plant.delay, estimator, fn);
    if (estimator.kind == VelocityEstimatorKind::backward) return largest_passive_alpha(plant);
    if (!(plant.delta > 0)) return {};
    auto h = [&](double alpha) {
        auto g = [&](double beta) { return passivity_condition_maximum({alpha, beta}, d, estimator).value; };
        return detail::passive_beta_minimum(g, plant.delta, alpha, d).first;
    };
    const auto bracket =
        detail::bisect([&](double a) { return h(a).value < plant.delta; }, 0.0, 2 * plant.delta, 0.0, 80);
    return {bracket.first, h(bracket.first).x};
}
#else
    ;
#endif

/// The passive set's boundary with the estimator as a closed polygon, as passive_polygon(plant, points) of
/// passivity.hpp (`points` alphas per side, clustered at both ends; the first point not repeated). Empty when
/// delta = 0. Throws InvalidParameter unless 3 <= points <= 10^6, and for a fractional delay.
HAPTICOPT_FUNC std::vector<PassivePoint> passive_polygon(const NormalizedPlant& plant,
                                                         const VelocityEstimator& estimator, int points = 64)
#if HAPTICOPT_DEFINITIONS
{
    const char* fn = "hapticopt::passive_polygon";
    detail::require_in_range(fn, "points", points, 3, false, 1e6, "3 <= points <= 10^6");
    validate(plant, fn);
    validate(estimator, fn);
    detail::estimator_passivity_delay(plant.delay, estimator, fn);
    if (estimator.kind == VelocityEstimatorKind::backward) return passive_polygon(plant, points);
    return detail::passive_outline(largest_passive_alpha(plant, estimator), points,
                                   [&](double a) { return passive_beta_interval(plant, a, estimator); });
}
#else
    ;
#endif

/// The minimum of cost(alpha, beta) over the stable passive gains with the estimator: alpha in (0, min(largest
/// passive alpha, alpha_max of the main region)), beta in the main region's interval clipped to the passive one;
/// nullopt when there are none (delta = 0, or the passive set misses the main region). The margin at the point is
/// passivity_margin with the estimator (>= 0 up to the intervals' bisection; ~0 on the passive edge).
template <typename Cost>
std::optional<PassiveOptimum> passive_minimum(const NormalizedPlant& plant, const VelocityEstimator& estimator,
                                              Cost&& cost, const RegionSearchOptions& options) {
    const EstimatorStabilityRegion region(plant, estimator);
    const double a1 = std::min(largest_passive_alpha(plant, estimator).alpha, region.alpha_max());
    if (!(a1 > 0)) return std::nullopt;
    auto interval = [&](double a) -> std::pair<double, double> {
        const auto [plo, phi] = passive_beta_interval(plant, a, estimator);
        const auto [lo, hi] = region.beta_interval(a);
        if (!(phi > plo) || !(hi > lo)) return {0.0, 0.0};
        return {std::max(lo, plo), std::min(hi, phi)};
    };
    const RegionMinimum m = minimize_on_region(cost, 0.0, a1, interval, options);
    if (!std::isfinite(m.value)) return std::nullopt;
    return PassiveOptimum{m.alpha, m.beta, m.value,
                          passivity_margin(plant, NormalizedGains{m.alpha, m.beta}, estimator)};
}

/// Best passive gains for the step criterion C_E<index> (index 0..2) with the estimator; the backward difference is
/// passive_optimum(index, plant, options) of passivity.hpp. Throws InvalidParameter for an index outside 0..2, a
/// fractional delay or an invalid estimator.
HAPTICOPT_FUNC std::optional<PassiveOptimum> passive_optimum(int index, const NormalizedPlant& plant,
                                                             const VelocityEstimator& estimator,
                                                             const RegionSearchOptions& options = {})
#if HAPTICOPT_DEFINITIONS
{
    detail::require_in_range("hapticopt::passive_optimum", "index", index, 0, false, 2, "0, 1 or 2");
    detail::estimator_passivity_delay(plant.delay, estimator, "hapticopt::passive_optimum");
    validate(estimator, "hapticopt::passive_optimum");
    if (estimator.kind == VelocityEstimatorKind::backward) return passive_optimum(index, plant, options);
    const SampledPlant<double> sampled(plant);
    auto c = [&](double a, double b) {
        const EnergyCosts e = estimator_energy_costs(sampled, estimator, a, b);
        return index == 0 ? e.ce0 : index == 1 ? e.ce1 : e.ce2;
    };
    return passive_minimum(plant, estimator, c, options);
}
#else
    ;
#endif

/// Best passive gains for the collision criterion C_I<index> (index 0..2) with the estimator; the backward
/// difference is passive_impulse_optimum(index, plant, options) of passivity.hpp.
HAPTICOPT_FUNC std::optional<PassiveOptimum> passive_impulse_optimum(int index, const NormalizedPlant& plant,
                                                                     const VelocityEstimator& estimator,
                                                                     const RegionSearchOptions& options = {})
#if HAPTICOPT_DEFINITIONS
{
    detail::require_in_range("hapticopt::passive_impulse_optimum", "index", index, 0, false, 2, "0, 1 or 2");
    detail::estimator_passivity_delay(plant.delay, estimator, "hapticopt::passive_impulse_optimum");
    validate(estimator, "hapticopt::passive_impulse_optimum");
    if (estimator.kind == VelocityEstimatorKind::backward) return passive_impulse_optimum(index, plant, options);
    const SampledPlant<double> sampled(plant);
    auto c = [&](double a, double b) { return estimator_impulse_costs(sampled, estimator, a, b)[index]; };
    return passive_minimum(plant, estimator, c, options);
}
#else
    ;
#endif

}  // namespace hapticopt
