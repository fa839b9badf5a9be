// SPDX-License-Identifier: Apache-2.0
// Stability of fixed physical gains over a box of plants: every arm (gamma_H, delta_H) in [0, gamma_max] x
// [0, delta_max] (per unit mass, ArmAlongRay::per_mass), every mass scale s in [s_lo, s_hi] and every total delay d in
// [d_lo, d_hi] periods, whole and fractional. A certified verdict, not a sampled one. Beyond Hulin et al. 2011.
//
// The family. Write d = n + phi (phi in [0, 1] within one whole n) and A = [[0, 1, 0], [-gamma, -delta, -1], [0, 0, 0]]
// (sampled_plant.hpp), gamma = gamma_0 + gamma_H, delta = delta_0 + delta_H. With E_a = exp(A phi), E_b = exp(A (1 -
// phi)) the loop's characteristic polynomial (characteristic_polynomial.hpp, two segments; phi = 0 adds a root at 0)
// with the velocity estimator (estimator_stability.hpp: At, Bt) is
//
//   p(z) = At(z) z^(n+2) (z^2 + d_1 z + d_0) + s q(z) K(z),   q(z) = q_0 + q_1 z + q_2 z^2,
//   K(z) = z (alpha At(z) + beta Bt(z))   (the backward difference: At = 1, K = (alpha + beta) z - beta),
//
// affine in the plant's five discrete coefficients c = (d_1, d_0, q_0, q_1, q_2) (d from E_b E_a = exp(A), q from
// E_a, E_b as characteristic_polynomial.hpp writes them), monic of one degree for every plant of the box.
//
// Enclosure. On a sub-box X of (gamma_H, delta_H, phi) the coefficients are enclosed in intervals [c_lo, c_hi] by
// interval arithmetic on the exponentials: exp(M) of the interval matrix M = A t by scaling (M / 2^j, |M / 2^j|_inf
// <= 1/2), the Taylor series to degree 20 in Horner form with its remainder |R| <= 2 mu^21 / 21! (mu <= 1/2 the
// scaled norm) added to every entry, and j squarings; the result is widened by kArmBoxRounding (64 (20 + 2^j) eps
// times the largest entry) for the rounding of the operations. With c_X the coefficients at the centre of X and
// r_i = max(c_hi,i - c_X,i, c_X,i - c_lo,i), every plant of X with every s satisfies at z = e^{i theta}
//
//   |p(z) - p_X(z; s)| <= G(theta) = |At(z)| (r_d1 + r_d0) + s_hi |K(z)| (r_q0 + r_q1 + r_q2),
//
// p_X(z; s) = P_X(z) + s Q_X(z) the centre's polynomial.
//
// Theorem used (zero exclusion; e.g. Barmish, New Tools for Robustness of Linear Systems, 1994, ch. 7): the roots
// depend continuously on the plant and s, the degree is constant (monic), and the pieces of whole delay n and n + 1
// join with the same roots outside the circle (phi = 1 of n is z^0 p_{n+1}, phi = 0 of n + 1 is z p_{n+1}); so the
// loop is stable on the whole box iff it is stable at one plant and p(e^{i theta}) != 0 for every theta and plant.
// The one plant: the exact Schur-Cohn verdict at the first sub-box's centre with s_lo (MassScalingTest::stable).
// The exclusion on X: H(theta) = min_{s in [s_lo, s_hi]} |P_X + s Q_X| - G(theta) > rounding for every theta in
// [0, pi] (real coefficients), the min over s closed-form, theta cell by cell (from 128 cells): on a cell of width h,
// H >= (H_1 + H_2) / 2 - L h / 2 with L the smaller, over the two ends, of a bound of |dH/dtheta| over the cell: |P_X'|
// + s_hi |Q_X'| plus the derivative of G's products, each factor |f| or |f'| bounded over the cell by its value at the
// end plus h sum k |f_k| or h sum k^2 |f_k| (|d/dtheta f(e^{i theta})| = |f'(z)|, |d|z - 1|/dtheta| <= 1); a failing
// cell is halved down to kArmBoxMinCell (at most 20000 halvings). Horner's rounding 4 (N + 1) eps sum |c_k| is added
// to the threshold.
//
// Before the boxes, and for every sub-box that fails, the plants at the box's corners with s_lo and s_hi are judged by
// Schur-Cohn (an unstable one confirmed by the library's exact verdict: the failing plant). A sub-box that fails at
// depths 0, kArmBoxExactEvery, ... is also judged exactly along the mass at its centre (MassScalingTest::over, the
// crossings of the unit circle along s: exact): an unstable centre is the failing plant (stable = false,
// proven_unstable), else the box is halved along the axis whose half-width moves G most at the theta where the
// exclusion failed (one-sided changes of c at the centre, double exponentials), and its halves are judged. More than
// kArmBoxMaxBoxes sub-boxes refuse conservatively (stable = false, proven_unstable false: no proof either way; the
// failing plant named is the last box's centre).
//
// Gain segments (segment_over; GainSegment of mass_scaling_stability.hpp): with the gains K(z; u) = K_0(z) + u K_1(z)
// for u in [u_lo, u_hi] (u >= 0) in place of s K(z), the centre's polynomial is (P_X + q_X K_0) + u q_X K_1 and
// max(|K(z; u_lo)|, |K(z; u_hi)|) (|K| is convex in u) takes the place of s_hi |K(z)| in G and in its slope; the rest
// is unchanged (the ray is K_0 = 0, u = s). The exact check along the centre is MassScalingTest::segment_over.
//
// Where exact, where certified: exact along the mass at each box centre; certified (a bound, never a sample) over the
// arm, the fractional delay and between the centres. Accuracy: the bound is strict and the enclosures rigorous up to
// the stated rounding allowance; a box whose roots pass within that rounding of the circle may be refused although
// stable, never the converse. Cost: docs/benchmarks.md, "Plant set" (tests/benchmarks/plant_set_benchmarks.cpp).
// Not for the real-time loop (allocates).
#pragma once

#include <Eigen/Core>
#include <algorithm>
#include <array>
#include <cmath>
#include <complex>
#include <limits>
#include <utility>
#include <vector>

#include "config.hpp"
#include "errors.hpp"
#include "estimator_stability.hpp"
#include "estimator_types.hpp"
#include "exponential_integrals.hpp"
#include "mass_scaling_stability.hpp"
#include "parameters.hpp"
#include "schur_cohn.hpp"

namespace hapticopt {

/// Stability over an arm box times a scale interval times a delay interval.
struct ArmBoxStability {
    bool stable = false;
    bool proven_unstable = false;  ///< the failing plant is unstable (exact verdict); false: refused without a proof
    double failing_scale = 0;      ///< when not stable: the plant's mass scale s ...
    double failing_gamma = 0;      ///< ... its arm gamma_H = k_H T^2 / m, delta_H = b_H T / m (per unit mass) ...
    double failing_delta = 0;
    double failing_delay = 0;  ///< ... and its total delay, periods
    int boxes = 0;             ///< sub-boxes judged
};

/// Sub-boxes judged at most per verdict; the narrowest theta cell.
inline constexpr int kArmBoxMaxBoxes = 4096;
inline constexpr double kArmBoxMinCell = 1e-9;
/// A failing sub-box is judged exactly along the mass at its centre at depths 0, kArmBoxExactEvery, ... (between:
/// halved without it; the exact verdict costs a crossing computation, O(N^3)).
inline constexpr int kArmBoxExactEvery = 3;

namespace detail {

/// A closed interval of reals; arithmetic encloses every result of its operands (up to rounding: the caller widens).
struct Interval {
    double lo = 0, hi = 0;
    Interval() = default;
    Interval(double v) : lo(v), hi(v) {}  // NOLINT: a point is an interval
    Interval(double l, double h) : lo(l), hi(h) {}
    double magnitude() const { return std::max(std::abs(lo), std::abs(hi)); }
};
inline Interval operator+(Interval a, Interval b) { return {a.lo + b.lo, a.hi + b.hi}; }
inline Interval operator-(Interval a, Interval b) { return {a.lo - b.hi, a.hi - b.lo}; }
inline Interval operator-(Interval a) { return {-a.hi, -a.lo}; }
inline Interval operator*(Interval a, Interval b) {
    const double p[4] = {a.lo * b.lo, a.lo * b.hi, a.hi * b.lo, a.hi * b.hi};
    return {*std::min_element(p, p + 4), *std::max_element(p, p + 4)};
}
inline Interval widened(Interval a, double w) { return {a.lo - w, a.hi + w}; }

using IntervalMatrix3 = std::array<std::array<Interval, 3>, 3>;

inline IntervalMatrix3 interval_product(const IntervalMatrix3& a, const IntervalMatrix3& b) {
    IntervalMatrix3 c{};
    for (std::size_t i = 0; i < 3; ++i) {
        for (std::size_t j = 0; j < 3; ++j) {
            Interval s(0.0);
            for (std::size_t k = 0; k < 3; ++k) s = s + a[i][k] * b[k][j];
            c[i][j] = s;
        }
    }
    return c;
}

/// An enclosure of exp(A t) for every gamma, delta, t of the intervals (header comment): scaling, the Taylor series
/// of degree 20 with its remainder, squaring, widened for rounding.
inline IntervalMatrix3 interval_exponential(Interval gamma, Interval delta, Interval t) {
    IntervalMatrix3 m{};
    for (auto& row : m) row.fill(Interval(0.0));
    m[0][1] = t;
    m[1][0] = -(gamma * t);
    m[1][1] = -(delta * t);
    m[1][2] = -t;
    double norm = 0;
    for (const auto& row : m) norm = std::max(norm, row[0].magnitude() + row[1].magnitude() + row[2].magnitude());
    int squarings = 0;
    if (norm > 0.5) squarings = static_cast<int>(std::ceil(std::log2(norm / 0.5)));
    const double scale = std::ldexp(1.0, -squarings);
    for (auto& row : m) {
        for (auto& e : row) e = Interval(e.lo * scale, e.hi * scale);
    }
    const double mu = norm * scale;
    constexpr int kDegree = 20;
    // Horner: I + M (I + M/2 (I + ... (I + M/20))).
    IntervalMatrix3 result{};
    for (std::size_t i = 0; i < 3; ++i) {
        for (std::size_t j = 0; j < 3; ++j) result[i][j] = Interval(i == j ? 1.0 : 0.0);
    }
    for (int k = kDegree; k >= 1; --k) {
        IntervalMatrix3 next = interval_product(m, result);
        for (std::size_t i = 0; i < 3; ++i) {
            for (std::size_t j = 0; j < 3; ++j) {
                next[i][j] = Interval(next[i][j].lo / k, next[i][j].hi / k) + Interval(i == j ? 1.0 : 0.0);
            }
        }
        result = next;
    }
    double remainder = 2.0;  // 2 mu^21 / 21!, mu <= 1/2: the series' tail in the infinity norm bounds every entry
    for (int k = 1; k <= kDegree + 1; ++k) remainder *= mu / k;
    for (auto& row : result) {
        for (auto& e : row) e = widened(e, remainder);
    }
    for (int i = 0; i < squarings; ++i) result = interval_product(result, result);
    double largest = 0;
    for (const auto& row : result) {
        for (const auto& e : row) largest = std::max(largest, e.magnitude());
    }
    const double rounding =
        64.0 * (kDegree + std::ldexp(1.0, squarings)) * std::numeric_limits<double>::epsilon() * std::max(largest, 1.0);
    for (auto& row : result) {
        for (auto& e : row) e = widened(e, rounding);
    }
    return result;
}

/// The plant's discrete coefficients about z = 1 (header comment), c = (e_0, e_1, f_0, f_1, f_2):
/// D(z) = (z - 1)^2 + e_1 (z - 1) + e_0 and q(z) = f_0 + f_1 (z - 1) + f_2 (z - 1)^2, from W = exp(A) and the
/// segments' E_a = exp(A phi), E_b = exp(A (1 - phi)) (Scalar double or Interval; entries read (i, j) through the
/// getters). Written so that each is one expression of the entries without cancellation: e_0 = det(I - W) (small, with
/// gamma), e_1 = tr(I - W), f_0 = q(1) = (1 - W_11) G_0 + W_01 G_1 with G = -W_(0..1, 2) the whole period's response
/// (independent of phi), f_1 = q'(1) = G_0 + (1 - W_11) gb_0 + W_01 gb_1, f_2 = gb_0, gb = -E_b,(0..1, 2).
template <typename Scalar, typename Get>
std::array<Scalar, 5> arm_plant_coefficients(Get whole, Get /*ea*/, Get eb) {
    const Scalar one(1.0);
    const Scalar u00 = one - whole(0, 0), u11 = one - whole(1, 1);
    const Scalar e0 = u00 * u11 - whole(0, 1) * whole(1, 0);
    const Scalar e1 = u00 + u11;
    const Scalar g0 = -whole(0, 2), g1 = -whole(1, 2);
    const Scalar gb0 = -eb(0, 2), gb1 = -eb(1, 2);
    const Scalar f0 = u11 * g0 + whole(0, 1) * g1;
    const Scalar f1 = g0 + u11 * gb0 + whole(0, 1) * gb1;
    return {e0, e1, f0, f1, gb0};
}

inline std::complex<double> horner(const Eigen::VectorXd& c, std::complex<double> z) {
    std::complex<double> v = 0;
    for (Eigen::Index k = c.size() - 1; k >= 0; --k) v = v * z + c(k);
    return v;
}

inline std::complex<double> horner_derivative(const Eigen::VectorXd& c, std::complex<double> z) {
    std::complex<double> v = 0;
    for (Eigen::Index k = c.size() - 1; k >= 1; --k) v = v * z + static_cast<double>(k) * c(k);
    return v;
}

inline double weighted_sum(const Eigen::VectorXd& c, int power) {
    double s = 0;
    for (Eigen::Index k = 0; k < c.size(); ++k) s += std::pow(static_cast<double>(k), power) * std::abs(c(k));
    return s;
}

}  // namespace detail

/// The certified verdict over the box (header comment) for one plant (gamma_0, delta_0 per unit mass), velocity
/// estimator, arm box and delay interval.
class ArmBoxTest {
  public:
    /// plant.gamma, plant.delta: the device's own per-mass stiffness and damping (0 for the free mass); plant.delay
    /// ignored: the delays are [d_lo, d_hi] periods (0 <= d_lo <= d_hi <= d_lo + 64, d_hi <= 1000). The arm box
    /// [0, gamma_max] x [0, delta_max] (0 <= gamma_max <= 10, 0 <= delta_max <= 100). Throws InvalidParameter naming
    /// the parameter.
    HAPTICOPT_DEFERRED
    ArmBoxTest(const NormalizedPlant& plant, const VelocityEstimator& estimator, double gamma_max, double delta_max,
               double d_lo, double d_hi)
        : plant_(plant), estimator_(estimator), gamma_max_(gamma_max), delta_max_(delta_max), d_lo_(d_lo), d_hi_(d_hi) {
        const char* fn = "hapticopt::ArmBoxTest";
        validate(plant, fn);
        validate(estimator, fn);
        if (!(gamma_max >= 0 && gamma_max <= 10)) throw InvalidParameter(fn, "gamma_max", gamma_max, "0 .. 10");
        if (!(delta_max >= 0 && delta_max <= 100)) throw InvalidParameter(fn, "delta_max", delta_max, "0 .. 100");
        if (!(d_lo >= 0 && d_lo <= d_hi && d_hi <= d_lo + 64 && d_hi <= 1000)) {
            throw InvalidParameter(fn, "delay interval", d_lo, "0 <= d_lo <= d_hi <= d_lo + 64, d_hi <= 1000 periods");
        }
        // At and K's two parts: the estimator's transfer written as estimator_characteristic_polynomial writes it.
        AffineCharacteristicPolynomial<double> unit;
        unit.base = unit.alpha = unit.beta = Eigen::VectorXd::Ones(1);
        if (estimator.kind == VelocityEstimatorKind::backward) {
            at_ = Eigen::VectorXd::Ones(1);
            k_alpha_ = Eigen::Vector2d(0, 1);  // z
            k_beta_ = Eigen::Vector2d(-1, 1);  // z - 1
        } else {
            const AffineCharacteristicPolynomial<double> e = estimator_characteristic_polynomial(unit, estimator);
            at_ = e.base;
            k_alpha_ = Eigen::VectorXd::Zero(e.base.size() + 1);
            k_alpha_.tail(e.base.size()) = e.base;  // z At
            k_beta_ = Eigen::VectorXd::Zero(e.beta.size() + 1);
            k_beta_.tail(e.beta.size()) = e.beta;  // z Bt
        }
    }

    /// Stability of s (alpha, beta) for every s in [s_lo, s_hi] (0 < s_lo <= s_hi, finite), every arm of the box and
    /// every delay of the interval. max_boxes (>= 1) bounds the subdivision: beyond it the verdict is "not proven"
    /// (stable false, proven_unstable false), so a smaller budget only refuses more, never accepts more.
    HAPTICOPT_DEFERRED ArmBoxStability over(double alpha, double beta, double s_lo, double s_hi,
                                            int max_boxes = kArmBoxMaxBoxes) const {
        if (!(s_lo > 0 && s_lo <= s_hi && std::isfinite(s_hi))) {
            throw InvalidParameter("hapticopt::ArmBoxTest::over", "scale interval", s_lo, "0 < s_lo <= s_hi, finite");
        }
        return segment_over(GainSegment::ray(alpha, beta, s_lo, s_hi), max_boxes);
    }

    /// Stability of every gain pair of the segment (mass_scaling_stability.hpp: (alpha_0 + u alpha_1, beta_0 + u
    /// beta_1), 0 <= u_lo <= u_hi, finite) with every arm of the box and every delay of the interval: the verdict above
    /// with s (alpha, beta) replaced by the segment's gains (header comment: P_X + s Q_X becomes (P_X + q K_0) + u q
    /// K_1, and s_hi |K| in G the larger |K| of the segment's ends). failing_scale: the u it fails at.
    HAPTICOPT_DEFERRED ArmBoxStability segment_over(const GainSegment& g, int max_boxes = kArmBoxMaxBoxes) const {
        if (!(g.u_lo >= 0 && g.u_lo <= g.u_hi && std::isfinite(g.u_hi))) {
            throw InvalidParameter("hapticopt::ArmBoxTest::segment_over", "u interval", g.u_lo,
                                   "0 <= u_lo <= u_hi, finite");
        }
        if (!(std::isfinite(g.alpha_0) && std::isfinite(g.beta_0) && std::isfinite(g.alpha_1) &&
              std::isfinite(g.beta_1))) {
            throw InvalidParameter("hapticopt::ArmBoxTest::segment_over", "gains", g.alpha_0, "finite");
        }
        ArmBoxStability r;
        const Gains k{gain_polynomial(g.alpha_0, g.beta_0), gain_polynomial(g.alpha_1, g.beta_1), g.u_lo, g.u_hi};
        // The boxes: one per whole delay n, phi in [max(d_lo - n, 0), min(d_hi - n, 1)].
        std::vector<Box> stack;
        const int n_first = static_cast<int>(std::floor(d_lo_));
        for (int n = n_first; n <= static_cast<int>(std::floor(d_hi_)); ++n) {
            const double lo = std::max(d_lo_ - n, 0.0), hi = std::min(d_hi_ - n, 1.0);
            if (n > n_first && hi == 0.0) continue;  // d_hi = n: the previous piece's phi = 1
            stack.push_back(Box{n, 0, {0.0, gamma_max_}, {0.0, delta_max_}, {lo, hi}});
        }
        // The one plant judged exactly: the first box's centre at s_lo; the boxes' corners first (a plant that fails
        // is most often there).
        {
            const Box& b = stack.front();
            const MassScalingTest centre(centre_plant(b), estimator_, ArmAlongRay::per_mass);
            if (!centre.stable(g.alpha(g.u_lo), g.beta(g.u_lo))) return failing(r, b, g.u_lo, true);
        }
        for (const Box& b : stack) {
            if (unstable_corner(b, k, g, r)) return r;
        }
        while (!stack.empty()) {
            const Box b = stack.back();
            stack.pop_back();
            ++r.boxes;
            const Centre c = centre(b);
            double theta = 0;
            if (excludes_zero(b, c, k, theta)) continue;
            if (b.depth > 0 && unstable_corner(b, k, g, r)) return r;
            if (b.depth % kArmBoxExactEvery == 0) {
                const MassScalingTest exact(centre_plant(b), estimator_, ArmAlongRay::per_mass);
                const GainRayStability ray = exact.segment_over(g);
                if (!ray.stable) return failing(r, b, ray.failing_scale, true);
            }
            if (r.boxes + static_cast<int>(stack.size()) + 2 > std::max(max_boxes, 1))
                return failing(r, b, g.u_lo, false);
            const int axis = split_axis(b, c, k, theta);
            Box lo = b, hi = b;
            Interval1& l = lo.axis(axis);
            Interval1& h = hi.axis(axis);
            const double mid = 0.5 * (l.lo + l.hi);
            l.hi = mid;
            h.lo = mid;
            lo.depth = hi.depth = b.depth + 1;
            stack.push_back(hi);
            stack.push_back(lo);
        }
        r.stable = true;
        return r;
    }

    /// The enclosure of the plant's coefficients (d_1, d_0, q_0, q_1, q_2) over gamma_H, delta_H, phi in the given
    /// intervals with whole delay n ignored (it does not enter them): for the tests.
    std::array<detail::Interval, 5> coefficient_enclosure(detail::Interval gamma_h, detail::Interval delta_h,
                                                          detail::Interval phi) const {
        const detail::Interval g = gamma_h + detail::Interval(plant_.gamma),
                               d = delta_h + detail::Interval(plant_.delta);
        const detail::IntervalMatrix3 w = detail::interval_exponential(g, d, detail::Interval(1.0));
        const detail::IntervalMatrix3 a = detail::interval_exponential(g, d, phi);
        const detail::IntervalMatrix3 b = detail::interval_exponential(g, d, detail::Interval(1.0) - phi);
        auto get = [](const detail::IntervalMatrix3& m) {
            return [&m](int i, int j) { return m[static_cast<std::size_t>(i)][static_cast<std::size_t>(j)]; };
        };
        return detail::arm_plant_coefficients<detail::Interval>(get(w), get(a), get(b));
    }

    /// The same coefficients at one point (double exponentials, exponential_integrals.hpp).
    std::array<double, 5> coefficients(double gamma_h, double delta_h, double phi) const {
        NormalizedPlant p = plant_;
        p.gamma += gamma_h;
        p.delta += delta_h;
        const Matrix3<double> a = plant_augmented_matrix<double>(p);
        const Matrix3<double> w = exponential<double>(a, 1.0), ea = exponential<double>(a, phi),
                              eb = exponential<double>(a, 1.0 - phi);
        auto get = [](const Matrix3<double>& m) { return [&m](int i, int j) { return m(i, j); }; };
        return detail::arm_plant_coefficients<double>(get(w), get(ea), get(eb));
    }

    /// The loop's characteristic polynomial at one plant (ascending; monic): At z^(n+2) D + s q K (header comment).
    Eigen::VectorXd polynomial(double gamma_h, double delta_h, int n, double phi, double s, double alpha,
                               double beta) const {
        const std::array<double, 5> c = coefficients(gamma_h, delta_h, phi);
        Eigen::VectorXd p, q;
        base_and_gain(c, n, gain_polynomial(alpha, beta), p, q);
        return p + s * q;
    }

  private:
    using Interval = detail::Interval;
    struct Interval1 {
        double lo, hi;
        double mid() const { return 0.5 * (lo + hi); }
    };
    struct Box {
        int n;
        int depth;
        Interval1 gamma, delta, phi;
        Interval1& axis(int i) { return i == 0 ? gamma : (i == 1 ? delta : phi); }
    };
    struct Centre {
        std::array<double, 5> c;
        std::array<double, 5> radius;
    };
    // The segment's gain polynomials: K(z; u) = K_0(z) + u K_1(z), u in [u_lo, u_hi] (header comment), and K at the
    // segment's ends. |K(z; u)|, |K'(z; u)| and sum_k k^j |K_k(u)| are convex in u, so their largest values over the
    // segment are at its ends.
    struct Gains {
        Eigen::VectorXd k0, k1, at_lo, at_hi;
        double u_lo, u_hi;
        Gains(Eigen::VectorXd k_0, Eigen::VectorXd k_1, double lo, double hi)
            : k0(std::move(k_0)), k1(std::move(k_1)), at_lo(k0 + lo * k1), at_hi(k0 + hi * k1), u_lo(lo), u_hi(hi) {}
        double bound(std::complex<double> z) const {
            return std::max(std::abs(detail::horner(at_lo, z)), std::abs(detail::horner(at_hi, z)));
        }
        double derivative_bound(std::complex<double> z) const {
            return std::max(std::abs(detail::horner_derivative(at_lo, z)),
                            std::abs(detail::horner_derivative(at_hi, z)));
        }
        double weighted_bound(int power) const {
            return std::max(detail::weighted_sum(at_lo, power), detail::weighted_sum(at_hi, power));
        }
    };

    Eigen::VectorXd gain_polynomial(double alpha, double beta) const {
        const Eigen::Index size = std::max(k_alpha_.size(), k_beta_.size());
        Eigen::VectorXd k = Eigen::VectorXd::Zero(size);
        k.head(k_alpha_.size()) += alpha * k_alpha_;
        k.head(k_beta_.size()) += beta * k_beta_;
        return k;
    }

    // P = At z^(n+2) D(z), Q = q K (header comment), padded to one size.
    void base_and_gain(const std::array<double, 5>& c, int n, const Eigen::VectorXd& k, Eigen::VectorXd& p,
                       Eigen::VectorXd& q) const {
        const Eigen::Index size = at_.size() + n + 4;
        p = Eigen::VectorXd::Zero(size);
        q = Eigen::VectorXd::Zero(size);
        // (z - 1)^2 + e1 (z - 1) + e0 and f0 + f1 (z - 1) + f2 (z - 1)^2 in ascending powers.
        const double d[3] = {1.0 - c[1] + c[0], c[1] - 2.0, 1.0};
        const double qc[3] = {c[2] - c[3] + c[4], c[3] - 2.0 * c[4], c[4]};
        for (Eigen::Index i = 0; i < at_.size(); ++i) {
            for (int j = 0; j < 3; ++j) p(i + n + 2 + j) += at_(i) * d[j];
        }
        for (Eigen::Index i = 0; i < k.size(); ++i) {
            for (int j = 0; j < 3; ++j) q(i + j) += k(i) * qc[j];
        }
    }

    // The segment's P = At z^(n+2) D + q K_0 and Q = q K_1: p(z; u) = P + u Q.
    void segment_polynomials(const std::array<double, 5>& c, int n, const Gains& k, Eigen::VectorXd& p,
                             Eigen::VectorXd& q) const {
        Eigen::VectorXd p_plant, q_0;
        base_and_gain(c, n, k.k0, p_plant, q_0);
        base_and_gain(c, n, k.k1, p, q);
        p = p_plant + q_0;
    }

    NormalizedPlant centre_plant(const Box& b) const {
        NormalizedPlant p = plant_;
        p.gamma += b.gamma.mid();
        p.delta += b.delta.mid();
        p.delay = b.n + b.phi.mid();
        return p;
    }

    Centre centre(const Box& b) const {
        Centre c;
        c.c = coefficients(b.gamma.mid(), b.delta.mid(), b.phi.mid());
        const std::array<Interval, 5> e =
            coefficient_enclosure({b.gamma.lo, b.gamma.hi}, {b.delta.lo, b.delta.hi}, {b.phi.lo, b.phi.hi});
        for (std::size_t i = 0; i < 5; ++i) c.radius[i] = std::max(e[i].hi - c.c[i], c.c[i] - e[i].lo);
        return c;
    }

    // The axis whose half-width moves G(theta) most at the theta where the exclusion failed (one-sided changes of c
    // at the centre, double exponentials, weighted as G weighs the radii).
    int split_axis(const Box& b, const Centre& c, const Gains& k, double theta) const {
        const std::complex<double> z = std::polar(1.0, theta);
        const double a = std::abs(detail::horner(at_, z)), kk = k.bound(z), w = std::abs(z - 1.0);
        int best = 2;
        double largest = -1;
        for (int axis = 0; axis < 3; ++axis) {
            Box e = b;
            Interval1& side = e.axis(axis);
            if (!(side.hi > side.lo)) continue;
            const double step = 0.5 * (side.hi - side.lo);
            double g = b.gamma.mid(), d = b.delta.mid(), f = b.phi.mid();
            (axis == 0 ? g : (axis == 1 ? d : f)) += step;
            const std::array<double, 5> m = coefficients(g, d, f);
            std::array<double, 5> r{};
            for (std::size_t i = 0; i < 5; ++i) r[i] = std::abs(m[i] - c.c[i]);
            const double change = a * (r[0] + r[1] * w) + kk * (r[2] + w * (r[3] + w * r[4]));
            if (change > largest) {
                largest = change;
                best = axis;
            }
        }
        return best;
    }

    // Schur-Cohn at the box's corners with s_lo and s_hi; a corner it finds unstable is confirmed by the library's
    // exact verdict (MassScalingTest::stable: the long double refinement near the boundary) and is then the failing
    // plant (r filled, true).
    HAPTICOPT_DEFERRED bool unstable_corner(const Box& b, const Gains& k, const GainSegment& gains,
                                            ArmBoxStability& r) const {
        for (int corner = 0; corner < 8; ++corner) {
            const double g = (corner & 1) ? b.gamma.hi : b.gamma.lo, d = (corner & 2) ? b.delta.hi : b.delta.lo,
                         f = (corner & 4) ? b.phi.hi : b.phi.lo;
            if (((corner & 1) && b.gamma.hi == b.gamma.lo) || ((corner & 2) && b.delta.hi == b.delta.lo) ||
                ((corner & 4) && b.phi.hi == b.phi.lo))
                continue;  // the same corner again
            Eigen::VectorXd p, q;
            segment_polynomials(coefficients(g, d, f), b.n, k, p, q);
            for (const double s : {k.u_lo, k.u_hi}) {
                if (schur_cohn<double>(Eigen::VectorXd(p + s * q)).stable) continue;
                NormalizedPlant plant = plant_;
                plant.gamma += g;
                plant.delta += d;
                plant.delay = b.n + f;
                if (MassScalingTest(plant, estimator_, ArmAlongRay::per_mass).stable(gains.alpha(s), gains.beta(s)))
                    continue;
                r.stable = false;
                r.proven_unstable = true;
                r.failing_scale = s;
                r.failing_gamma = g;
                r.failing_delta = d;
                r.failing_delay = b.n + f;
                return true;
            }
        }
        return false;
    }

    ArmBoxStability& failing(ArmBoxStability& r, const Box& b, double s, bool proven) const {
        r.stable = false;
        r.proven_unstable = proven;
        r.failing_scale = s;
        r.failing_gamma = b.gamma.mid();
        r.failing_delta = b.delta.mid();
        r.failing_delay = b.n + b.phi.mid();
        return r;
    }

    // H(theta) > threshold on [0, pi] (header comment).
    HAPTICOPT_DEFERRED bool excludes_zero(const Box& b, const Centre& c, const Gains& k, double& failing_theta) const {
        const double s_lo = k.u_lo, s_hi = k.u_hi;
        Eigen::VectorXd p, q;
        segment_polynomials(c.c, b.n, k, p, q);
        const std::array<double, 5>& r = c.radius;
        const double eps = std::numeric_limits<double>::epsilon();
        const double threshold = 4.0 * static_cast<double>(p.size() + 1) * eps *
                                 (detail::weighted_sum(p, 0) + s_hi * detail::weighted_sum(q, 0));
        // Bounds over theta of |f| growth: |f(z(theta'))| <= |f(z)| + |theta' - theta| sum k |f_k|, and of |f'| with
        // sum k^2 |f_k|.
        const double p2 = detail::weighted_sum(p, 2);
        const double q2 = detail::weighted_sum(q, 2);
        const double a1 = detail::weighted_sum(at_, 1), a2 = detail::weighted_sum(at_, 2);
        const double k1 = k.weighted_bound(1), k2 = k.weighted_bound(2);
        struct Point {
            double h;                            // H(theta)
            double p_d, q_d, a, a_d, k, k_d, w;  // |P'|, |Q'|, |At|, |At'|, bounds of |K| and |K'|, |z - 1|
        };
        auto at = [&](double theta) {
            const std::complex<double> z = std::polar(1.0, theta);
            const std::complex<double> pz = detail::horner(p, z), qz = detail::horner(q, z);
            const double qq = std::norm(qz);
            double s = qq > 0 ? -(pz * std::conj(qz)).real() / qq : s_lo;
            s = std::clamp(s, s_lo, s_hi);
            Point v;
            v.a = std::abs(detail::horner(at_, z));
            v.k = k.bound(z);
            v.w = std::abs(z - 1.0);
            const double g = v.a * (r[0] + r[1] * v.w) + v.k * (r[2] + v.w * (r[3] + v.w * r[4]));
            v.h = std::abs(pz + s * qz) - g;
            v.p_d = std::abs(detail::horner_derivative(p, z));
            v.q_d = std::abs(detail::horner_derivative(q, z));
            v.a_d = std::abs(detail::horner_derivative(at_, z));
            v.k_d = k.derivative_bound(z);
            return v;
        };
        // The largest |dH/dtheta| within h of a point: min_s |P + s Q| moves by at most |P'| + s_hi |Q'|, G by the
        // derivative of its products (|d|z - 1|/dtheta| <= 1), each factor bounded over the cell from the point (|K|
        // and |K'| by their larger value at the segment's ends; s: the segment's u).
        auto slope = [&](const Point& v, double h) {
            const double pd = v.p_d + h * p2, qd = v.q_d + h * q2;
            const double a = v.a + h * a1, ad = v.a_d + h * a2, kk = v.k + h * k1, kd = v.k_d + h * k2;
            const double w = std::min(v.w + h, 2.0);
            const double g_d =
                ad * (r[0] + r[1] * w) + a * r[1] + kd * (r[2] + w * (r[3] + w * r[4])) + kk * (r[3] + 2.0 * w * r[4]);
            return pd + s_hi * qd + g_d;
        };
        constexpr int kCells = 128;
        const double pi = 3.14159265358979323846;
        struct Cell {
            double a, b;
            Point pa, pb;
        };
        std::vector<Cell> cells;
        Point prev = at(0.0);
        failing_theta = 0.0;
        if (!(prev.h > threshold)) return false;
        for (int i = 1; i <= kCells; ++i) {
            const double theta = pi * i / kCells;
            failing_theta = theta;
            const Point next = at(theta);
            if (!(next.h > threshold)) return false;
            cells.push_back(Cell{pi * (i - 1) / kCells, theta, prev, next});
            prev = next;
        }
        int evaluations = 0;
        while (!cells.empty()) {
            const Cell cell = cells.back();
            cells.pop_back();
            const double h = cell.b - cell.a;
            const double lipschitz = std::min(slope(cell.pa, h), slope(cell.pb, h));
            if ((cell.pa.h + cell.pb.h) / 2 - lipschitz * h / 2 > threshold) continue;
            const double mid = 0.5 * (cell.a + cell.b);
            failing_theta = mid;
            if (h < kArmBoxMinCell || ++evaluations > 20000) return false;
            const Point pm = at(mid);
            if (!(pm.h > threshold)) return false;
            cells.push_back(Cell{cell.a, mid, cell.pa, pm});
            cells.push_back(Cell{mid, cell.b, pm, cell.pb});
        }
        return true;
    }

    NormalizedPlant plant_;
    VelocityEstimator estimator_;
    double gamma_max_, delta_max_, d_lo_, d_hi_;
    Eigen::VectorXd at_, k_alpha_, k_beta_;
};

}  // namespace hapticopt
