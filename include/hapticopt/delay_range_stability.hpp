// SPDX-License-Identifier: Apache-2.0
// Stability of fixed physical gains over a box of masses and total delays: s in [s_lo, s_hi] (the mass ray of
// mass_scaling_stability.hpp) times d in [d_lo, d_hi] periods, whole and fractional. Beyond Hulin et al. 2011.
//
// The delay d = n + phi, phi in [0, 1] within one whole n. For the free-mass plant (gamma = delta = 0) the ZOH
// double integrator with delay n + phi has the pulse transfer (modified z-transform of 1 / s^3)
//
//   G(z) = z^-n [(1 - phi)^2 z^2 + (1 + 2 phi - 2 phi^2) z + phi^2] / (2 z (z - 1)^2),
//
// so the monic characteristic polynomial of the loop with the controller alpha + beta E(z) (E the velocity
// estimator, rational in z and independent of phi) is, per whole n,
//
//   p_n(z; s, phi) = P_0(z) + s Q(z; phi),   Q(z; phi) = Q_0(z) + phi Q_1(z) + phi^2 Q_2(z),
//
// of one degree N_n + 1 for every phi in [0, 1] (P_0 = 2 z^(n+1) (z - 1)^2 At(z) / lead: independent of phi), with
// p_n(z; s, 0) = z p_{n}(z; s) (the whole delay n, one extra root at 0) and p_n(z; s, 1) = p_{n+1}(z; s). This
// header does not use the closed form: it reads p at D + 1 Chebyshev nodes phi_i in (0, 1) from the library's exact
// discretisation (sampled_plant.hpp: two ZOH segments), fits the coefficients as polynomials of degree D in phi
// (D = 2 suffices for the free-mass plant; 4 is fitted, the higher terms are rounding) and measures the fit at 4 more
// phi (fit_residual: 1e-15 relative for the free-mass plant, tests/beyond/test_delay_range_stability.cpp). With an
// arm (gamma, delta > 0) the coefficients hold exp(A phi) and are not polynomials in phi: the fit is raised up to
// degree 8 and its measured residual is added to the bound below; that path is estimated, not proven (`certified`
// false).
//
// Theorem used (zero exclusion): the roots of p_n depend continuously on (s, phi), the degree is constant on the
// box (leading coefficient 1), and the number of roots outside the unit circle agrees at the junction of n and
// n + 1 (z p_{n+1} has the roots of p_{n+1} and 0). So the loop is stable on the whole box iff it is stable at
// one point of it and p_n(e^{i theta}; s, phi) != 0 for every theta, s in [s_lo, s_hi] and phi of every
// segment. The exact verdict at one point is the library's (Schur-Cohn at (d_lo, s_lo); the slabs cover the rest of
// the box, its edges included). Zero exclusion on a slab phi in [phi_c - w, phi_c + w] is certified by
//
//   H(theta) = min_s |P_0(z) + s Q(z; phi_c)| - w G(theta) > r   for every theta,
//   G(theta) = sum_{j >= 1} 2 j tau^(j-1) (|P_0,j(z)| + s_hi |Q_j(z)|)   (P_0,j, Q_j the t^j terms of the fit,
//   t = 2 phi - 1, tau the largest |t| of the slab; terms at rounding level enter by sum |c_k|), r the fit residual,
//
// since |p(phi) - p(phi_c)| <= |phi - phi_c| G(theta) at each z = e^{i theta}. For each theta the min over s is
// closed-form (the distance of the segment P_0 + [s_lo, s_hi] Q from 0). The min over theta in [0, pi] (real
// coefficients: the lower half circle mirrors it) is bounded from below cell by cell: on a cell of width h with end
// values H_1, H_2, H >= (H_1 + H_2) / 2 - L h / 2 with L = min over the ends of (|P_0'(z)| + s_hi |Q'(z)|) + h (sum k^2
// |P_0,k|
// + s_hi sum k^2 |Q_k|) + w sum_j 2 j tau^(j-1) sum_k k (|P_0,jk| + s_hi |Q_jk|) (|d/dtheta p| = |p'(z)|; the
// second derivative bounds its change over the cell), and
// Horner's rounding 4 (N + 1) eps sum |c_k| is added to the threshold. A cell that fails is halved; a slab that
// fails is checked exactly at phi_c (gain_ray_crossings of p_n(z; ., phi_c): a crossing in [s_lo, s_hi] is the
// failing plant, with its delay and scale), then halved. A slab narrower than 1e-7 or more than kMaxSlabs slabs
// refuse the box conservatively (at the slab's delay: no proof either way).
//
// Accuracy: exact (for the free-mass plant) up to the rounding of the coefficients: the bound is strict, so a box
// is accepted only with a positive distance of every root from the unit circle; a box whose roots pass within the
// rounding of the circle may be refused although stable. Cost: docs/benchmarks.md, "Plant set".
// Not for the real-time loop (allocates).
#pragma once

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <complex>
#include <limits>
#include <vector>

#include "characteristic_polynomial.hpp"
#include "config.hpp"
#include "errors.hpp"
#include "estimator_types.hpp"
#include "mass_scaling_stability.hpp"
#include "parameters.hpp"

namespace hapticopt {

/// Stability over the box s in [s_lo, s_hi] times d in [d_lo, d_hi].
struct DelayBoxStability {
    bool stable = false;
    bool certified = false;    ///< decided by zero exclusion on the exact (free-mass) polynomial family
    double failing_scale = 0;  ///< when not stable: a scale of the box at which the loop is not stable (or not proven)
    double failing_delay = 0;  ///< periods, with it
    bool proven_unstable = false;  ///< the failing plant has a root on or outside the unit circle (else: not proven)
};

/// The family p_n(z; s, phi) of one whole delay n with its coefficients fitted as polynomials in t = 2 phi - 1.
struct DelaySegmentFamily {
    int whole_delay = 0;
    int degree = 0;  ///< in t
    /// [j](k): coefficient of t^j in the k-th coefficient (ascending z) of P_0, P_alpha, P_beta.
    std::vector<Eigen::VectorXd> base, alpha, beta;
    double residual = 0;  ///< largest measured |fit - exact| at 4 check points, absolute (per unit s, alpha, beta)
};

namespace detail {

inline Eigen::VectorXd padded(const Eigen::VectorXd& v, Eigen::Index size) {
    Eigen::VectorXd r = Eigen::VectorXd::Zero(size);
    r.head(std::min(size, v.size())) = v.head(std::min(size, v.size()));
    return r;
}

inline Eigen::VectorXd series_at(const std::vector<Eigen::VectorXd>& c, double t) {
    Eigen::VectorXd v = c.back();
    for (std::size_t j = c.size() - 1; j-- > 0;) v = v * t + c[j];
    return v;
}

}  // namespace detail

/// The exact polynomial family over a delay interval for one plant (gamma, delta per unit mass: ArmAlongRay::
/// per_mass) and velocity estimator; judges gains over boxes of scales and delays (header comment).
class DelayRangeTest {
  public:
    static constexpr int kMaxSlabs = 2048;

    /// plant.delay is ignored: the delays are [d_lo, d_hi] periods (0 <= d_lo <= d_hi <= d_lo + 64, d_hi <= 1000).
    /// Throws InvalidParameter for an invalid plant, estimator or interval.
    HAPTICOPT_DEFERRED
    DelayRangeTest(const NormalizedPlant& plant, const VelocityEstimator& estimator, double d_lo, double d_hi)
        : plant_(plant), estimator_(estimator), d_lo_(d_lo), d_hi_(d_hi) {
        const char* fn = "hapticopt::DelayRangeTest";
        if (!(d_lo >= 0 && d_lo <= d_hi && d_hi <= 1000 && d_hi - d_lo <= 64)) {
            throw InvalidParameter(fn, "delay interval", d_lo,
                                   "0 <= d_lo <= d_hi <= 1000 periods, at most 64 periods wide");
        }
        for (const double d : sampled_delays(d_lo, d_hi)) {
            NormalizedPlant at = plant;
            at.delay = d;
            sample_tests_.emplace_back(at, estimator, ArmAlongRay::per_mass);
        }
        certified_ = plant.gamma == 0.0 && plant.delta == 0.0;
        if (d_hi > d_lo) {
            for (int n = static_cast<int>(std::floor(d_lo)); n < d_hi; ++n) families_.push_back(fit(n));
        }
        for (const DelaySegmentFamily& f : families_) {
            if (f.residual > 1e-12) certified_ = false;
        }
    }

    double delay_min() const { return d_lo_; }
    double delay_max() const { return d_hi_; }
    /// Whether every verdict is a proof (the free-mass plant's polynomial family, its fit at rounding level).
    bool certified() const { return certified_; }
    const std::vector<DelaySegmentFamily>& families() const { return families_; }

    /// The fitted p_n(z; s, phi) at (n, phi) as an affine polynomial in the gains (ascending z, monic).
    AffineCharacteristicPolynomial<double> polynomial(const DelaySegmentFamily& f, double phi) const {
        const double t = 2 * phi - 1;
        AffineCharacteristicPolynomial<double> p;
        p.base = detail::series_at(f.base, t);
        p.alpha = detail::series_at(f.alpha, t);
        p.beta = detail::series_at(f.beta, t);
        return p;
    }

    /// Stability of s (alpha, beta) for every s in [s_lo, s_hi] (0 < s_lo <= s_hi, finite) and every delay.
    HAPTICOPT_DEFERRED DelayBoxStability over(double alpha, double beta, double s_lo, double s_hi) const {
        DelayBoxStability r;
        r.certified = certified_;
        // The one point: (d_lo, s_lo) by the exact verdict (the slabs below cover the rest of the box, its edges
        // included); without a range the exact test along s at the one delay.
        GainRayStability first;
        if (families_.empty()) {
            first = sample_tests_.front().over(alpha, beta, s_lo, s_hi);
        } else {
            first.stable = sample_tests_.front().stable(s_lo * alpha, s_lo * beta);
            first.failing_scale = s_lo;
        }
        if (!first.stable) {
            r.failing_scale = unstable_scale_near(d_lo_, alpha, beta, first.failing_scale, s_lo, s_hi);
            r.failing_delay = d_lo_;
            r.proven_unstable = true;
            return r;
        }
        for (const DelaySegmentFamily& f : families_) {
            const double a = std::max(0.0, d_lo_ - f.whole_delay), b = std::min(1.0, d_hi_ - f.whole_delay);
            if (!segment_clear(f, a, b, alpha, beta, s_lo, s_hi, r)) return r;
        }
        r.stable = true;
        return r;
    }

    /// The delays a sampled verdict is taken at: d_lo, d_hi, every whole period between them and the midpoints of
    /// consecutive ones (periods; d_lo first).
    static std::vector<double> sampled_delays(double d_lo, double d_hi) {
        std::vector<double> knots{d_lo};
        for (double n = std::floor(d_lo) + 1; n < d_hi; n += 1) knots.push_back(n);
        if (d_hi > d_lo) knots.push_back(d_hi);
        std::vector<double> out{d_lo};
        for (std::size_t i = 1; i < knots.size(); ++i) {
            out.push_back((knots[i - 1] + knots[i]) / 2);
            out.push_back(knots[i]);
        }
        return out;
    }

    /// Matrix gains A, B (normalised for the reference mass matrix, as MassScalingTest::matrix_over) over the scales
    /// and every delay: symmetric commuting gains exactly per common direction (over); otherwise sampled, with
    /// MassScalingTest::matrix_over at each of sampled_delays (`certified` false); failing_delay with the failing
    /// scale.
    HAPTICOPT_DEFERRED MatrixGainScaleStability matrix_over(const Eigen::MatrixXd& A, const Eigen::MatrixXd& B,
                                                            double s_lo, double s_hi, int samples) const {
        MatrixGainScaleStability first = sample_tests_.front().matrix_over(A, B, s_lo, s_hi, samples);
        first.failing_delay = d_lo_;
        if (!first.stable) return first;
        MatrixGainScaleStability r = first;
        if (first.commuting) {
            const Eigen::MatrixXd As = (A + A.transpose()) / 2, Bs = (B + B.transpose()) / 2;
            const Eigen::MatrixXd Q = detail::acting_basis(As, Bs);
            const Eigen::MatrixXd Ar = Q.transpose() * As * Q, Br = Q.transpose() * Bs * Q;
            for (const NormalizedGains& g : detail::common_direction_gains(Ar, Br)) {
                const DelayBoxStability d = over(g.alpha, g.beta, s_lo, s_hi);
                if (!d.stable) {
                    r.stable = false;
                    r.certified = d.certified;
                    r.failing_scale = d.failing_scale;
                    r.failing_delay = d.failing_delay;
                    return r;
                }
            }
            r.certified = certified_;
            return r;
        }
        const std::vector<double> delays = sampled_delays(d_lo_, d_hi_);
        for (std::size_t i = 1; i < sample_tests_.size(); ++i) {
            MatrixGainScaleStability v = sample_tests_[i].matrix_over(A, B, s_lo, s_hi, samples);
            r.spectral_radius = std::max(r.spectral_radius, v.spectral_radius);
            if (!v.stable) {
                v.failing_delay = delays[i];
                return v;
            }
        }
        return r;
    }

  private:
    HAPTICOPT_DEFERRED DelaySegmentFamily fit(int n) const {
        DelaySegmentFamily f;
        f.whole_delay = n;
        const double scale_gain = 1.0;
        for (int degree : {4, 6, 8}) {
            f.degree = degree;
            const int m = degree + 1;
            Eigen::MatrixXd V(m, m);
            std::vector<AffineCharacteristicPolynomial<double>> at(static_cast<std::size_t>(m));
            Eigen::Index size = 0;
            for (int i = 0; i < m; ++i) {
                const double t = std::cos((2.0 * i + 1.0) * 3.14159265358979323846 / (2.0 * m));
                for (int j = 0; j < m; ++j) V(i, j) = std::pow(t, j);
                at[static_cast<std::size_t>(i)] = exact(n, (t + 1) / 2);
                size = std::max(size, at[static_cast<std::size_t>(i)].base.size());
            }
            const Eigen::PartialPivLU<Eigen::MatrixXd> lu(V);
            auto fit_one = [&](auto member) {
                Eigen::MatrixXd values(m, size);
                for (int i = 0; i < m; ++i)
                    values.row(i) = detail::padded(member(at[static_cast<std::size_t>(i)]), size).transpose();
                const Eigen::MatrixXd c = lu.solve(values);
                std::vector<Eigen::VectorXd> out;
                for (int j = 0; j < m; ++j) out.push_back(c.row(j).transpose());
                return out;
            };
            f.base = fit_one([](const AffineCharacteristicPolynomial<double>& p) { return p.base; });
            f.alpha = fit_one([](const AffineCharacteristicPolynomial<double>& p) { return p.alpha; });
            f.beta = fit_one([](const AffineCharacteristicPolynomial<double>& p) { return p.beta; });
            f.residual = 0;
            for (const double phi : {0.0731, 0.3333, 0.6180, 0.9413}) {
                const AffineCharacteristicPolynomial<double> e = exact(n, phi), p = polynomial(f, phi);
                f.residual = std::max({f.residual, (detail::padded(e.base, size) - p.base).cwiseAbs().sum(),
                                       scale_gain * (detail::padded(e.alpha, size) - p.alpha).cwiseAbs().sum(),
                                       scale_gain * (detail::padded(e.beta, size) - p.beta).cwiseAbs().sum()});
            }
            if (f.residual <= 1e-12) break;
        }
        return f;
    }

    HAPTICOPT_DEFERRED AffineCharacteristicPolynomial<double> exact(int n, double phi) const {
        NormalizedPlant p = plant_;
        p.delay = n + phi;
        return MassScalingTest(p, estimator_, ArmAlongRay::per_mass).polynomial();
    }

    // A scale of [s_lo, s_hi] at delay d whose loop the exact verdict finds unstable, given a crossing s there (a
    // root on the circle): the ends of the interval (the farthest from the crossing), then s (1 -+ 1e-2 .. 1e-4);
    // the crossing itself when none is.
    HAPTICOPT_DEFERRED double unstable_scale_near(double d, double alpha, double beta, double s, double s_lo,
                                                  double s_hi) const {
        NormalizedPlant p = plant_;
        p.delay = d;
        const MassScalingTest test(p, estimator_, ArmAlongRay::per_mass);
        for (const double c : {s_hi, s_lo}) {
            if (!test.stable(c * alpha, c * beta)) return c;
        }
        for (const double step : {1e-2, 1e-3, 1e-4}) {
            for (const double c : {s * (1 + step), s * (1 - step)}) {
                if (c >= s_lo && c <= s_hi && !test.stable(c * alpha, c * beta)) return c;
            }
        }
        return s;
    }

    // min over s in [s_lo, s_hi] of |p + s q| and the s attaining it.
    static double segment_distance(std::complex<double> p, std::complex<double> q, double s_lo, double s_hi,
                                   double& s_at) {
        const double qq = std::norm(q);
        s_at = qq > 0 ? std::clamp(-(p.real() * q.real() + p.imag() * q.imag()) / qq, s_lo, s_hi) : s_lo;
        return std::abs(p + s_at * q);
    }

    struct Evaluation {
        double theta, H, slope, s_at;  // H = F - w G; slope: |P'(z)| + s_hi |Q'(z)|
    };

    // The slab's data: P, Q at phi_c, and the phi-series terms j >= 1 of P_0 and Q (for G, header comment).
    struct Slab {
        Eigen::VectorXd P, Q;
        std::vector<Eigen::VectorXd> base_terms, q_terms;  // j = 1 .. D
        std::vector<double> weights;                       // 2 j tau^(j-1)
        // Terms below 1e-9 of the largest (the rounding of the free-mass plant's fit) enter G by sum |c_k| instead
        // of their value at z (|sum c_k z^k| <= sum |c_k|): g_constant.
        std::vector<bool> base_evaluated, q_evaluated;
        double g_constant = 0;
        double s_lo, s_hi, w;
    };

    static std::complex<double> horner(const Eigen::VectorXd& c, std::complex<double> z) {
        std::complex<double> v = 0;
        for (Eigen::Index k = c.size() - 1; k >= 0; --k) v = v * z + c(k);
        return v;
    }

    static Evaluation evaluate(const Slab& slab, double theta) {
        const std::complex<double> z = std::polar(1.0, theta);
        std::complex<double> p = 0, dp = 0, q = 0, dq = 0;
        for (Eigen::Index k = slab.P.size() - 1; k >= 0; --k) {
            dp = dp * z + p;
            p = p * z + slab.P(k);
            dq = dq * z + q;
            q = q * z + slab.Q(k);
        }
        double g = slab.g_constant;  // G(theta) >= max over the slab of |dp / dphi| at this z
        for (std::size_t j = 0; j < slab.weights.size(); ++j) {
            if (slab.base_evaluated[j]) g += slab.weights[j] * std::abs(horner(slab.base_terms[j], z));
            if (slab.q_evaluated[j]) g += slab.weights[j] * slab.s_hi * std::abs(horner(slab.q_terms[j], z));
        }
        Evaluation e;
        e.theta = theta;
        e.H = segment_distance(p, q, slab.s_lo, slab.s_hi, e.s_at) - slab.w * g;
        e.slope = std::abs(dp) + slab.s_hi * std::abs(dq);
        return e;
    }

    // Whether min over theta in [0, pi] of H(theta) = F(theta) - w G(theta) exceeds `threshold` (certified, header
    // comment); `worst`: the evaluation with the smallest H seen.
    HAPTICOPT_DEFERRED static bool distance_exceeds(const Slab& slab, double threshold, Evaluation& worst) {
        const Eigen::VectorXd& P = slab.P;
        const Eigen::VectorXd& Q = slab.Q;
        const double s_hi = slab.s_hi;
        double second = 0, absolute = 0, g_slope = 0;
        for (Eigen::Index k = 0; k < P.size(); ++k) {
            const double kk = static_cast<double>(k) * static_cast<double>(k);
            second += kk * (std::abs(P(k)) + s_hi * std::abs(Q(k)));
            absolute += std::abs(P(k)) + s_hi * std::abs(Q(k));
        }
        for (std::size_t j = 0; j < slab.weights.size(); ++j) {
            for (Eigen::Index k = 0; k < slab.base_terms[j].size(); ++k) {
                g_slope += slab.weights[j] * static_cast<double>(k) *
                           (std::abs(slab.base_terms[j](k)) + s_hi * std::abs(slab.q_terms[j](k)));
            }
        }
        threshold += 4.0 * static_cast<double>(P.size() + 1) * std::numeric_limits<double>::epsilon() * absolute;
        constexpr int kCells = 64;
        constexpr int kMaxEvaluations = 20000;
        std::vector<std::pair<Evaluation, Evaluation>> stack;
        Evaluation previous = evaluate(slab, 0.0);
        worst = previous;
        for (int i = 1; i <= kCells; ++i) {
            const Evaluation e = evaluate(slab, 3.14159265358979323846 * i / kCells);
            stack.emplace_back(previous, e);
            previous = e;
        }
        int evaluations = kCells + 1;
        while (!stack.empty()) {
            const auto [a, b] = stack.back();
            stack.pop_back();
            if (a.H < worst.H) worst = a;
            if (b.H < worst.H) worst = b;
            if (!(std::min(a.H, b.H) > threshold)) return false;
            const double h = b.theta - a.theta;
            const double lipschitz = std::min(a.slope, b.slope) + h * second + slab.w * g_slope;
            if ((a.H + b.H) / 2 - lipschitz * h / 2 > threshold) continue;
            if (++evaluations > kMaxEvaluations || h < 1e-12) return false;
            const Evaluation m = evaluate(slab, (a.theta + b.theta) / 2);
            stack.emplace_back(a, m);
            stack.emplace_back(m, b);
        }
        return true;
    }

    // Zero exclusion on phi in [a, b] of family f (header comment); on failure fills r.
    HAPTICOPT_DEFERRED bool segment_clear(const DelaySegmentFamily& f, double a, double b, double alpha, double beta,
                                          double s_lo, double s_hi, DelayBoxStability& r) const {
        std::vector<std::pair<double, double>> slabs{{a, b}};
        int count = 0;
        std::vector<Eigen::VectorXd> q_series;
        for (std::size_t j = 0; j < f.alpha.size(); ++j) q_series.push_back(alpha * f.alpha[j] + beta * f.beta[j]);
        const double residual = f.residual * (1 + s_hi * (std::abs(alpha) + std::abs(beta)));
        while (!slabs.empty()) {
            const auto [lo, hi] = slabs.back();
            slabs.pop_back();
            const double phi = (lo + hi) / 2, w = (hi - lo) / 2;
            const double tau = std::max(std::abs(2 * lo - 1), std::abs(2 * hi - 1));
            const double t = 2 * phi - 1;
            Slab slab;
            slab.P = detail::series_at(f.base, t);
            slab.Q = detail::series_at(q_series, t);
            slab.s_lo = s_lo;
            slab.s_hi = s_hi;
            slab.w = w;
            double power = 1;
            double largest_base = 0, largest_q = 0;
            for (std::size_t j = 1; j < f.base.size(); ++j) {
                largest_base = std::max(largest_base, f.base[j].cwiseAbs().sum());
                largest_q = std::max(largest_q, q_series[j].cwiseAbs().sum());
            }
            for (std::size_t j = 1; j < f.base.size(); ++j) {
                slab.base_terms.push_back(f.base[j]);
                slab.q_terms.push_back(q_series[j]);
                const double weight = 2.0 * static_cast<double>(j) * power;
                slab.weights.push_back(weight);
                const double base_sum = f.base[j].cwiseAbs().sum(), q_sum = q_series[j].cwiseAbs().sum();
                slab.base_evaluated.push_back(base_sum > 1e-9 * largest_base);
                slab.q_evaluated.push_back(q_sum > 1e-9 * largest_q);
                if (!slab.base_evaluated.back()) slab.g_constant += weight * base_sum;
                if (!slab.q_evaluated.back()) slab.g_constant += weight * s_hi * q_sum;
                power *= tau;
            }
            const Eigen::VectorXd& P = slab.P;
            Evaluation worst{};
            if (distance_exceeds(slab, 2 * residual, worst)) continue;
            // Exact along s at phi: a crossing inside [s_lo, s_hi] is a failing plant.
            AffineCharacteristicPolynomial<double> at;
            at.base = P;
            at.alpha = detail::series_at(f.alpha, t);
            at.beta = detail::series_at(f.beta, t);
            for (const double s : gain_ray_crossings(at, alpha, beta)) {
                if (s >= s_lo && s <= s_hi) {
                    r.failing_scale = unstable_scale_near(f.whole_delay + phi, alpha, beta, s, s_lo, s_hi);
                    r.failing_delay = f.whole_delay + phi;
                    r.proven_unstable = true;
                    return false;
                }
            }
            if (w < 1e-7 || ++count > kMaxSlabs) {
                r.failing_scale = worst.s_at;
                r.failing_delay = f.whole_delay + phi;
                return false;
            }
            slabs.emplace_back(lo, phi);
            slabs.emplace_back(phi, hi);
        }
        return true;
    }

    NormalizedPlant plant_;
    VelocityEstimator estimator_;
    double d_lo_ = 0, d_hi_ = 0;
    bool certified_ = true;
    std::vector<MassScalingTest> sample_tests_;  // at sampled_delays(d_lo, d_hi), d_lo first
    std::vector<DelaySegmentFamily> families_;
};

}  // namespace hapticopt
