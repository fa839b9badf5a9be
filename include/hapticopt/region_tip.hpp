// SPDX-License-Identifier: Apache-2.0
// The candidates for the tip (largest alpha) of a stable set of the gain plane, from the D-decomposition of an
// affine characteristic polynomial p(z) = P_0 + alpha P_alpha + beta P_beta (characteristic_polynomial.hpp).
//
// On the unit circle z = e^{i theta}, p = 0 is two real equations linear in (alpha, beta); Cramer's rule gives the
// boundary curve C(theta) = (alpha(theta), beta(theta)) for theta in (0, pi), and its ends C(0), C(pi) solve
// p(+-1) = p'(+-1) = 0 (the limits theta -> 0, pi, since Im p(e^{i theta}) / sin(theta) -> +-p'(+-1)). A point
// C(theta) lies on the closure of a stable set iff the other roots of p there, those of the deflated polynomial
// q(z) = p(z) / (z^2 - 2 cos(theta) z + 1), are all inside the unit circle (Schur-Cohn, schur_cohn.hpp). The curve's
// arcs are the theta intervals where that holds. On the closure of a stable set, alpha is locally largest at
//  - a stationary point of alpha(theta) inside an arc: a smooth tip, or a cusp of the curve (C'(theta) = 0, where
//    alpha'(theta) = 0 too, so the parametrisation is smooth there);
//  - an end of an arc: a corner, where another pair of roots reaches the circle (a second branch of the curve, or
//    the lines p(1) = 0, p(-1) = 0, crosses);
//  - an end of the curve (theta = 0 or pi) when an arc reaches it.
// Not covered: a tip where the lines p(1) = 0 and p(-1) = 0 cross each other away from the curve. For the wall's
// loops p(1) = 0 is the line alpha = -gamma (P_beta vanishes at z = 1: a velocity estimator has no gain at DC), so
// that crossing has alpha <= 0 and is never the tip of a region in alpha > 0.
// Method: the curve sampled at `samples` equally spaced theta in (0, pi) and its two ends, the verdict on q at
// each; arc ends bisected in theta (60 halvings: theta to ~1e-17 of pi); the samples' local maxima of alpha inside an
// arc refined by Brent's minimiser (scalar_search.hpp) to ~1e-8 in theta, i.e. alpha to ~1e-15 relative at a smooth
// maximum. Arcs and maxima narrower than a sample spacing can be missed. Everything in long double.
// Cost: (samples + 2 + 60 per arc end + ~40 per maximum) x (evaluation of C, O(degree), and a Schur-Cohn verdict,
// O(degree^2)).
#pragma once

#include <cmath>
#include <complex>
#include <utility>
#include <vector>

#include "characteristic_polynomial.hpp"
#include "errors.hpp"
#include "scalar_search.hpp"
#include "schur_cohn.hpp"

namespace hapticopt {

/// A point of the D-decomposition curve where alpha is locally largest on the closure of a stable set.
struct RegionTipCandidate {
    enum class Kind { smooth_maximum, arc_end, curve_end };
    double alpha = 0;
    double beta = 0;
    double theta = 0;  ///< the crossing frequency (radians per period)
    Kind kind = Kind::smooth_maximum;
};

namespace detail {

/// The D-decomposition curve of one affine polynomial, in long double (region_tip.hpp's header comment).
class DDecompositionCurve {
  public:
    using LD = long double;
    explicit DDecompositionCurve(const AffineCharacteristicPolynomial<double>& p) {
        base_ = p.base.cast<LD>();
        alpha_ = p.alpha.cast<LD>();
        beta_ = p.beta.cast<LD>();
    }

    /// C(theta); theta = 0 and pi give the curve's ends (p(+-1) = p'(+-1) = 0). Non-finite where the 2 x 2 system
    /// is singular.
    std::pair<LD, LD> point(LD theta) const {
        const LD pi = 3.141592653589793238462643383279502884L;
        LD c0r, c0i, car, cai, cbr, cbi;
        if (theta <= 0 || theta >= pi) {
            const LD z = theta <= 0 ? LD(1) : LD(-1);
            value_and_derivative(base_, z, c0r, c0i);
            value_and_derivative(alpha_, z, car, cai);
            value_and_derivative(beta_, z, cbr, cbi);
        } else {
            const std::complex<LD> z = std::polar(LD(1), theta);
            const std::complex<LD> c0 = horner(base_, z), ca = horner(alpha_, z), cb = horner(beta_, z);
            c0r = c0.real();
            c0i = c0.imag();
            car = ca.real();
            cai = ca.imag();
            cbr = cb.real();
            cbi = cb.imag();
        }
        const LD det = car * cbi - cai * cbr;
        return {(c0i * cbr - c0r * cbi) / det, (c0r * cai - c0i * car) / det};
    }

    /// True when the roots of p at C(theta) other than e^{+-i theta} are all strictly inside the unit circle.
    bool on_stable_closure(LD theta) const {
        const std::pair<LD, LD> g = point(theta);
        if (!std::isfinite(static_cast<double>(g.first)) || !std::isfinite(static_cast<double>(g.second))) {
            return false;
        }
        const Eigen::Matrix<LD, Eigen::Dynamic, 1> p = base_ + g.first * alpha_ + g.second * beta_;
        const Eigen::Index n = p.size() - 1;
        if (n < 2) return false;
        const LD c = std::cos(theta);
        // p = (z^2 - 2 c z + 1) q + remainder, from the top: q_{k-2} = p_k + 2 c q_{k-1} - q_k.
        Eigen::Matrix<LD, Eigen::Dynamic, 1> q = Eigen::Matrix<LD, Eigen::Dynamic, 1>::Zero(n - 1);
        for (Eigen::Index k = n; k >= 2; --k) {
            const LD above = k - 1 <= n - 2 ? q(k - 1) : LD(0);
            const LD above2 = k <= n - 2 ? q(k) : LD(0);
            q(k - 2) = p(k) + 2 * c * above - above2;
        }
        if (q.size() == 1) return q(0) != 0;
        return schur_cohn<LD>(q).stable;
    }

  private:
    static std::complex<LD> horner(const Eigen::Matrix<LD, Eigen::Dynamic, 1>& c, std::complex<LD> z) {
        std::complex<LD> v = 0;
        for (Eigen::Index k = c.size() - 1; k >= 0; --k) v = v * z + c(k);
        return v;
    }
    /// p(z) and p'(z) at z = +-1: the real and (divided by sin theta, in the limit) imaginary parts of p(e^{i theta}).
    static void value_and_derivative(const Eigen::Matrix<LD, Eigen::Dynamic, 1>& c, LD z, LD& value, LD& derivative) {
        value = 0;
        derivative = 0;
        for (Eigen::Index k = c.size() - 1; k >= 0; --k) {
            derivative = derivative * z + value;
            value = value * z + c(k);
        }
        derivative *= z;  // Im p(e^{i theta}) / theta -> z p'(z) at z = +-1; the sign is common to both rows
    }

    Eigen::Matrix<LD, Eigen::Dynamic, 1> base_, alpha_, beta_;
};

}  // namespace detail

/// The tip candidates of every stable set of p's gain plane (header comment), unsorted; empty when the curve has no
/// arc. Throws InvalidParameter naming `samples` unless 8 <= samples <= 10^6.
inline std::vector<RegionTipCandidate> region_tip_candidates(const AffineCharacteristicPolynomial<double>& p,
                                                             int samples) {
    using LD = long double;
    const LD pi = 3.141592653589793238462643383279502884L;
    const detail::DDecompositionCurve curve(p);
    std::vector<RegionTipCandidate> out;
    detail::require_in_range("hapticopt::region_tip_candidates", "samples", samples, 8, false, 1e6,
                             "8 <= samples <= 10^6");
    std::vector<LD> theta(static_cast<std::size_t>(samples) + 2);
    std::vector<char> arc(theta.size());
    std::vector<LD> alpha(theta.size());
    for (std::size_t k = 0; k < theta.size(); ++k) {
        theta[k] = pi * LD(k) / LD(samples + 1);
        arc[k] = curve.on_stable_closure(theta[k]);
        alpha[k] = curve.point(theta[k]).first;
    }
    auto add = [&](LD t, RegionTipCandidate::Kind kind) {
        const std::pair<LD, LD> g = curve.point(t);
        if (!std::isfinite(static_cast<double>(g.first)) || !std::isfinite(static_cast<double>(g.second))) return;
        out.push_back({static_cast<double>(g.first), static_cast<double>(g.second), static_cast<double>(t), kind});
    };
    const std::size_t last = theta.size() - 1;
    if (arc[0]) add(0, RegionTipCandidate::Kind::curve_end);
    if (arc[last]) add(pi, RegionTipCandidate::Kind::curve_end);
    for (std::size_t k = 0; k < last; ++k) {
        if (arc[k] == arc[k + 1]) continue;
        LD inside = arc[k] ? theta[k] : theta[k + 1], outside = arc[k] ? theta[k + 1] : theta[k];
        for (int i = 0; i < 60; ++i) {
            const LD mid = (inside + outside) / 2;
            (curve.on_stable_closure(mid) ? inside : outside) = mid;
        }
        add(inside, RegionTipCandidate::Kind::arc_end);
    }
    for (std::size_t k = 1; k < last; ++k) {
        if (!arc[k] || !(alpha[k] >= alpha[k - 1] && alpha[k] >= alpha[k + 1])) continue;
        const detail::ScalarMinimum m =
            detail::minimize_scalar([&](double t) { return -static_cast<double>(curve.point(t).first); },
                                    static_cast<double>(theta[k - 1]), static_cast<double>(theta[k + 1]), 1e-15);
        if (curve.on_stable_closure(m.x)) add(m.x, RegionTipCandidate::Kind::smooth_maximum);
    }
    return out;
}

}  // namespace hapticopt
