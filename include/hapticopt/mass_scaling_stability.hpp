// SPDX-License-Identifier: Apache-2.0
// Stability of fixed physical gains over an interval of moving masses: the hand gripping or letting go.
// Beyond Hulin et al. 2011, whose objective 4 is robustness against the operator's parameters.
//
// Free-mass plant (b = k = 0, gamma = delta = 0), or an arm given per unit mass (k/m and b/m fixed: ArmAlongRay::
// per_mass): the normalised plant (gamma, delta, d) is the same at every mass, and
// fixed physical gains (K, B) acting on mass m are alpha = K T^2 / m, beta = B T / m. With a reference mass
// m_ref and (alpha, beta) its normalised gains, mass m gives s (alpha, beta), s = m_ref / m: the masses
// [m_lo, m_hi] are the segment s in [m_ref / m_hi, m_ref / m_lo] of a ray through the origin. The
// characteristic polynomial (characteristic_polynomial.hpp, or estimator_characteristic_polynomial with a
// velocity estimator) is affine in the gains, hence in s:
//
//   p(z; s) = P_0(z) + s Q(z),   Q = alpha P_alpha + beta P_beta.
//
// A root lies on the unit circle at z = e^{i theta} only where P_0(z) / Q(z) is real, i.e. where
//
//   h(theta) = Im(P_0(e^{i theta}) conj Q(e^{i theta})) = sum_{n=1..N} c_n sin(n theta),
//   c_n = sum_{j-k=n} P_0,j Q_k - sum_{k-j=n} P_0,j Q_k,
//
// vanishes, and then at s = -P_0(z) / Q(z) (real). h(theta) = sin(theta) g(cos theta) with
// g(x) = sum c_n U_{n-1}(x), a Chebyshev series of degree N - 1 (U_{n-1} written in T_j: 2 T_{n-1} + 2 T_{n-3}
// + ..., the T_0 term once). theta = 0 and pi (z = 1, -1) are crossings candidates for any gains. The sign
// changes of g on [-1, 1] are bracketed to adjacent doubles by the derivative cascade (passivity.hpp,
// detail::chebyshev_cascade_zeros: no sign change can be lost); a zero of g without a sign change (the
// root touches the circle and returns) is caught at the extrema of g where |g| is within its rounding
// allowance 8 (N + 1)^2 u sum |g_j| (Clenshaw's recurrence), and counted as a crossing.
//
// Theorem used: the roots of p(z; s) depend continuously on s, so the number of roots outside the unit circle
// can change only at a crossing scale. The loop is therefore stable for every s in [s_lo, s_hi] iff it is stable
// at s_lo (the exact Schur-Cohn verdict with the long double refinement: stability.hpp, or
// EstimatorStabilityTest with an estimator) and no crossing scale lies in [s_lo, s_hi]. The verdict at s_hi is
// computed as well, as a second opinion (it must agree; if it does not, the set is refused at s_hi).
// The degree of p stays n + 3 (+ L with an estimator) for every s > 0 (its leading coefficient is P_0's), so no
// root escapes to infinity.
//
// Accuracy: exact up to rounding in the coefficients of P_0 and Q and of the c_n (relative ~N eps of the largest
// products): a crossing is missed only where the root passes within that rounding of the unit circle, and a
// crossing s is computed to ~1e-12 relative; crossings within 1e-9 (relative) outside [s_lo, s_hi] count as inside.
// The tests compare with the eigenvalues of the loop transition at 2000 masses per segment and with an
// independent time-stepping simulation of the loop at masses drawn from the set, corners and interior
// (tests/beyond/test_mass_scaling_stability.cpp).
//
// Matrix gains (several objects at once, matrix_gain_stability.hpp) on a mass matrix scaled by 1/s: with symmetric,
// commuting A and B the loop decouples along their common eigenvectors into scalar loops (alpha_i, beta_i), each
// judged as above: an exact verdict (`certified`). Otherwise the characteristic loci do not reduce to one
// polynomial in s; the block companion matrix's roots are checked inside the unit circle (below 1 -
// kMatrixGainRadiusMargin, or certified one by one nearer: matrix_gain_stability.hpp) at `samples` scales spread over
// the interval (ends included) and at s = 1: a sampled check, not a proof
// (`certified` false); numerical_range_certificate.hpp proves such sums where it can, with segment_over below.
//
// Segments (GainSegment): the gains (alpha_0 + u alpha_1, beta_0 + u beta_1), u in [u_lo, u_hi], give
// p(z; u) = (P_0 + alpha_0 P_alpha + beta_0 P_beta) + u (alpha_1 P_alpha + beta_1 P_beta), affine in u like the ray,
// so the same crossing test with that base decides every segment exactly (segment_over; the ray is the segment with
// alpha_0 = beta_0 = 0 and u = s).
//
// Cost: the cascade is O(N^3) with up to 64 bisection steps per zero of each derivative, N = n + 3 (+ L): 2.5 us at
// d = 1 and 16 us at d = 6 with the backward difference, 0.34 ms with a 15-period window at d = 6
// (docs/benchmarks.md, "Plant set").
// Not for the real-time loop (allocates).
#pragma once

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <complex>
#include <limits>
#include <optional>
#include <vector>

#include "characteristic_polynomial.hpp"
#include "config.hpp"
#include "errors.hpp"
#include "estimator_stability.hpp"
#include "matrix_gain_stability.hpp"
#include "passivity.hpp"
#include "stability.hpp"
#include "estimator_types.hpp"

namespace hapticopt {

/// Stability over a scale interval [s_lo, s_hi] of the gains s (alpha, beta).
struct GainRayStability {
    bool stable = false;
    bool certified = false;    ///< decided by the exact crossing test (always for scalar gains)
    double failing_scale = 0;  ///< when not stable: a scale in [s_lo, s_hi] at which the loop is not stable
};

/// The gains (alpha_0 + u alpha_1, beta_0 + u beta_1), u in [u_lo, u_hi] (0 <= u_lo <= u_hi): a segment of the gain
/// plane. The mass ray s (alpha, beta), s in [s_lo, s_hi], is ray(alpha, beta, s_lo, s_hi); the edge from gains g to h
/// is between(g, h) (u in [0, 1]). Its characteristic polynomial is affine in u (header comment, with P_0 the base
/// plus alpha_0 P_alpha + beta_0 P_beta), so the ray's crossing test applies to every segment.
struct GainSegment {
    double alpha_0 = 0, beta_0 = 0, alpha_1 = 0, beta_1 = 0, u_lo = 0, u_hi = 0;
    static GainSegment ray(double alpha, double beta, double s_lo, double s_hi) {
        return {0.0, 0.0, alpha, beta, s_lo, s_hi};
    }
    static GainSegment between(double alpha_from, double beta_from, double alpha_to, double beta_to) {
        return {alpha_from, beta_from, alpha_to - alpha_from, beta_to - beta_from, 0.0, 1.0};
    }
    double alpha(double u) const { return alpha_0 + u * alpha_1; }
    double beta(double u) const { return beta_0 + u * beta_1; }
};

/// The same for matrix gains; `commuting`: symmetric A, B that commute, decided exactly per direction.
struct MatrixGainScaleStability {
    bool stable = false;
    bool certified = false;
    bool commuting = false;
    double failing_scale = 0;
    double spectral_radius = 0;  ///< at failing_scale when not stable, else the largest over the scales checked
    double failing_delay = -1;   ///< periods, with failing_scale, when a delay range was judged (DelayRangeTest)
};

namespace detail {

inline std::complex<double> polynomial_value(const Eigen::VectorXd& c, std::complex<double> z) {
    std::complex<double> v = 0;
    for (Eigen::Index k = c.size() - 1; k >= 0; --k) v = v * z + c(k);
    return v;
}

}  // namespace detail

/// The scales s > 0 at which p(z; s) = P_0 + s (alpha P_alpha + beta P_beta) has a root on the unit circle
/// (header comment), ascending. Touching roots count. Cost O(N^3).
HAPTICOPT_FUNC std::vector<double> gain_ray_crossings(const AffineCharacteristicPolynomial<double>& p, double alpha,
                                                      double beta)
#if HAPTICOPT_DEFINITIONS
{
    const Eigen::VectorXd& p0 = p.base;
    const Eigen::Index size = p0.size();
    Eigen::VectorXd q = Eigen::VectorXd::Zero(size);
    q.head(p.alpha.size()) += alpha * p.alpha;
    q.head(p.beta.size()) += beta * p.beta;
    const int n_max = static_cast<int>(size) - 1;
    // c_n, n = 1 .. n_max, of h(theta) = sum c_n sin(n theta).
    std::vector<double> c(static_cast<std::size_t>(n_max + 1), 0.0);
    for (Eigen::Index j = 0; j < size; ++j) {
        for (Eigen::Index k = 0; k < size; ++k) {
            const Eigen::Index n = j - k;
            if (n > 0) c[static_cast<std::size_t>(n)] += p0(j) * q(k);
            if (n < 0) c[static_cast<std::size_t>(-n)] -= p0(j) * q(k);
        }
    }
    // g(x) = sum_n c_n U_{n-1}(x) in Chebyshev T coefficients.
    std::vector<double> g(static_cast<std::size_t>(std::max(n_max, 1)), 0.0);
    for (int n = 1; n <= n_max; ++n) {
        for (int j = n - 1; j >= 0; j -= 2)
            g[static_cast<std::size_t>(j)] += (j == 0 ? 1.0 : 2.0) * c[static_cast<std::size_t>(n)];
    }
    while (g.size() > 1 && g.back() == 0.0) g.pop_back();
    double sum = 0;
    for (double v : g) sum += std::abs(v);

    std::vector<double> candidates{1.0, -1.0};  // z = 1, -1
    if (sum > 0 && g.size() > 1) {
        for (double& v : g) v /= sum;
        std::vector<std::vector<double>> derivative{g};
        while (derivative.back().size() > 1) derivative.push_back(detail::chebyshev_derivative(derivative.back()));
        std::vector<detail::ChebyshevBracket> extrema;
        const std::vector<detail::ChebyshevBracket> zeros = detail::chebyshev_cascade_zeros(derivative, 0, &extrema);
        for (const auto& b : zeros) candidates.push_back((b.lo + b.hi) / 2);
        const double n = static_cast<double>(g.size());
        const double allowance = 8 * n * n * std::numeric_limits<double>::epsilon();  // sum |g| = 1 after scaling
        for (const auto& b : extrema) {
            const double x = (b.lo + b.hi) / 2;
            if (std::abs(detail::chebyshev_value(g.data(), static_cast<int>(g.size()), x)) <= allowance) {
                candidates.push_back(x);
            }
        }
    }
    std::vector<double> scales;
    for (const double x : candidates) {
        const double y = std::sqrt(std::max(0.0, 1.0 - x * x));
        const std::complex<double> z(x, y);
        const std::complex<double> pz = detail::polynomial_value(p0, z), qz = detail::polynomial_value(q, z);
        if (!(std::abs(qz) > 0)) continue;  // no s solves it (or a root there for every s: the verdict sees it)
        const double s = (-pz / qz).real();
        if (s > 0 && std::isfinite(s)) scales.push_back(s);
    }
    std::sort(scales.begin(), scales.end());
    return scales;
}
#else
    ;
#endif

/// How the plant's gamma and delta read along the mass ray. `fixed_physical` (the default): they come from a
/// physical k and b, so gamma = k T^2 / m and delta = b T / m change with the mass and only gamma = delta = 0 (the
/// free-mass plant) keeps the normalised plant the same at every mass: other values are refused. `per_mass`: they
/// are k/m and b/m held fixed while the mass scales (an arm whose stiffness and damping per unit of the moving mass
/// are given, the form in which Hulin et al. 2011, eq. 2, bound the human arm), so the normalised plant is the same
/// at every mass and the test is exact for any gamma, delta >= 0.
enum class ArmAlongRay { fixed_physical, per_mass };

/// The exact verdict of one loop and its affine characteristic polynomial, for a plant whose normalised form is the
/// same at every mass of the ray (ArmAlongRay) with a velocity estimator; judges gains over scale intervals (header
/// comment).
class MassScalingTest {
  public:
    /// Throws InvalidParameter for gamma or delta != 0 with ArmAlongRay::fixed_physical (the plant then depends on
    /// the mass), an invalid plant or estimator.
    HAPTICOPT_DEFERRED
    MassScalingTest(const NormalizedPlant& plant, const VelocityEstimator& estimator = {},
                    ArmAlongRay arm = ArmAlongRay::fixed_physical)
        : plant_(plant), estimator_(estimator), sampled_(plant) {
        const char* fn = "hapticopt::MassScalingTest";
        validate(plant, fn);
        validate(estimator, fn);
        if (arm == ArmAlongRay::fixed_physical && (plant.gamma != 0.0 || plant.delta != 0.0)) {
            throw InvalidParameter(fn, plant.gamma != 0.0 ? "gamma" : "delta",
                                   plant.gamma != 0.0 ? plant.gamma : plant.delta,
                                   "0 (the free-mass plant: with b or k the normalised plant depends on the mass; "
                                   "ArmAlongRay::per_mass reads them as k/m and b/m)");
        }
        if (is_backward()) {
            poly_ = characteristic_polynomial(sampled_);
        } else {
            test_.emplace(plant, estimator);
            poly_ = test_->polynomial();
        }
    }

    const NormalizedPlant& plant() const { return plant_; }
    const VelocityEstimator& estimator() const { return estimator_; }
    const AffineCharacteristicPolynomial<double>& polynomial() const { return poly_; }

    /// The exact verdict at (alpha, beta): Schur-Cohn with the long double refinement.
    HAPTICOPT_DEFERRED bool stable(double alpha, double beta) const {
        if (!(std::isfinite(alpha) && std::isfinite(beta))) return false;
        return test_ ? test_->stable(alpha, beta) : loop_is_stable(sampled_, alpha, beta);
    }

    /// Stability of s (alpha, beta) for every s in [s_lo, s_hi] (0 < s_lo <= s_hi, finite).
    HAPTICOPT_DEFERRED GainRayStability over(double alpha, double beta, double s_lo, double s_hi) const {
        if (!(s_lo > 0 && s_lo <= s_hi && std::isfinite(s_hi))) {
            throw InvalidParameter("hapticopt::MassScalingTest::over", "scale interval", s_lo,
                                   "0 < s_lo <= s_hi, finite");
        }
        return segment_over(GainSegment::ray(alpha, beta, s_lo, s_hi));
    }

    /// Stability of every gain pair of the segment (0 <= u_lo <= u_hi, all finite): the exact verdict at u_lo and the
    /// unit-circle crossings of p(z; u) = (P_0 + alpha_0 P_alpha + beta_0 P_beta) + u (alpha_1 P_alpha + beta_1 P_beta)
    /// (gain_ray_crossings on the rebased polynomial; exact as over is). failing_scale: the u it fails at. Gains that
    /// are not finite are not stable (failing at u_lo), as stable() says.
    HAPTICOPT_DEFERRED GainRayStability segment_over(const GainSegment& g) const {
        if (!(g.u_lo >= 0 && g.u_lo <= g.u_hi && std::isfinite(g.u_hi))) {
            throw InvalidParameter("hapticopt::MassScalingTest::segment_over", "u interval", g.u_lo,
                                   "0 <= u_lo <= u_hi, finite");
        }
        GainRayStability r;
        r.certified = true;
        if (!stable(g.alpha(g.u_lo), g.beta(g.u_lo))) {
            r.failing_scale = g.u_lo;
            return r;
        }
        if (g.u_hi > g.u_lo) {
            AffineCharacteristicPolynomial<double> rebased = poly_;
            if (g.alpha_0 != 0.0 || g.beta_0 != 0.0) {
                rebased.base.head(poly_.alpha.size()) += g.alpha_0 * poly_.alpha;
                rebased.base.head(poly_.beta.size()) += g.beta_0 * poly_.beta;
            }
            for (const double u : gain_ray_crossings(rebased, g.alpha_1, g.beta_1)) {
                if (u >= g.u_lo * (1 - 1e-9) && u <= g.u_hi * (1 + 1e-9)) {
                    r.failing_scale = std::clamp(u, g.u_lo, g.u_hi);
                    return r;
                }
            }
            if (!stable(g.alpha(g.u_hi), g.beta(g.u_hi))) {
                r.failing_scale = g.u_hi;
                return r;
            }
        }
        r.stable = true;
        return r;
    }

    /// Matrix gains A, B (any real r x r, normalised for the reference mass matrix) over s in [s_lo, s_hi]
    /// (header comment): exact per direction when A and B are symmetric and commute, else `samples` scales spread over
    /// the interval, ends included (one when s_lo = s_hi), and s = 1 (the reference mass) when inside it.
    HAPTICOPT_DEFERRED MatrixGainScaleStability matrix_over(const Eigen::MatrixXd& A, const Eigen::MatrixXd& B,
                                                            double s_lo, double s_hi, int samples = 33) const {
        const char* fn = "hapticopt::MassScalingTest::matrix_over";
        detail::validate_gain_matrices(plant_, A, B, fn);
        if (!(s_lo > 0 && s_lo <= s_hi && std::isfinite(s_hi))) {
            throw InvalidParameter(fn, "scale interval", s_lo, "0 < s_lo <= s_hi, finite");
        }
        MatrixGainScaleStability r;
        const double scale = A.norm() + B.norm();
        const bool symmetric = (A - A.transpose()).norm() <= kMatrixGainRoundingLevel * scale &&
                               (B - B.transpose()).norm() <= kMatrixGainRoundingLevel * scale;
        const Eigen::MatrixXd As = symmetric ? Eigen::MatrixXd((A + A.transpose()) / 2) : A;
        const Eigen::MatrixXd Bs = symmetric ? Eigen::MatrixXd((B + B.transpose()) / 2) : B;
        const Eigen::MatrixXd Q = detail::acting_basis(As, Bs);
        if (Q.cols() == 0) {
            r.stable = r.certified = r.commuting = true;
            return r;
        }
        const Eigen::MatrixXd Ar = Q.transpose() * As * Q, Br = Q.transpose() * Bs * Q;
        if (symmetric) {
            r.commuting = (Ar * Br - Br * Ar).norm() <= 1e-12 * (1.0 + Ar.norm() * Br.norm());
        }
        if (r.commuting) {
            r.certified = true;
            r.stable = true;
            for (const NormalizedGains& g : detail::common_direction_gains(Ar, Br)) {
                const GainRayStability d = over(g.alpha, g.beta, s_lo, s_hi);
                if (!d.stable) {
                    r.stable = false;
                    r.failing_scale = d.failing_scale;
                    return r;
                }
            }
            return r;
        }
        const int n = s_hi > s_lo ? std::max(samples, 2) : 1;
        std::vector<double> scales;
        for (int i = 0; i < n; ++i) scales.push_back(n == 1 ? s_lo : s_lo + (s_hi - s_lo) * i / (n - 1));
        if (s_lo < 1.0 && 1.0 < s_hi) scales.push_back(1.0);  // the reference mass itself
        for (const double s : scales) {
            const detail::CompanionRoots roots = detail::companion_roots(poly_, s * Ar, s * Br);
            r.spectral_radius = std::max(r.spectral_radius, roots.radius);
            if (!roots.inside) {
                r.failing_scale = s;
                r.spectral_radius = roots.radius;
                return r;
            }
        }
        r.stable = true;
        return r;
    }

  private:
    bool is_backward() const { return estimator_.kind == VelocityEstimatorKind::backward; }

    NormalizedPlant plant_;
    VelocityEstimator estimator_;
    SampledPlant<double> sampled_;
    AffineCharacteristicPolynomial<double> poly_;
    std::optional<EstimatorStabilityTest> test_;
};

}  // namespace hapticopt
