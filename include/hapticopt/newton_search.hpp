// SPDX-License-Identifier: Apache-2.0
// Local minimisation with an analytic gradient, used by the fast optimum (optimum.hpp):
//  - minimize_newton_2d: Levenberg-Marquardt-damped Newton steps (a trust-region method: the damping mu
//    shrinks the step where the quadratic model fails) on f(x, y) given f and its gradient; the Hessian
//    is the callback's own where it returns one (ValueGradientHessian2; exact Hessians: estimator_hessian.hpp),
//    else forward differences of the analytic gradient (step 1e-6 in the scaled coordinates x / sx,
//    y / sy), kept after an accepted step below kKeepHessianBelow (a chord step: the Hessian there differs
//    by about that fraction, so each step still contracts the error by about as much; a kept Hessian whose step
//    is rejected is replaced by a fresh one at the same point). A step is accepted when f decreases, or when f
//    stays within rounding (8 eps |f|) and the gradient's norm decreases (at a minimum the values differ by
//    rounding only, the gradient still resolves the point); a rejected step leaving the domain (f not finite)
//    raises mu. Stops when a step (accepted, or proposed under any damping) is below `step_tolerance` in the
//    scaled coordinates, when a step below kUnresolvedStep is rejected inside the domain (the function no longer
//    resolves it), when no step is accepted, or after `max_iterations`; a proposed step below the tolerance is
//    not evaluated. With the callback's exact Hessian, an undamped step s_(k+1) following an undamped accepted
//    s_k is taken without evaluating f there, and ends the search, where the error it leaves, estimated from the
//    observed quadratic contraction as (s_(k+1) / s_k^2) s_(k+1)^2, is at or below `step_tolerance`; the value
//    returned is then the quadratic model's, f + g.s + s.H s / 2 (error third order in s). Converges quadratically near
//    a minimum with a positive definite Hessian (with the callback's exact Hessian at every step; with the differences
//    until the chord steps, whose Hessian's relative error ~1e-6 only slows the last step's contraction to ~1e-6 per
//    step); J. Nocedal, S. J. Wright, "Numerical Optimization", 2nd ed., 2006, ch. 4 and 10.
//  - minimize_newton_1d: the same for a function of one variable, kept inside (lo, hi), with a fresh second
//    derivative at every step and only the step-tolerance stop.
// Both converge to a local minimum; callers start them in the global minimum's basin (a coarse grid).
#pragma once

#include <algorithm>
#include <cmath>
#include <limits>
#include <type_traits>

namespace hapticopt::detail {

/// minimize_newton_2d keeps its Hessian after an accepted step below this (scaled coordinates): from there
/// the Hessian changes by about that fraction, so each further step still contracts the error by about as much.
inline constexpr double kKeepHessianBelow = 1e-3;
/// A step below this (scaled coordinates) rejected inside the domain ends minimize_newton_2d: the model's decrease
/// over it, ~ step^2, is below the values' rounding, and the gradient there differs from the point's by rounding
/// only. (A step rejected for leaving the domain raises the damping instead.)
inline constexpr double kUnresolvedStep = 1e-8;

struct ValueAndGradient2 {
    double value;  ///< f, +inf (or NaN) outside the domain
    double dx;
    double dy;
};

/// A result of minimize_newton_2d's callback with the Hessian: f, its gradient and its second derivatives.
struct ValueGradientHessian2 {
    double value;  ///< f, +inf (or NaN) outside the domain
    double dx;
    double dy;
    double dxx;
    double dxy;
    double dyy;
};

/// True for callback results with members dxx, dxy, dyy (minimize_newton_2d then takes the Hessian from them).
template <typename R, typename = void>
struct has_hessian2 : std::false_type {};
template <typename R>
struct has_hessian2<R, std::void_t<decltype(R::dxx), decltype(R::dxy), decltype(R::dyy)>> : std::true_type {};

struct NewtonMinimum2 {
    double x;
    double y;
    double value;
    int evaluations;  ///< calls of the function
};

/// See the header comment. `fg(x, y)` returns ValueAndGradient2 (or anything with value, dx, dy members), or
/// ValueGradientHessian2 (members dxx, dxy, dyy too): the Hessian is then the callback's at every point where it
/// is finite (no difference evaluations, no kept Hessian), and the forward differences where it is not.
template <typename F>
NewtonMinimum2 minimize_newton_2d(F&& fg, double x, double y, double sx, double sy, double step_tolerance = 1e-12,
                                  int max_iterations = 60) {
    const double eps = std::numeric_limits<double>::epsilon();
    int evaluations = 0;
    struct Point {
        double u, v, f, gu, gv;
        double huu, hvv, huv;  // the callback's Hessian in the scaled coordinates (NaN without one)
    };
    using Result = std::decay_t<decltype(fg(x, y))>;
    auto eval = [&](double u, double v) {
        ++evaluations;
        const Result r = fg(u * sx, v * sy);
        const double nan = std::numeric_limits<double>::quiet_NaN();
        if constexpr (has_hessian2<Result>::value) {
            return Point{u, v, r.value, r.dx * sx, r.dy * sy, r.dxx * sx * sx, r.dyy * sy * sy, r.dxy * sx * sy};
        } else {
            return Point{u, v, r.value, r.dx * sx, r.dy * sy, nan, nan, nan};
        }
    };
    auto finite = [](const Point& p) { return std::isfinite(p.f) && std::isfinite(p.gu) && std::isfinite(p.gv); };
    Point p = eval(x / sx, y / sy);
    if (!finite(p)) return {x, y, p.f, evaluations};
    const double h = 1e-6;
    double mu = 0;
    double huu = 0, hvv = 0, huv = 0, floor_mu = 0;
    double previous_step = 0;  // the last accepted step's length where it was undamped, else 0
    bool fresh_hessian = true;
    for (int it = 0; it < max_iterations; ++it) {
        const bool exact = std::isfinite(p.huu) && std::isfinite(p.hvv) && std::isfinite(p.huv);
        const bool reused = !fresh_hessian && !exact;
        if (exact) {  // the callback's Hessian at p
            huu = p.huu;
            hvv = p.hvv;
            huv = p.huv;
            floor_mu = 1e-3 * (std::abs(huu) + std::abs(hvv)) + 1e-300;
        } else if (fresh_hessian) {
            // Hessian by forward differences of the gradient (backward where the forward point is outside).
            Point pu = eval(p.u + h, p.v);
            double hu = h;
            if (!finite(pu)) {
                pu = eval(p.u - h, p.v);
                hu = -h;
            }
            Point pv = eval(p.u, p.v + h);
            double hv = h;
            if (!finite(pv)) {
                pv = eval(p.u, p.v - h);
                hv = -h;
            }
            if (!finite(pu) || !finite(pv)) break;
            huu = (pu.gu - p.gu) / hu;
            hvv = (pv.gv - p.gv) / hv;
            huv = ((pu.gv - p.gv) / hu + (pv.gu - p.gu) / hv) / 2;
            floor_mu = 1e-3 * (std::abs(huu) + std::abs(hvv)) + 1e-300;
        }
        const double gnorm = std::hypot(p.gu, p.gv);
        bool accepted = false, converged = false, refresh = false, undamped = false;
        double step = 0;
        for (int tries = 0; tries < 40 && !accepted; ++tries) {
            const double a = huu + mu, c = hvv + mu, det = a * c - huv * huv;
            if (!(a > 0 && det > 0)) {
                mu = std::max(4 * mu, floor_mu);
                continue;
            }
            const double su = -(c * p.gu - huv * p.gv) / det, sv = -(a * p.gv - huv * p.gu) / det;
            const double proposed = std::hypot(su, sv);
            if (proposed <= step_tolerance) {  // converged: a step this small is not evaluated
                converged = true;
                break;
            }
            // An undamped step on the callback's Hessian after an accepted one: the contraction observed over the
            // last two steps, proposed / previous^2, predicts the error left after this step; at or below the
            // tolerance, the step is taken unevaluated, with the quadratic model's value (its error is third
            // order in the step).
            if (exact && mu == 0 && previous_step > 0 &&
                proposed / (previous_step * previous_step) * proposed * proposed <= step_tolerance) {
                p.f += p.gu * su + p.gv * sv + (huu * su * su + 2 * huv * su * sv + hvv * sv * sv) / 2;
                p.u += su;
                p.v += sv;
                converged = true;
                break;
            }
            const Point q = eval(p.u + su, p.v + sv);
            const bool lower = q.f < p.f;
            const bool level = q.f <= p.f + 8 * eps * std::abs(p.f) && std::hypot(q.gu, q.gv) < gnorm;
            if (finite(q) && (lower || level)) {
                p = q;
                step = std::hypot(su, sv);
                accepted = true;
                undamped = mu == 0;
                mu = mu / 4 < 1e-6 * floor_mu ? 0 : mu / 4;
            } else if (finite(q) && std::hypot(su, sv) <= kUnresolvedStep) {  // rounding level: stop here
                converged = true;
                break;
            } else if (reused) {  // the kept Hessian failed: a fresh one at the same point
                refresh = true;
                break;
            } else {
                mu = std::max(4 * mu, floor_mu);
            }
        }
        if (refresh) {
            fresh_hessian = true;
            continue;
        }
        if (converged || !accepted || step <= step_tolerance) break;
        fresh_hessian = step > kKeepHessianBelow;
        previous_step = undamped ? step : 0;
    }
    return {p.u * sx, p.v * sy, p.f, evaluations};
}

struct ValueAndDerivative {
    double value;  ///< f, +inf (or NaN) outside the domain
    double dx;
};

/// Damped Newton on f(x) given f and f' (`fd(x)` returns ValueAndDerivative), from x, kept inside (lo, hi);
/// the second derivative from a forward difference of f' (step 1e-6 (hi - lo)). Same acceptance and stops as
/// minimize_newton_2d with the step tolerance relative to (hi - lo).
template <typename F>
NewtonMinimum2 minimize_newton_1d(F&& fd, double x, double lo, double hi, double step_tolerance = 1e-12,
                                  int max_iterations = 60) {
    const double eps = std::numeric_limits<double>::epsilon();
    const double width = hi - lo;
    int evaluations = 0;
    auto eval = [&](double t) {
        ++evaluations;
        return fd(t);
    };
    auto finite = [](const ValueAndDerivative& v) { return std::isfinite(v.value) && std::isfinite(v.dx); };
    ValueAndDerivative p = eval(x);
    if (!finite(p)) return {x, 0, p.value, evaluations};
    const double h = 1e-6 * width;
    double mu = 0;
    for (int it = 0; it < max_iterations; ++it) {
        double dh = x + h < hi ? h : -h;
        ValueAndDerivative ph = eval(x + dh);
        if (!finite(ph)) {
            dh = -dh;
            ph = eval(x + dh);
        }
        if (!finite(ph)) break;
        const double curvature = (ph.dx - p.dx) / dh;
        const double floor_mu = 1e-3 * std::abs(curvature) + 1e-300;
        bool accepted = false, converged = false;
        double step = 0;
        for (int tries = 0; tries < 40 && !accepted; ++tries) {
            const double a = curvature + mu;
            if (!(a > 0)) {
                mu = std::max(4 * mu, floor_mu);
                continue;
            }
            const double s = -p.dx / a;
            if (std::abs(s) <= step_tolerance * width) {  // converged: a step this small is not evaluated
                converged = true;
                break;
            }
            const double t = x + s;
            if (!(t > lo && t < hi)) {
                mu = std::max(4 * mu, floor_mu);
                continue;
            }
            const ValueAndDerivative q = eval(t);
            const bool lower = q.value < p.value;
            const bool level = q.value <= p.value + 8 * eps * std::abs(p.value) && std::abs(q.dx) < std::abs(p.dx);
            if (finite(q) && (lower || level)) {
                x = t;
                p = q;
                step = std::abs(s);
                accepted = true;
                mu = mu / 4 < 1e-6 * floor_mu ? 0 : mu / 4;
            } else {
                mu = std::max(4 * mu, floor_mu);
            }
        }
        if (converged || !accepted || step <= step_tolerance * width) break;
    }
    return {x, 0, p.value, evaluations};
}

}  // namespace hapticopt::detail
