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
// interval arithmetic on the exponentials (interval_exponential.hpp: scaling, the Taylor series of degree 20 with its
// remainder, squaring, a rounding allowance of 64 (20 + 2^j) eps times the largest entry). With c_X the coefficients
// at the centre of X and r_i = max(c_hi,i - c_X,i, c_X,i - c_lo,i), every plant of X with every s satisfies at
// z = e^{i theta}
//
//   |p(z) - p_X(z; s)| <= G(theta) = |At(z)| (r_d1 + r_d0) + s_hi |K(z)| (r_q0 + r_q1 + r_q2),
//
// p_X(z; s) = P_X(z) + s Q_X(z) the centre's polynomial: the radii's bound.
//
// Mean-value form. The radii's bound loses the correlation between the coefficients: where |p| is small, near z = 1
// for gains near zero (the first ticks of a ramp: the roots within ~beta of z = 1), G exceeds it for any sub-box
// wider than ~beta^2. On such a sub-box the coefficients are written c(x) = c(x_c) + J (x - x_c) + e, x = (gamma_H,
// delta_H, phi), with J the midpoints of enclosures of the gradient over X (interval_exponential.hpp: the block
// exponential for gamma and delta, -A E_b for phi, carried through the coefficients' expressions by DualInterval) and
// |e_i| <= E_i: the radius of c(x_c)'s thin enclosure plus sum_j rad(J_ij over X) r_j (the mean value theorem per
// coefficient). Since p is affine in c and in s, at z = e^{i theta} with s in [s_a, s_b] (s_c, s_r its middle and
// half-width),
//
//   p = p_c + tau Q_c + sum_j t_j (a_j + s_c b_j) + tau sum_j t_j b_j,   |tau| <= s_r, |t_j| <= 1,
//
// with one generator j per axis of positive width (J's column times r_j) and per coefficient remainder (E_i), each
// the polynomial dp/dc applied to it (a_j its part with K_0, b_j with K_1): the first three terms range over a
// zonotope of the complex plane whose distance from 0 is exact (zonotope_distance.hpp), the last over a disc of radius
// s_r sum_j |b_j(z)|. Its margin, distance less disc less rounding, is a lower bound of |p| over X and the s of the
// cell, and moves with theta by at most the sum of its polynomials' |f'| bounds (each largest at an end of s).
//
// Theorem used (zero exclusion; e.g. Barmish, New Tools for Robustness of Linear Systems, 1994, ch. 7): the roots
// depend continuously on the plant and s, the degree is constant (monic), and the pieces of whole delay n and n + 1
// join with the same roots outside the circle (phi = 1 of n is z^0 p_{n+1}, phi = 0 of n + 1 is z p_{n+1}); so the
// loop is stable on the whole box iff it is stable at one plant and p(e^{i theta}) != 0 for every theta and plant.
// The one plant: the exact Schur-Cohn verdict at the first sub-box's centre with s_lo (MassScalingTest::stable).
// The exclusion on X: H(theta) = min_{s in [s_a, s_b]} |P_X + s Q_X| - G(theta) > rounding for every theta in
// [0, pi] (real coefficients) and every s, the min over s closed-form, cell by cell in (theta, s) from 128 theta cells
// with the whole s range: on a cell of width h, H >= (H_1 + H_2) / 2 - L h / 2 with L the smaller, over the two ends,
// of a bound of |dH/dtheta| over the cell: max over the cell's ends of s of |P_X' + s Q_X'| (convex in s) plus the
// derivative of G's products, each factor |f| or |f'| bounded over the cell by its value at the end plus h sum k |f_k|
// or h sum k^2 |f_k| (|d/dtheta f(e^{i theta})| = |f'(z)|, |d|z - 1|/dtheta| <= 1). A cell with an end where H is not
// positive is judged by the mean-value margin instead (the same bound on the cell, with its own slope). A cell that
// fails is halved in s where an end is not positive or where |P_X' + s Q_X'| differs by more than a factor 2 between
// the ends of s (down to 1e-6 of the segment), else in theta, down to kArmBoxMinCell, at most kArmBoxMaxEvaluations
// times. Horner's rounding 4 (N + 1) eps sum |c_k| (over every polynomial evaluated) is added to the threshold.
//
// Before the boxes, and for every sub-box that fails, the plants at the box's corners with s_lo and s_hi are judged by
// Schur-Cohn (an unstable one confirmed by the library's exact verdict: the failing plant). A sub-box that fails at
// depths 0, kArmBoxExactEvery, ... is also judged exactly along the mass at its centre (MassScalingTest::over, the
// crossings of the unit circle along s: exact): an unstable centre is the failing plant (stable = false,
// proven_unstable), else the box is halved along the axis whose half-width moves G most at the theta where the
// exclusion failed (one-sided changes of c at the centre, double exponentials), and its halves are judged. A sub-box
// of one plant (no width on any axis) that fails is decided by that exact verdict alone. More than kArmBoxMaxBoxes
// sub-boxes refuse conservatively (stable = false, proven_unstable false: no proof either way; the failing plant named
// is the last box's centre).
//
// Gain segments (segment_over; GainSegment of mass_scaling_stability.hpp): with the gains K(z; u) = K_0(z) + u K_1(z)
// for u in [u_lo, u_hi] (u >= 0) in place of s K(z), the centre's polynomial is (P_X + q_X K_0) + u q_X K_1 and
// max(|K(z; u_a)|, |K(z; u_b)|) over the cell's u (|K| is convex in u) takes the place of s_hi |K(z)| in G and in its
// slope; the rest is unchanged (the ray is K_0 = 0, u = s). The exact check along the centre is
// MassScalingTest::segment_over.
//
// Where exact, where certified: exact along the mass at each box centre; certified (a bound, never a sample) over the
// arm, the fractional delay and between the centres. Accuracy: the bound is strict and the enclosures rigorous up to
// the stated rounding allowance; a box whose roots pass within that rounding of the circle may be refused although
// stable, never the converse. Tests: tests/beyond/test_arm_box_stability.cpp, test_arm_box_mean_value.cpp. Cost:
// docs/benchmarks.md, "Plant set" (tests/benchmarks/plant_set_benchmarks.cpp).
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
#include "interval_exponential.hpp"
#include "mass_scaling_stability.hpp"
#include "parameters.hpp"
#include "schur_cohn.hpp"
#include "zonotope_distance.hpp"

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
/// Cells of (theta, s) evaluated at most per sub-box's exclusion, and of them judged by the mean-value form (each
/// ~10 times the radii's cost): beyond, the exclusion fails and the sub-box is halved, as where its bound is not
/// positive.
inline constexpr int kArmBoxMaxEvaluations = 20000;
inline constexpr int kArmBoxMaxMeanValuePoints = 512;

namespace detail {

/// The plant's discrete coefficients about z = 1 (header comment), c = (e_0, e_1, f_0, f_1, f_2):
/// D(z) = (z - 1)^2 + e_1 (z - 1) + e_0 and q(z) = f_0 + f_1 (z - 1) + f_2 (z - 1)^2, from W = exp(A) and the
/// segments' E_a = exp(A phi), E_b = exp(A (1 - phi)) (Scalar double or Interval; entries read (i, j) through the
/// getters). Written so that each is one expression of the entries without cancellation: e_0 = det(I - W) (small, with
/// gamma), e_1 = tr(I - W), f_0 = q(1) = (1 - W_11) G_0 + W_01 G_1 with G = -W_(0..1, 2) the whole period's response
/// (independent of phi), f_1 = q'(1) = G_0 + (1 - W_11) gb_0 + W_01 gb_1, f_2 = gb_0, gb = -E_b,(0..1, 2).
template <typename Scalar, typename GetWhole, typename GetA, typename GetB>
std::array<Scalar, 5> arm_plant_coefficients(GetWhole whole, GetA /*ea*/, GetB eb) {
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

/// |z| as sqrt(re^2 + im^2) (within 2 ulp; the magnitudes here are far from overflow and underflow).
inline double magnitude(std::complex<double> z) { return std::sqrt(std::norm(z)); }

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
            const bool point = b.gamma.hi == b.gamma.lo && b.delta.hi == b.delta.lo && b.phi.hi == b.phi.lo;
            if (point || b.depth % kArmBoxExactEvery == 0) {
                const MassScalingTest exact(centre_plant(b), estimator_, ArmAlongRay::per_mass);
                const GainRayStability ray = exact.segment_over(g);
                if (!ray.stable) return failing(r, b, ray.failing_scale, true);
                if (point) continue;  // one plant: the exact verdict is the whole verdict
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
        const detail::IntervalMatrix3 b = detail::interval_exponential(g, d, detail::Interval(1.0) - phi);
        auto get = [](const detail::IntervalMatrix3& m) {
            return [&m](int i, int j) { return m[static_cast<std::size_t>(i)][static_cast<std::size_t>(j)]; };
        };
        return detail::arm_plant_coefficients<detail::Interval>(get(w), get(w), get(b));  // E_a does not enter
    }

    /// Enclosures of the same coefficients and of their partial derivatives along (gamma_H, delta_H, phi) over the
    /// intervals (interval_exponential.hpp: the block exponential for gamma and delta, -A E_b for phi).
    std::array<detail::DualInterval, 5> coefficient_gradient_enclosure(detail::Interval gamma_h,
                                                                       detail::Interval delta_h,
                                                                       detail::Interval phi) const {
        using detail::DualInterval;
        using detail::Interval;
        const Interval g = gamma_h + Interval(plant_.gamma), d = delta_h + Interval(plant_.delta);
        const Interval rest = Interval(1.0) - phi;
        const detail::IntervalMatrix3 w = detail::interval_exponential(g, d, Interval(1.0));
        const detail::IntervalMatrix3 eb = detail::interval_exponential(g, d, rest);
        const std::array<detail::IntervalMatrix3, 2> dw = detail::interval_exponential_derivatives(g, d, Interval(1.0));
        const std::array<detail::IntervalMatrix3, 2> deb = detail::interval_exponential_derivatives(g, d, rest);
        detail::IntervalMatrix3 deb_phi =
            detail::interval_product(detail::plant_interval_matrix(g, d, Interval(1.0)), eb);
        for (auto& row : deb_phi) {
            for (auto& e : row) e = -e;  // d exp(A (1 - phi)) / dphi = -A exp(A (1 - phi))
        }
        auto at = [](const detail::IntervalMatrix3& m, int i, int j) {
            return m[static_cast<std::size_t>(i)][static_cast<std::size_t>(j)];
        };
        auto whole = [&](int i, int j) {
            return DualInterval(at(w, i, j), {at(dw[0], i, j), at(dw[1], i, j), Interval(0.0)});
        };
        auto rest_segment = [&](int i, int j) {
            return DualInterval(at(eb, i, j), {at(deb[0], i, j), at(deb[1], i, j), at(deb_phi, i, j)});
        };
        return detail::arm_plant_coefficients<DualInterval>(whole, whole, rest_segment);
    }

    /// The mean-value form at theta on a sub-box (gamma_H, delta_H, phi in the intervals, whole delay n) for the
    /// segment's gains with u in [u_lo, u_hi] (header comment): margin, a lower bound of |p(e^{i theta})| over every
    /// plant of the box and every u (less the rounding allowances), and its slope bound within h of theta, slope +
    /// h growth. For the tests.
    struct CircleMargin {
        double margin, slope, growth;
    };
    CircleMargin mean_value_margin(detail::Interval gamma_h, detail::Interval delta_h, detail::Interval phi, int n,
                                   const GainSegment& g, double theta) const {
        const Box b{n, 0, {gamma_h.lo, gamma_h.hi}, {delta_h.lo, delta_h.hi}, {phi.lo, phi.hi}};
        const Gains k{gain_polynomial(g.alpha_0, g.beta_0), gain_polynomial(g.alpha_1, g.beta_1), g.u_lo, g.u_hi};
        CircleMargin m{};
        mean_value_form(b, k).fill(theta, g.u_lo, g.u_hi, m.margin, m.slope, m.growth);
        return m;
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
        double bound(std::complex<double> z) const { return bound(z, u_lo, u_hi); }
        // Over u in [lo, hi]: the larger of |K| (|K'|) at the two ends.
        double bound(std::complex<double> z, double lo, double hi) const {
            const std::complex<double> k_0 = detail::horner(k0, z), k_1 = detail::horner(k1, z);
            return std::max(detail::magnitude(k_0 + lo * k_1), detail::magnitude(k_0 + hi * k_1));
        }
        double derivative_bound(std::complex<double> z, double lo, double hi) const {
            const std::complex<double> k_0 = detail::horner_derivative(k0, z), k_1 = detail::horner_derivative(k1, z);
            return std::max(detail::magnitude(k_0 + lo * k_1), detail::magnitude(k_0 + hi * k_1));
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

    // The mean-value form over a sub-box (header comment): c(x) in cc + m (x - x_c) + [-e, e] for every x of the box.
    struct MeanValue {
        std::array<double, 5> cc{}, e{};
        std::array<std::array<double, 3>, 5> m{};
        std::array<double, 3> r{};  // the box's half-widths along gamma_H, delta_H, phi
    };
    MeanValue mean_value(const Box& b) const {
        MeanValue v;
        const double x[3] = {b.gamma.mid(), b.delta.mid(), b.phi.mid()};
        v.r = {0.5 * (b.gamma.hi - b.gamma.lo), 0.5 * (b.delta.hi - b.delta.lo), 0.5 * (b.phi.hi - b.phi.lo)};
        const std::array<Interval, 5> at_centre = coefficient_enclosure(x[0], x[1], x[2]);
        const std::array<detail::DualInterval, 5> over =
            coefficient_gradient_enclosure({b.gamma.lo, b.gamma.hi}, {b.delta.lo, b.delta.hi}, {b.phi.lo, b.phi.hi});
        for (std::size_t i = 0; i < 5; ++i) {
            v.cc[i] = at_centre[i].mid();
            v.e[i] = at_centre[i].radius();
            for (std::size_t j = 0; j < 3; ++j) {
                v.m[i][j] = over[i].d[j].mid();
                v.e[i] += over[i].d[j].radius() * v.r[j];
            }
        }
        return v;
    }

    // A polynomial affine in the segment's u: a0 + u a1, with sum k^2 |a0_k + u a1_k| bounded over the segment (its
    // larger value at the ends: convex in u) and sum |a0_k| + u_hi sum |a1_k| for the rounding allowance.
    struct AffinePolynomial {
        Eigen::VectorXd a0, a1;
        double w2 = 0, w2_a1 = 0, size = 0;
    };
    AffinePolynomial affine_polynomial(const std::array<double, 5>& dc, int n, const Gains& k) const {
        // At z^(n+2) (dc_0 + dc_1 (z - 1)) + K(z; u) (dc_2 + dc_3 (z - 1) + dc_4 (z - 1)^2): base_and_gain of dc less
        // its monic (z - 1)^2 part.
        static const std::array<double, 5> none{};
        Eigen::VectorXd p, q, monic, unused, q1;
        base_and_gain(dc, n, k.k0, p, q);
        base_and_gain(none, n, k.k0, monic, unused);
        base_and_gain(dc, n, k.k1, unused, q1);
        AffinePolynomial a;
        a.a0 = p - monic + q;
        a.a1 = q1;
        a.w2 = std::max(detail::weighted_sum(Eigen::VectorXd(a.a0 + k.u_lo * a.a1), 2),
                        detail::weighted_sum(Eigen::VectorXd(a.a0 + k.u_hi * a.a1), 2));
        a.w2_a1 = detail::weighted_sum(a.a1, 2);
        a.size = detail::weighted_sum(a.a0, 0) + k.u_hi * detail::weighted_sum(a.a1, 0);
        return a;
    }

    // The mean-value form's polynomials on one sub-box (header comment): the centre's P_m + s Q_m and the generators
    // (one per axis of positive width, one per coefficient remainder), each affine in s.
    struct MeanValueForm {
        bool built = false;
        Eigen::VectorXd pm, qm;
        double pm2 = 0, qm2 = 0, threshold = 0;
        std::vector<AffinePolynomial> gens;
        // At theta with s in [s_lo, s_hi] (u_c the middle, s_r the half-width): p = (P_m + u_c Q_m) + tau Q_m +
        // sum_k t_k (A0_k + u_c A1_k) + tau sum_k t_k A1_k, |tau| <= s_r, |t_k| <= 1: the zonotope of the first three
        // terms, the last in a disc. margin: its distance from 0 less the disc and the rounding; slope: the sum of its
        // polynomials' |f'| bounds at theta (each largest at an end of s), growth: that bound's growth per unit of h.
        void fill(double theta, double s_lo, double s_hi, double& margin, double& slope, double& growth) const {
            const double eps = std::numeric_limits<double>::epsilon();
            const std::complex<double> z = std::polar(1.0, theta);
            const double u_c = 0.5 * (s_lo + s_hi), s_r = 0.5 * (s_hi - s_lo);
            std::array<std::complex<double>, kZonotopeMaxGenerators> g{};
            std::size_t m = 0;
            const std::complex<double> qz = detail::horner(qm, z);
            const std::complex<double> centre = detail::horner(pm, z) + u_c * qz;
            g[m++] = s_r * qz;
            const std::complex<double> pd = detail::horner_derivative(pm, z), qd = detail::horner_derivative(qm, z);
            slope = std::max(detail::magnitude(pd + s_lo * qd), detail::magnitude(pd + s_hi * qd)) +
                    s_r * detail::magnitude(qd);
            growth = pm2 + s_r * qm2;
            double disc = 0, sum = detail::magnitude(centre) + detail::magnitude(g[0]);
            for (const AffinePolynomial& a : gens) {
                const std::complex<double> a0 = detail::horner(a.a0, z), a1 = detail::horner(a.a1, z);
                const std::complex<double> a0d = detail::horner_derivative(a.a0, z),
                                           a1d = detail::horner_derivative(a.a1, z);
                g[m++] = a0 + u_c * a1;
                sum += detail::magnitude(g[m - 1]);
                disc += s_r * detail::magnitude(a1);
                slope += std::max(detail::magnitude(a0d + s_lo * a1d), detail::magnitude(a0d + s_hi * a1d)) +
                         s_r * detail::magnitude(a1d);
                growth += a.w2 + s_r * a.w2_a1;
            }
            const double rounding = (2.0 * static_cast<double>(m) + 4.0) * eps * 2.0 * sum;
            margin = zonotope_origin_distance(centre, g.data(), m) - disc - rounding - threshold;
        }
    };
    MeanValueForm mean_value_form(const Box& b, const Gains& k) const {
        const MeanValue mv = mean_value(b);
        MeanValueForm f;
        f.built = true;
        segment_polynomials(mv.cc, b.n, k, f.pm, f.qm);
        f.pm2 = std::max(detail::weighted_sum(Eigen::VectorXd(f.pm + k.u_lo * f.qm), 2),
                         detail::weighted_sum(Eigen::VectorXd(f.pm + k.u_hi * f.qm), 2));
        f.qm2 = detail::weighted_sum(f.qm, 2);
        for (std::size_t j = 0; j < 3; ++j) {
            if (!(mv.r[j] > 0)) continue;
            std::array<double, 5> dc{};
            for (std::size_t i = 0; i < 5; ++i) dc[i] = mv.m[i][j] * mv.r[j];
            f.gens.push_back(affine_polynomial(dc, b.n, k));
        }
        for (std::size_t i = 0; i < 5; ++i) {
            if (!(mv.e[i] > 0)) continue;
            std::array<double, 5> dc{};
            dc[i] = mv.e[i];
            f.gens.push_back(affine_polynomial(dc, b.n, k));
        }
        // Horner's rounding on every polynomial evaluated (as the radii's threshold).
        double size = detail::weighted_sum(f.pm, 0) + k.u_hi * detail::weighted_sum(f.qm, 0);
        for (const AffinePolynomial& a : f.gens) size += a.size;
        f.threshold = 4.0 * static_cast<double>(f.pm.size() + 1) * std::numeric_limits<double>::epsilon() * size;
        return f;
    }

    // H(theta) > threshold on [0, pi] (header comment), cell by cell in (theta, s): a cell is excluded by the
    // coefficient radii's bound or, on a sub-box of positive width where that fails, by the mean-value form.
    HAPTICOPT_DEFERRED bool excludes_zero(const Box& b, const Centre& c, const Gains& k, double& failing_theta) const {
        Eigen::VectorXd p, q;
        segment_polynomials(c.c, b.n, k, p, q);
        const std::array<double, 5>& r = c.radius;
        const double eps = std::numeric_limits<double>::epsilon();
        const double threshold = 4.0 * static_cast<double>(p.size() + 1) * eps *
                                 (detail::weighted_sum(p, 0) + k.u_hi * detail::weighted_sum(q, 0));
        // Bounds over theta of |f| growth: |f(z(theta'))| <= |f(z)| + |theta' - theta| sum k |f_k|, and of |f'| with
        // sum k^2 |f_k|; for the affine families in s (P + s Q, K) their larger value at the segment's ends.
        const double p2 = std::max(detail::weighted_sum(Eigen::VectorXd(p + k.u_lo * q), 2),
                                   detail::weighted_sum(Eigen::VectorXd(p + k.u_hi * q), 2));
        const double a1 = detail::weighted_sum(at_, 1), a2 = detail::weighted_sum(at_, 2);
        const double k1 = k.weighted_bound(1), k2 = k.weighted_bound(2);
        const bool wide = b.gamma.hi > b.gamma.lo || b.delta.hi > b.delta.lo || b.phi.hi > b.phi.lo;
        MeanValueForm form;  // built at its first use
        struct Point {
            double theta, s_lo, s_hi;
            double h;                       // H(theta) over the point's s, the radii's bound
            double p_d, a, a_d, k, k_d, w;  // max over s of |P' + s Q'|, |At|, |At'|, bounds of |K| and |K'|, |z - 1|
            bool mv = false;                // the mean-value margin below computed
            double h_mv = -1, mv_d = 0, mv_w = 0;  // it, its slope bound at the point and that bound's growth per h
        };
        auto at = [&](double theta, double s_lo, double s_hi) {
            const std::complex<double> z = std::polar(1.0, theta);
            const std::complex<double> pz = detail::horner(p, z), qz = detail::horner(q, z);
            const std::complex<double> pd = detail::horner_derivative(p, z), qd = detail::horner_derivative(q, z);
            const double qq = std::norm(qz);
            double s = qq > 0 ? -(pz * std::conj(qz)).real() / qq : s_lo;
            s = std::clamp(s, s_lo, s_hi);
            Point v;
            v.theta = theta;
            v.s_lo = s_lo;
            v.s_hi = s_hi;
            v.a = detail::magnitude(detail::horner(at_, z));
            v.k = k.bound(z, s_lo, s_hi);
            v.w = detail::magnitude(z - 1.0);
            const double g = v.a * (r[0] + r[1] * v.w) + v.k * (r[2] + v.w * (r[3] + v.w * r[4]));
            v.h = detail::magnitude(pz + s * qz) - g;
            v.p_d = std::max(detail::magnitude(pd + s_lo * qd), detail::magnitude(pd + s_hi * qd));
            v.a_d = detail::magnitude(detail::horner_derivative(at_, z));
            v.k_d = k.derivative_bound(z, s_lo, s_hi);
            return v;
        };
        int fills = 0;  // mean-value points computed; beyond kArmBoxMaxMeanValuePoints the cell is not positive there
        auto with_mean_value = [&](Point& v) {
            if (!wide || v.mv) return;
            v.mv = true;
            if (++fills > kArmBoxMaxMeanValuePoints) return;  // h_mv stays -1: not positive
            if (!form.built) form = mean_value_form(b, k);
            form.fill(v.theta, v.s_lo, v.s_hi, v.h_mv, v.mv_d, v.mv_w);
        };
        // The largest |dH/dtheta| within h of a point: min_s |P + s Q| moves by at most max_s |P' + s Q'| (convex in s:
        // at the cell's ends of s), G by the derivative of its products (|d|z - 1|/dtheta| <= 1), each factor bounded
        // over the cell from the point.
        auto slope = [&](const Point& v, double h) {
            const double pd = v.p_d + h * p2;
            const double a = v.a + h * a1, ad = v.a_d + h * a2, kk = v.k + h * k1, kd = v.k_d + h * k2;
            const double w = std::min(v.w + h, 2.0);
            const double g_d =
                ad * (r[0] + r[1] * w) + a * r[1] + kd * (r[2] + w * (r[3] + w * r[4])) + kk * (r[3] + 2.0 * w * r[4]);
            return pd + g_d;
        };
        auto positive = [&](Point& v) {
            if (v.h > threshold) return true;
            with_mean_value(v);
            return v.h_mv > 0;
        };
        // Where the radii's bound is positive at both ends the cell is left to it (halving theta refines it, at a
        // fraction of the mean-value form's cost); where it is not at an end, the mean-value form judges the cell.
        auto passes = [&](Point& pa, Point& pb, double h) {
            if (pa.h > threshold && pb.h > threshold)
                return (pa.h + pb.h) / 2 - std::min(slope(pa, h), slope(pb, h)) * h / 2 > threshold;
            if (!wide) return false;
            with_mean_value(pa);
            with_mean_value(pb);
            const double lipschitz = std::min(pa.mv_d + h * pa.mv_w, pb.mv_d + h * pb.mv_w);
            return pa.h_mv > 0 && pb.h_mv > 0 && (pa.h_mv + pb.h_mv) / 2 - lipschitz * h / 2 > 0;
        };
        constexpr int kCells = 128;
        const double pi = 3.14159265358979323846;
        struct Cell {
            Point pa, pb;
        };
        std::vector<Cell> cells;
        Point prev = at(0.0, k.u_lo, k.u_hi);
        for (int i = 1; i <= kCells; ++i) {
            const Point next = at(pi * i / kCells, k.u_lo, k.u_hi);
            cells.push_back(Cell{prev, next});
            prev = next;
        }
        // A cell with an end where neither bound is positive is refined in s (the mean-value form's s-generator and
        // K's bound shrink with s's range) down to 1e-6 of the segment's, then fails; one whose ends are positive but
        // whose slope bound is too large is halved in s (s_spread) or theta.
        const double s_narrowest = 1e-6 * (k.u_hi - k.u_lo);
        int evaluations = 0;
        while (!cells.empty()) {
            Cell cell = cells.back();
            cells.pop_back();
            const double h = cell.pb.theta - cell.pa.theta;
            const bool ends = positive(cell.pa) && positive(cell.pb);
            if (ends && passes(cell.pa, cell.pb, h)) continue;
            failing_theta =
                ends ? 0.5 * (cell.pa.theta + cell.pb.theta) : (cell.pa.h > threshold ? cell.pb.theta : cell.pa.theta);
            if (h < kArmBoxMinCell || ++evaluations > kArmBoxMaxEvaluations) return false;
            const double s_lo = cell.pa.s_lo, s_hi = cell.pa.s_hi;
            const bool s_split =
                s_hi - s_lo > s_narrowest && (!ends || s_spread(cell.pa.theta, s_lo, s_hi, p, q) > 2.0);
            if (!ends && !s_split) return false;
            if (s_split) {
                const double s_mid = 0.5 * (s_lo + s_hi);
                for (const auto& [lo, hi] : {std::pair{s_lo, s_mid}, std::pair{s_mid, s_hi}})
                    cells.push_back(Cell{at(cell.pa.theta, lo, hi), at(cell.pb.theta, lo, hi)});
                continue;
            }
            const Point mid = at(0.5 * (cell.pa.theta + cell.pb.theta), s_lo, s_hi);
            cells.push_back(Cell{cell.pa, mid});
            cells.push_back(Cell{mid, cell.pb});
        }
        return true;
    }

    // max / min over the ends of s of |P' + s Q'| at theta (the s-split rule of excludes_zero).
    static double s_spread(double theta, double s_lo, double s_hi, const Eigen::VectorXd& p, const Eigen::VectorXd& q) {
        const std::complex<double> z = std::polar(1.0, theta);
        const std::complex<double> pd = detail::horner_derivative(p, z), qd = detail::horner_derivative(q, z);
        const double lo = std::abs(pd + s_lo * qd), hi = std::abs(pd + s_hi * qd);
        return std::max(lo, hi) / std::max(std::min(lo, hi), std::numeric_limits<double>::min());
    }

    NormalizedPlant plant_;
    VelocityEstimator estimator_;
    double gamma_max_, delta_max_, d_lo_, d_hi_;
    Eigen::VectorXd at_, k_alpha_, k_beta_;
};

}  // namespace hapticopt
