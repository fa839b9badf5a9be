// SPDX-License-Identifier: Apache-2.0
// The overshoot criterion C_OV = (max_t x(t) - x_inf) / x_inf (Hulin et al. 2011, eq. 9) of the
// continuous-time unit step response, with the maximum found exactly inside each period.
//
// Method. The motion is propagated period by period with the exact loop map (closed_loop.hpp).
// Inside a piece of a segment the velocity x' solves x''' + delta x'' + gamma x' = 0, whose
// non-trivial solutions have at most one zero on an interval shorter than pi / omega
// (omega^2 = gamma - delta^2/4; Sturm); pieces are cut shorter than that (sampled_plant.hpp). So
// a maximum inside a piece exists iff x' goes from > 0 to < 0 across it; it is located by
// safeguarded Newton on the Taylor series of x(tau) (exact to rounding: the series is summed to
// machine precision) and evaluated there. Elsewhere the maximum is at a piece end.
//
// Proven stop. With P solving M^T P M = P - I (P >= I; ShiftSteinSolver::observability_gramian,
// stein_equation.hpp: O(N^3) for a (2N-1)-square LU, no eigen-decomposition), V_j = e_j^T P e_j is
// non-increasing, and for every t after period j
//   |x(t) - x_inf| <= kappa sqrt(V_j),  kappa = max_s sum_k h_s^k/k! ||e1^T A^k R_s||_2 (+ tail),
// so the search stops as soon as kappa sqrt(V_j) <= max(current maximum, tol x_inf): later times
// can neither exceed the maximum found nor the tolerance. No fixed horizon.
//
// Tolerance. "No overshoot" means C_OV <= tol (relative). The default 1e-12 reproduces every C_OV
// and C_Ex^OV row of the paper (Tables III and IV; just past the exact no-overshoot region the overshoot
// is positive but tiny, 1e-35 ... 1e-12, because a complex pole pair overtakes a slower real
// pole). Values below ~1e-15 are not resolved in double precision and count as zero; choose a
// physically meaningful tol (1e-6, 1e-3) when that is what the application needs.
// Cost: one LU of size 2N - 1 (the Stein solve for P), then O(N^2) per period until the stop (the
// period loop allocates nothing).
#pragma once

#include <array>
#include <cmath>
#include <limits>

#include "config.hpp"
#include "loop_schur_form.hpp"

namespace hapticopt {

struct OvershootOptions {
    double tolerance = 1e-12;           ///< relative overshoot counted as "no overshoot"; (0, 1]
    long long max_periods = 100000000;  ///< safety cap; reaching it is reported, never silent
    /// The scan stops as soon as the overshoot found exceeds this (relative, >= 0; +inf: never). The value
    /// is then a lower bound above it (stopped_above), which is all a comparison with it needs.
    double stop_above = std::numeric_limits<double>::infinity();
};

template <typename Scalar>
struct OvershootResultT {
    Scalar value = 0;               ///< C_OV >= 0 (exact when > tolerance); +inf when unstable
    Scalar time = 0;                ///< time of the maximum (normalised; NaN when value == 0)
    bool within_tolerance = false;  ///< value <= tolerance and no later excess above it
    bool converged = false;         ///< the proven stop was reached (false: max_periods hit, unstable or
                                    ///< stopped_above)
    bool stopped_above = false;     ///< value > options.stop_above was found and the scan stopped there
    long long periods = 0;          ///< periods examined
};
using OvershootResult = OvershootResultT<double>;

namespace detail {

/// Maximum of x on a piece [0, h] given xi at its start, when x' > 0 at 0 and < 0 at h.
/// Returns (tau*, x(tau*)) with x the first component of exp(A tau) xi.
template <typename Scalar>
std::pair<Scalar, Scalar> interior_maximum(const Matrix3<Scalar>& a, const Eigen::Matrix<Scalar, 3, 1>& xi, Scalar h) {
    // Taylor coefficients c_k of x(tau) = sum c_k tau^k, summed to machine precision on [0, h].
    constexpr int kMax = 64;
    std::array<Scalar, kMax> c{};
    Eigen::Matrix<Scalar, 3, 1> w = xi;
    int count = 0;
    Scalar scale = 0;
    Scalar hk = 1;  // h^k
    for (int k = 0; k < kMax; ++k, hk *= h) {
        c[static_cast<std::size_t>(k)] = w(0);
        count = k + 1;
        using std::abs;
        const Scalar size = std::max(abs(w(0)), std::max(abs(w(1)), abs(w(2)))) * hk;
        scale = std::max(scale, size);
        if (k > 3 && size <= std::numeric_limits<Scalar>::epsilon() * Scalar(1e-3) * scale) break;
        const Eigen::Matrix<Scalar, 3, 1> v = w;
        for (int i = 0; i < 3; ++i) w(i) = (a(i, 0) * v(0) + a(i, 1) * v(1) + a(i, 2) * v(2)) / Scalar(k + 1);
    }
    auto x_at = [&](Scalar tau) {
        Scalar s = 0;
        for (int k = count - 1; k >= 0; --k) s = s * tau + c[static_cast<std::size_t>(k)];
        return s;
    };
    auto v_at = [&](Scalar tau) {
        Scalar s = 0;
        for (int k = count - 1; k >= 1; --k) s = s * tau + Scalar(k) * c[static_cast<std::size_t>(k)];
        return s;
    };
    auto dv_at = [&](Scalar tau) {
        Scalar s = 0;
        for (int k = count - 1; k >= 2; --k) {
            s = s * tau + Scalar(k * (k - 1)) * c[static_cast<std::size_t>(k)];
        }
        return s;
    };
    Scalar lo = 0, hi = h;
    const Scalar v_lo = v_at(lo), v_hi = v_at(hi);
    Scalar tau = v_lo / (v_lo - v_hi) * h;  // secant start
    for (int it = 0; it < 100; ++it) {
        const Scalar v = v_at(tau);
        if (v > 0)
            lo = tau;
        else
            hi = tau;
        const Scalar dv = dv_at(tau);
        Scalar next = dv != Scalar(0) ? tau - v / dv : (lo + hi) / 2;
        if (!(next > lo && next < hi)) next = (lo + hi) / 2;
        const bool done = std::abs(next - tau) <= Scalar(4) * std::numeric_limits<Scalar>::epsilon() * h;
        tau = next;
        if (done || hi - lo <= std::numeric_limits<Scalar>::epsilon() * h) break;
    }
    return {tau, x_at(tau)};
}

/// kappa_s = sum_k h^k/k! ||e1^T A^k R_s||_2 plus a bound on the series' tail.
template <typename Scalar>
Scalar deviation_gain(const Matrix3<Scalar>& a, const DynamicMatrix<Scalar>& r, Scalar h) {
    using std::sqrt;
    const Scalar a_norm = sqrt(a.squaredNorm());  // Frobenius >= spectral
    const Scalar r_norm = sqrt(r.squaredNorm());
    Scalar row[3] = {1, 0, 0};
    Scalar sum = 0;
    Scalar weight = 1;           // h^k / k!
    Scalar bound_term = r_norm;  // r_norm (a_norm h)^k / k!
    for (int k = 0; k < 200; ++k) {
        Scalar row_r = 0;  // ||row R||_2^2
        for (Eigen::Index l = 0; l < r.cols(); ++l) {
            const Scalar v = row[0] * r(0, l) + row[1] * r(1, l) + row[2] * r(2, l);
            row_r += v * v;
        }
        sum += weight * sqrt(row_r);
        const Scalar next[3] = {row[0] * a(0, 0) + row[1] * a(1, 0) + row[2] * a(2, 0),
                                row[0] * a(0, 1) + row[1] * a(1, 1) + row[2] * a(2, 1),
                                row[0] * a(0, 2) + row[1] * a(1, 2) + row[2] * a(2, 2)};
        for (int i = 0; i < 3; ++i) row[i] = next[i];
        weight *= h / Scalar(k + 1);
        bound_term *= a_norm * h / Scalar(k + 1);
        const Scalar tail = bound_term * std::exp(a_norm * h);
        if (tail <= Scalar(1e-9) * sum) return sum + tail;
    }
    return sum * Scalar(2);  // not reached for pieces with ||A|| h <= 2
}

/// What piece_maximum_bound needs for pieces of length h: the rows giving x' = e1^T A xi and
/// x'' = e1^T A^2 xi from the piece's start state xi (for this plant xi = (x, x', f)), and the remainder gain
/// c with |x(tau) - (x + x' tau + x'' tau^2 / 2)| <= c ||xi||_2 on [0, h]: Taylor's remainder
/// |x'''(s)| tau^3 / 6 with |x'''(s)| = |e1^T A^3 exp(A s) xi| <= ||e1^T A^3||_2 exp(||A||_F h) ||xi||_2.
template <typename Scalar>
struct PieceBound {
    Eigen::Matrix<Scalar, 1, 3> velocity_row;
    Eigen::Matrix<Scalar, 1, 3> acceleration_row;
    Scalar remainder_gain = 0;
};

template <typename Scalar>
PieceBound<Scalar> make_piece_bound(const Matrix3<Scalar>& a, Scalar h) {
    using std::exp;
    using std::sqrt;
    PieceBound<Scalar> b;
    b.velocity_row = a.row(0);
    b.acceleration_row = b.velocity_row * a;
    const Eigen::Matrix<Scalar, 1, 3> third = b.acceleration_row * a;
    b.remainder_gain = sqrt(third.squaredNorm()) * exp(sqrt(a.squaredNorm()) * h) * h * h * h / Scalar(6);
    return b;
}

/// Upper bound on max_{0 <= tau <= h} x(tau) from the quadratic Taylor part and its remainder (PieceBound),
/// widened by 1e-12 of the terms' size for rounding.
template <typename Scalar>
Scalar piece_maximum_bound(const Eigen::Matrix<Scalar, 3, 1>& xi, Scalar h, const PieceBound<Scalar>& bound) {
    using std::abs;
    using std::sqrt;
    const Scalar x0 = xi(0), v0 = bound.velocity_row.dot(xi), a0 = bound.acceleration_row.dot(xi);
    auto q = [&](Scalar tau) { return x0 + tau * (v0 + tau * a0 / Scalar(2)); };
    Scalar top = std::max(q(Scalar(0)), q(h));
    if (a0 < 0) {
        const Scalar vertex = -v0 / a0;
        if (vertex > 0 && vertex < h) top = std::max(top, q(vertex));
    }
    const Scalar size = abs(x0) + abs(v0) * h + abs(a0) * h * h;
    return top + bound.remainder_gain * sqrt(xi.squaredNorm()) + Scalar(1e-12) * size;
}

template <typename Scalar>
struct ContinuousMaximum {
    Scalar value = 0;        ///< largest x(t) found (the start value when nothing exceeds it)
    Scalar time = 0;         ///< where, in periods (0 when nothing exceeds the start value)
    long long periods = 0;   ///< periods scanned
    bool converged = false;  ///< the Lyapunov bound proved no later x(t) can exceed the maximum
    bool exceeded = false;   ///< value > ceiling was found and the scan stopped there
};

/// The exact maximum over t >= 0 of x(t) for the loop started from loop.initial_state: each ZOH
/// piece is checked at its end and, where the velocity changes sign from + to -, at its interior
/// maximum (interior_maximum), unless piece_maximum_bound shows that the piece cannot exceed
/// max(value, floor). After period j the bound |x(t)| <= kappa sqrt(e_j^T P e_j) for all
/// later t (P = M^T P M + I, the observability Gramian; kappa = max_s deviation_gain, +1e-6 for
/// rounding) stops the scan once it is <= max(value, floor); a value above `ceiling` stops it too.
/// Allocates two N-vectors, then nothing.
template <typename Scalar>
ContinuousMaximum<Scalar> continuous_maximum(const SampledPlant<Scalar>& plant, const ClosedLoop<Scalar>& loop,
                                             const DynamicMatrix<Scalar>& p, Scalar start_value, Scalar floor,
                                             long long max_periods,
                                             Scalar ceiling = std::numeric_limits<Scalar>::infinity()) {
    const Matrix3<Scalar>& a = plant.augmented_matrix();
    Scalar kappa = 0;
    for (int s = 0; s < plant.segment_count(); ++s) {
        kappa =
            std::max(kappa, deviation_gain(a, loop.segment_map[static_cast<std::size_t>(s)], plant.segment(s).length));
    }
    kappa *= Scalar(1) + Scalar(1e-6);                // rounding in P and in the series
    std::array<PieceBound<Scalar>, 2> piece_bound{};  // per segment (at most 2: sampled_plant.hpp)
    for (int s = 0; s < plant.segment_count(); ++s) {
        const auto& seg = plant.segment(s);
        piece_bound[static_cast<std::size_t>(s)] = make_piece_bound(a, seg.length / Scalar(seg.pieces));
    }

    ContinuousMaximum<Scalar> result;
    result.value = start_value;
    const Eigen::Index n = loop.transition.rows();
    // Rows k >= 2 of closed_loop.hpp's M are unit rows (shift_source); another realisation's M (the
    // collision loop of impulse_costs.hpp) is multiplied densely.
    bool shift_rows = true;
    for (Eigen::Index k = 2; shift_rows && k < n; ++k) {
        for (Eigen::Index l = 0; l < n; ++l) {
            const Scalar unit = l == shift_source(static_cast<int>(k)) ? Scalar(1) : Scalar(0);
            if (loop.transition(k, l) != unit) {
                shift_rows = false;
                break;
            }
        }
    }
    DynamicVector<Scalar> e = loop.initial_state;
    DynamicVector<Scalar> next(n);
    using Vec3 = Eigen::Matrix<Scalar, 3, 1>;
    for (long long j = 0; j < max_periods; ++j) {
        for (int s = 0; s < plant.segment_count(); ++s) {
            const auto& seg = plant.segment(s);
            const auto& r = loop.segment_map[static_cast<std::size_t>(s)];
            Vec3 xi = Vec3::Zero();  // R_s e
            for (Eigen::Index l = 0; l < n; ++l) {
                for (int i = 0; i < 3; ++i) xi(i) += r(i, l) * e(l);
            }
            const Scalar piece = seg.length / Scalar(seg.pieces);
            const Matrix3<Scalar>& step = seg.piece_exp;
            for (int q = 0; q < seg.pieces; ++q) {
                Vec3 end;
                for (int i = 0; i < 3; ++i) end(i) = step(i, 0) * xi(0) + step(i, 1) * xi(1) + step(i, 2) * xi(2);
                const Scalar t0 = Scalar(j) + seg.start + Scalar(q) * piece;
                if (end(0) > result.value) {
                    result.value = end(0);
                    result.time = t0 + piece;
                }
                if (xi(1) > 0 && end(1) < 0 &&
                    piece_maximum_bound(xi, piece, piece_bound[static_cast<std::size_t>(s)]) >
                        std::max(result.value, floor)) {
                    const auto [tau, x] = interior_maximum(a, xi, piece);
                    if (x > result.value) {
                        result.value = x;
                        result.time = t0 + tau;
                    }
                }
                xi = end;
            }
        }
        // e <- M e, written out.
        const Eigen::Index dense_rows = shift_rows ? std::min<Eigen::Index>(2, n) : n;
        for (Eigen::Index i = 0; i < dense_rows; ++i) {
            Scalar sum = 0;
            for (Eigen::Index l = 0; l < n; ++l) sum += loop.transition(i, l) * e(l);
            next(i) = sum;
        }
        for (Eigen::Index k = dense_rows; k < n; ++k) next(k) = e(shift_source(static_cast<int>(k)));
        e.swap(next);
        result.periods = j + 1;
        if (result.value > ceiling) {
            result.exceeded = true;
            break;
        }
        Scalar v = 0;  // e^T P e, P symmetric
        for (Eigen::Index l = 0; l < n; ++l) {
            Scalar pl = 0;
            for (Eigen::Index k = 0; k < l; ++k) pl += p(k, l) * e(k);
            v += (2 * pl + p(l, l) * e(l)) * e(l);
        }
        const Scalar bound = kappa * std::sqrt(std::max(v, Scalar(0)));
        if (bound <= std::max(result.value, floor)) {
            result.converged = true;
            break;
        }
    }
    return result;
}

}  // namespace detail

/// C_OV of the loop (plant, alpha, beta). Throws InvalidParameter for a tolerance outside (0, 1].
template <typename Scalar>
OvershootResultT<Scalar> overshoot(const SampledPlant<Scalar>& plant, Scalar alpha, Scalar beta,
                                   const OvershootOptions& options = {}) {
    detail::require_in_range("hapticopt::overshoot", "tolerance", options.tolerance, 0.0, true, 1.0,
                             "0 < tolerance <= 1");
    if (!(options.stop_above >= 0)) {
        throw InvalidParameter("hapticopt::overshoot", "stop_above", options.stop_above, ">= 0 (+inf: never)");
    }
    OvershootResultT<Scalar> result;
    result.time = std::numeric_limits<Scalar>::quiet_NaN();
    if (!loop_is_stable(plant, alpha, beta)) {
        result.value = std::numeric_limits<Scalar>::infinity();
        return result;
    }
    const ClosedLoop<Scalar> loop = make_closed_loop(plant, alpha, beta);
    // Lyapunov matrix P = sum_k (M^T)^k M^k (P = M^T P M + I) by the shift-structured solver.
    DynamicMatrix<Scalar> p;
    {
        const ShiftSteinSolver<Scalar> stein(loop.transition.topRows(2));
        if (stein.ok()) p = stein.observability_gramian();
    }
    // P >= I for a Schur-stable M; anything else is rounding at the stability boundary.
    bool p_ok = p.size() > 0;
    for (Eigen::Index k = 0; p_ok && k < p.size(); ++k) p_ok = std::isfinite(static_cast<double>(p.data()[k]));
    for (Eigen::Index k = 0; p_ok && k < p.rows(); ++k) p_ok = p(k, k) >= Scalar(1) - Scalar(1e-9);
    if (!p_ok) {
        result.value = std::numeric_limits<Scalar>::infinity();
        return result;
    }

    const Scalar x_inf = loop.final_position;
    // x - x_inf starts at -x_inf (t = 0); the scan stops once the bound is below the tolerance floor.
    const detail::ContinuousMaximum<Scalar> scan =
        detail::continuous_maximum(plant, loop, p, -x_inf, Scalar(options.tolerance) * x_inf, options.max_periods,
                                   Scalar(options.stop_above) * x_inf);
    result.periods = scan.periods;
    result.converged = scan.converged;
    result.stopped_above = scan.exceeded;
    const Scalar best = scan.value;
    const Scalar best_time = scan.time;
    result.value = best > 0 ? best / x_inf : Scalar(0);
    // The scan compares in absolute units (best > stop_above x_inf); the quotient can round to stop_above itself.
    if (result.stopped_above && !(result.value > Scalar(options.stop_above)))
        result.value = std::nextafter(Scalar(options.stop_above), std::numeric_limits<Scalar>::infinity());
    if (result.value > 0) result.time = best_time;
    result.within_tolerance = result.converged && result.value <= Scalar(options.tolerance);
    return result;
}

/// Convenience: C_OV at (gamma, delta, d) and (alpha, beta).
HAPTICOPT_FUNC OvershootResult overshoot(const NormalizedPlant& plant, const NormalizedGains& gains,
                                         const OvershootOptions& options = {})
#if HAPTICOPT_DEFINITIONS
{
    validate(gains, "hapticopt::overshoot");
    return overshoot(SampledPlant<double>(plant), gains.alpha, gains.beta, options);
}
#else
    ;
#endif

}  // namespace hapticopt
