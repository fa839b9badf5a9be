// SPDX-License-Identifier: Apache-2.0
// The stable region of the wall gains in the (alpha, beta) plane, computed exactly by
// D-decomposition (parameter-space method; Hulin, Preusche, Hirzinger, IROS 2006/2008 use the same
// characteristic equation).
//
// On the boundary a root of p(z) = P_0(z) + alpha P_alpha(z) + beta P_beta(z) lies on the unit
// circle. For z = e^{i theta}, 0 < theta < pi, p = 0 is two real linear equations in (alpha, beta),
// so each frequency theta gives one boundary point (complex-root branch). The real-root branches are
// z = 1, where p(1) = 0 reduces to alpha = -gamma (P_beta(1) = 0), and z = -1, a straight line.
// The stable region is enclosed by the complex branch for theta in (0, theta_c), theta_c the first
// frequency where it returns to alpha = -gamma, and the segment of alpha = -gamma between the branch's
// two ends (for every plant tested, d in [0, 50]; tests/core/test_stability.cpp checks points
// just inside and outside the polygon with the Schur-Cohn test).
//
// alpha_max is the largest alpha of the branch: a root of d alpha / d theta (differentiated
// exactly), bracketed on a 512-point scan and refined by bisection to ~1e-15 in theta, so alpha_max
// and its beta are accurate to ~1e-12 (beta's conditioning is that of theta, not of the flat alpha).
// The stiffness range of the wall is [-gamma, alpha_max].
#pragma once

#include <complex>
#include <vector>

#include "characteristic_polynomial.hpp"
#include "config.hpp"
#include "scalar_search.hpp"

namespace hapticopt {

struct BoundaryPoint {
    double theta;  ///< frequency of the unit-circle root, rad per period (0: z = 1, pi: z = -1)
    double alpha;
    double beta;
};

class StabilityRegion {
  public:
    HAPTICOPT_DEFERRED
    explicit StabilityRegion(const NormalizedPlant& plant)
        : plant_(plant), sampled_(plant), poly_(characteristic_polynomial(sampled_)) {
        constexpr int kScan = 512;
        // theta_c: first return of the branch to alpha = -gamma.
        const double left = -plant.gamma;
        double previous = 0;
        theta_c_ = 0;
        for (int i = 1; i < kScan; ++i) {
            const double theta = kPi * i / kScan;
            const double excess = point(theta).alpha - left;
            if (i > 1 && previous > 0 && !(excess > 0)) {
                const auto bracket = detail::bisect([&](double t) { return point(t).alpha - left > 0; },
                                                    kPi * (i - 1) / kScan, theta, 1e-15);
                theta_c_ = bracket.first;
                break;
            }
            previous = excess;
        }
        if (theta_c_ == 0) {
            throw InvalidParameter("hapticopt::StabilityRegion", "delay", plant.delay,
                                   "a plant whose stable region is enclosed by the complex-root branch "
                                   "(not found for these gamma, delta)");
        }
        // alpha_max: sign change of d alpha / d theta from + to -, at the largest alpha.
        double best_theta = 0, best_alpha = -HUGE_VAL;
        for (int i = 1; i < kScan; ++i) {
            const double theta = theta_c_ * i / kScan;
            const double a = point(theta).alpha;
            if (a > best_alpha) {
                best_alpha = a;
                best_theta = theta;
            }
        }
        const double step = theta_c_ / kScan;
        const double lo = std::max(best_theta - step, 1e-300), hi = std::min(best_theta + step, theta_c_);
        const auto bracket = detail::bisect([&](double t) { return alpha_slope(t) > 0; }, lo, hi, 1e-16);
        theta_max_ = (bracket.first + bracket.second) / 2;
        tip_ = point(theta_max_);
    }

    const NormalizedPlant& plant() const { return plant_; }

    /// The boundary point of the complex-root branch at frequency theta (0 < theta < pi).
    BoundaryPoint point(double theta) const {
        const auto [a, b] = solve(theta);
        return {theta, a, b};
    }

    /// The point of largest alpha (the tip of the region) and the stiffness range [-gamma, alpha_max].
    double alpha_max() const { return tip_.alpha; }
    double beta_at_alpha_max() const { return tip_.beta; }
    double alpha_min() const { return -plant_.gamma; }
    /// The frequency where the branch closes on alpha = -gamma, and where it reaches alpha_max.
    double closing_frequency() const { return theta_c_; }
    double tip_frequency() const { return theta_max_; }

    /// The interval of stable beta at a given alpha in (alpha_min, alpha_max): the two crossings of the
    /// branch with that alpha, below and above the tip (bisection in theta to ~1e-15).
    std::pair<double, double> beta_range(double alpha) const {
        detail::require_in_range("hapticopt::StabilityRegion::beta_range", "alpha", alpha, alpha_min(), true,
                                 alpha_max(), "alpha_min < alpha <= alpha_max");
        auto above = [&](double t) { return point(t).alpha > alpha; };
        const auto low = detail::bisect(above, 1e-300, theta_max_, 1e-15);
        const auto high = detail::bisect(above, theta_max_, theta_c_, 1e-15);
        return {point((low.first + low.second) / 2).beta, point((high.first + high.second) / 2).beta};
    }

    /// The closed boundary as a polygon: `points` samples of the complex branch from theta -> 0 to
    /// theta_c, then back down the line alpha = -gamma (the last point equals the first's beta).
    std::vector<BoundaryPoint> polygon(int points = 256) const {
        detail::require_in_range("hapticopt::StabilityRegion::polygon", "points", points, 8, false, 1e7,
                                 "8 <= points <= 10^7");
        std::vector<BoundaryPoint> out;
        out.reserve(static_cast<std::size_t>(points) + 1);
        for (int i = 0; i < points; ++i) {
            // Cosine spacing puts more points near the branch's ends and its tip region's ends.
            const double s = (1 - std::cos(kPi * (i + 0.5) / points)) / 2;
            out.push_back(point(theta_c_ * s));
        }
        out.push_back(BoundaryPoint{0.0, alpha_min(), out.front().beta});
        return out;
    }

  private:
    static constexpr double kPi = 3.14159265358979323846;
    using Complex = std::complex<double>;

    static Complex horner(const Eigen::VectorXd& c, Complex z) {
        Complex s = 0;
        for (Eigen::Index k = c.size() - 1; k >= 0; --k) s = s * z + c(k);
        return s;
    }
    static Complex horner_derivative(const Eigen::VectorXd& c, Complex z) {
        Complex s = 0;
        for (Eigen::Index k = c.size() - 1; k >= 1; --k) s = s * z + double(k) * c(k);
        return s;
    }

    /// (alpha, beta) with p(e^{i theta}) = 0.
    std::pair<double, double> solve(double theta) const {
        const Complex z = std::polar(1.0, theta);
        const Complex p0 = horner(poly_.base, z), pa = horner(poly_.alpha, z), pb = horner(poly_.beta, z);
        const double det = pa.real() * pb.imag() - pb.real() * pa.imag();
        const double a = (-p0.real() * pb.imag() + pb.real() * p0.imag()) / det;
        const double b = (-pa.real() * p0.imag() + p0.real() * pa.imag()) / det;
        return {a, b};
    }

    /// d alpha / d theta, from differentiating Re/Im of p(e^{i theta}) = 0 (dz/dtheta = i z).
    double alpha_slope(double theta) const {
        const Complex z = std::polar(1.0, theta);
        const Complex dz(-z.imag(), z.real());
        const Complex pa = horner(poly_.alpha, z), pb = horner(poly_.beta, z);
        const auto [a, b] = solve(theta);
        const Complex dp = (horner_derivative(poly_.base, z) + a * horner_derivative(poly_.alpha, z) +
                            b * horner_derivative(poly_.beta, z)) *
                           dz;
        // [Re pa, Re pb; Im pa, Im pb] [a'; b'] = -[Re dp; Im dp]
        const double det = pa.real() * pb.imag() - pb.real() * pa.imag();
        return (-dp.real() * pb.imag() + pb.real() * dp.imag()) / det;
    }

    NormalizedPlant plant_;
    SampledPlant<double> sampled_;
    AffineCharacteristicPolynomial<double> poly_;
    double theta_c_ = 0;
    double theta_max_ = 0;
    BoundaryPoint tip_{0, 0, 0};
};

}  // namespace hapticopt
