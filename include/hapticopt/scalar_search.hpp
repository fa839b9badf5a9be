// SPDX-License-Identifier: Apache-2.0
// One-dimensional searches used by the optimisers: Brent's minimiser (golden section with
// parabolic interpolation; R. P. Brent, "Algorithms for Minimization without Derivatives", 1973,
// ch. 5), bisection on a sign change, and the Illinois variant of regula falsi for a sign change of a continuous
// function. Both treat non-finite values as "worse than any finite".
#pragma once

#include <cmath>
#include <limits>
#include <utility>

namespace hapticopt::detail {

struct ScalarMinimum {
    double x;
    double value;
};

/// Minimum of f on [a, b] to an absolute tolerance `tol` in x (plus ~sqrt(eps) |x|).
/// Converges to a local minimum; callers bracket the global one first.
template <typename F>
ScalarMinimum minimize_scalar(F&& f, double a, double b, double tol, int max_iterations = 200) {
    const double golden = 0.3819660112501051;  // (3 - sqrt 5) / 2
    const double rel = std::sqrt(std::numeric_limits<double>::epsilon());
    auto eval = [&](double x) {
        const double v = f(x);
        return std::isfinite(v) ? v : std::numeric_limits<double>::max();
    };
    double x = a + golden * (b - a);
    double w = x, v = x;
    double fx = eval(x), fw = fx, fv = fx;
    double d = 0, e = 0;
    for (int it = 0; it < max_iterations; ++it) {
        const double m = (a + b) / 2;
        const double tol1 = rel * std::abs(x) + tol / 3;
        const double tol2 = 2 * tol1;
        if (std::abs(x - m) <= tol2 - (b - a) / 2) break;
        bool golden_step = true;
        if (std::abs(e) > tol1) {  // try a parabola through x, w, v
            double r = (x - w) * (fx - fv);
            double q = (x - v) * (fx - fw);
            double p = (x - v) * q - (x - w) * r;
            q = 2 * (q - r);
            if (q > 0)
                p = -p;
            else
                q = -q;
            const double e_prev = e;
            e = d;
            if (std::isfinite(p) && std::isfinite(q) && std::abs(p) < std::abs(q * e_prev / 2) && p > q * (a - x) &&
                p < q * (b - x)) {
                d = p / q;
                const double u = x + d;
                if (u - a < tol2 || b - u < tol2) d = x < m ? tol1 : -tol1;
                golden_step = false;
            }
        }
        if (golden_step) {
            e = (x < m ? b : a) - x;
            d = golden * e;
        }
        const double u = x + (std::abs(d) >= tol1 ? d : (d > 0 ? tol1 : -tol1));
        const double fu = eval(u);
        if (fu <= fx) {
            (u < x ? b : a) = x;
            v = w;
            fv = fw;
            w = x;
            fw = fx;
            x = u;
            fx = fu;
        } else {
            (u < x ? a : b) = u;
            if (fu <= fw || w == x) {
                v = w;
                fv = fw;
                w = u;
                fw = fu;
            } else if (fu <= fv || v == x || v == w) {
                v = u;
                fv = fu;
            }
        }
    }
    return {x, fx};
}

/// A root of g on [lo, hi] given g(lo) and g(hi) of opposite signs (or `pred(lo) != pred(hi)` for the
/// predicate form), by bisection down to |hi - lo| <= tol. Returns the bracket.
template <typename Pred>
std::pair<double, double> bisect(Pred&& pred, double lo, double hi, double tol, int max_iterations = 200) {
    const bool at_lo = pred(lo);
    for (int it = 0; it < max_iterations && std::abs(hi - lo) > tol; ++it) {
        const double mid = (lo + hi) / 2;
        if (pred(mid) == at_lo)
            lo = mid;
        else
            hi = mid;
    }
    return {lo, hi};
}

/// A bracket [a, b] of a sign change of a continuous g with g(a) < 0 < g(b), |b - a| <= tol, by the Illinois
/// variant of regula falsi (Dowell and Jarratt, "A modified regula falsi method for computing the root of an
/// equation", BIT 11, 1971: the endpoint kept twice in a row has its value halved; superlinear, order ~1.44, on a
/// simple root) with a bisection step whenever three steps failed to halve the bracket, so at most three times
/// bisection's steps; it stops early when a and b are adjacent doubles. Returns {a, b, false} as soon as some x has
/// g(x) == 0 exactly (then `a` = `b` = x) or g is not finite: the caller decides (e.g. bisects for the ends of a flat
/// zero set).
struct IllinoisBracket {
    double a, b;
    bool bracketed;
};

template <typename G>
IllinoisBracket illinois_bracket(G&& g, double a, double b, double ga, double gb, double tol,
                                 int max_iterations = 600) {
    int kept = 0;  // +1: a kept in a row, -1: b kept in a row
    double width = b - a;
    for (int it = 0; it < max_iterations && b - a > tol; ++it) {
        double x;
        if (it % 3 == 2 && b - a > width / 2) {
            x = a + (b - a) / 2;
        } else {
            x = a - ga * (b - a) / (gb - ga);
            if (!(x > a && x < b)) x = a + (b - a) / 2;
        }
        if (!(x > a && x < b)) break;  // a and b adjacent doubles: no narrower bracket exists
        if (it % 3 == 2) width = b - a;
        const double gx = g(x);
        if (!std::isfinite(gx) || gx == 0) return {x, x, false};
        if (gx < 0) {
            a = x;
            ga = gx;
            if (kept == -1) gb /= 2;
            kept = -1;
        } else {
            b = x;
            gb = gx;
            if (kept == +1) ga /= 2;
            kept = +1;
        }
    }
    return {a, b, true};
}

}  // namespace hapticopt::detail
