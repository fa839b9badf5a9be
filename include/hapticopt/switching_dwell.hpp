// SPDX-License-Identifier: Apache-2.0
// A minimum dwell time for switching among stable loops: how often the wall's gains (and the plant) may change
// with every switching sequence still exponentially stable.
//
// Modes: Schur-stable matrices A_1 .. A_m acting on one state (switching_loop.hpp builds them for the rendered
// loop: each pair of gains with each plant of a set).
//
// Power bound (Lyapunov, for one mode). For a rate lambda with rho(A_i) < lambda < 1, P_i solves the Stein equation
//   B^T P_i B - P_i = -I,   B = A_i / lambda.
// Then V(x) = x^T P_i x satisfies V(B x) = V(x) - |x|^2 <= V(x), so V(A_i^n x) <= lambda^(2n) V(x) and
//   ||A_i^n||_2 <= M_i lambda^n  for every n >= 0,   M_i = sqrt(cond(P_i)) = sqrt(lambda_max(P_i) / lambda_min(P_i)).
// The computed P_i is verified a posteriori: the smallest eigenvalue of P_i - B^T P_i B must exceed the rounding
// allowance 8 N eps (1 + ||B||^2) ||P_i|| of forming it, and lambda_min(P_i) must be > 0; only then is M_i used.
//
// Theorem (average dwell time; Hespanha & Morse, CDC 1999, Theorem 1, in discrete time as in Zhai, Hu, Yasuda &
// Michel, Int. J. Systems Science 32(8), 2001). Let ||A_i^n|| <= M lambda^n for every mode i and n >= 0 (M >= 1,
// lambda < 1), and let the switching signal have at most N_0 + t / tau_a switches in any t ticks. Then every
// trajectory of x_{t+1} = A_{sigma(t)} x_t obeys
//   ||x_t|| <= M^(1 + N_0) (M^(1 / tau_a) lambda)^t ||x_0||,
// exponentially stable whenever tau_a > ln M / (-ln lambda). (Proof: t ticks with k switches are k + 1 blocks of
// one mode each; the product of the blocks' norms is at most M^(k + 1) lambda^t.) The dwell-time case (Morse, IEEE
// TAC 41(10), 1996): consecutive switches at least N_d ticks apart give k <= 1 + t / N_d; N_d is the smallest
// integer with M lambda^(N_d) < 1, i.e. N_d > ln M / (-ln lambda).
//
// minimum_dwell() takes M(lambda) = max_i M_i(lambda) on a grid of rates between the largest spectral radius and 1
// and returns the smallest N_d over the grid with its rate and constant. The bound M_i is conservative (the true
// sup_n ||A_i^n|| lambda^-n is smaller; tests/beyond/test_switching_dwell.cpp computes it from the powers), so N_d
// is sufficient, not necessary. What is proven is exactly the family given: a plant or gain outside it is not
// covered, and a continuous drift of the plant between the listed ones is not a switch among them.
// A tighter certificate from the powers themselves (power_dwell): if ||A_i^n||_2 <= q < 1 for every mode and every
// n in [N, 2N), then every n >= N is a sum of lengths in [N, 2N) (floor(n / N) - 1 of N and one of N + (n mod N)),
// so ||A_i^n|| <= q^floor(n / N) <= q^(n / 2N) for every n >= N: each block of a switching sequence whose switches are
// at least N ticks apart contracts by at least q, and ||x_t|| <= M_s^2 q^(t / 2N - 2) ||x_0|| with
// M_s = max over modes and n < N of ||A_i^n|| (the first and the last block may be shorter). Finite: only the
// powers up to 2N - 1 are computed, each bounded by its Frobenius norm (>= the 2-norm) plus the rounding of the
// product A P_{n-1} accumulated over n steps, n N eps ||A||_F max_k ||A^k||_F^2.
// Cost: one complex Schur form per mode (~25 N^3) and per rate one triangular Stein solve and two symmetric
// eigenproblems per mode (~15 N^3). Not for the real-time loop (allocates). The functions are HAPTICOPT_DEFERRED
// (config.hpp): their Eigen decompositions are instantiated only where they are called.
#pragma once

#include <Eigen/Core>
#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <complex>
#include <limits>
#include <string>
#include <vector>

#include "closed_loop.hpp"
#include "config.hpp"
#include "errors.hpp"
#include "stein_equation.hpp"

namespace hapticopt {

/// ||A^n||_2 <= constant * rate^n for every n >= 0, when `valid`.
struct PowerBound {
    bool valid = false;
    double rate = 1;
    double constant = HUGE_VAL;
};

/// The complex Schur form A = U T U^H of one mode, computed once for every rate.
struct ModeSchurForm {
    ComplexMatrix<double> unitary;
    ComplexMatrix<double> triangular;
    DynamicMatrix<double> matrix;
    double spectral_radius = 0;
};

HAPTICOPT_DEFERRED inline ModeSchurForm mode_schur_form(const DynamicMatrix<double>& a) {
    constexpr const char* kFunction = "hapticopt::mode_schur_form";
    if (a.rows() != a.cols() || a.rows() == 0) {
        throw InvalidParameter(kFunction, "rows", static_cast<double>(a.rows()),
                               "a square, non-empty matrix (rows = columns >= 1)");
    }
    for (Eigen::Index i = 0; i < a.size(); ++i) detail::require_finite(kFunction, "matrix entry", a.data()[i]);
    const Eigen::ComplexSchur<ComplexMatrix<double>> schur(a.cast<std::complex<double>>());
    ModeSchurForm f;
    f.unitary = schur.matrixU();
    f.triangular = schur.matrixT();
    f.matrix = a;
    for (Eigen::Index i = 0; i < a.rows(); ++i)
        f.spectral_radius = std::max(f.spectral_radius, std::abs(f.triangular(i, i)));
    return f;
}

/// The Lyapunov power bound of the header comment at `rate`: invalid unless the mode's spectral radius is below
/// the rate and the computed P passes the a-posteriori check.
HAPTICOPT_DEFERRED inline PowerBound lyapunov_power_bound(const ModeSchurForm& mode, double rate) {
    PowerBound bound;
    bound.rate = rate;
    if (!(rate > mode.spectral_radius) || !(rate <= 1.0)) return bound;
    const Eigen::Index n = mode.matrix.rows();
    // Y = S^H Y S + I with S = T / rate; X = J Y J solves X = T' X T'^H + I with T' = J S^H J (upper triangular).
    const ComplexMatrix<double> s = mode.triangular / rate;
    const ComplexMatrix<double> t_flipped = flip<double>(ComplexMatrix<double>(s.adjoint()));
    const ComplexMatrix<double> x = solve_triangular_stein<double>(t_flipped, ComplexMatrix<double>::Identity(n, n));
    const ComplexMatrix<double> y = flip<double>(x);
    DynamicMatrix<double> p = (mode.unitary * y * mode.unitary.adjoint()).real();
    p = (0.5 * (p + p.transpose())).eval();
    if (!p.allFinite()) return bound;
    const DynamicMatrix<double> b = mode.matrix / rate;
    DynamicMatrix<double> residual = p - b.transpose() * p * b;
    residual = (0.5 * (residual + residual.transpose())).eval();
    const Eigen::SelfAdjointEigenSolver<DynamicMatrix<double>> ep(p, Eigen::EigenvaluesOnly);
    const Eigen::SelfAdjointEigenSolver<DynamicMatrix<double>> er(residual, Eigen::EigenvaluesOnly);
    if (ep.info() != Eigen::Success || er.info() != Eigen::Success) return bound;
    const double p_min = ep.eigenvalues().minCoeff();
    const double p_max = ep.eigenvalues().maxCoeff();
    const double b_norm = b.operatorNorm();
    const double allowance =
        8.0 * static_cast<double>(n) * std::numeric_limits<double>::epsilon() * (1.0 + b_norm * b_norm) * p_max;
    if (!(p_min > 0.0) || !(er.eigenvalues().minCoeff() > allowance)) return bound;
    bound.valid = true;
    bound.constant = std::sqrt(p_max / p_min);
    return bound;
}

/// The dwell certificate of the header comment for a family of modes.
struct DwellCertificate {
    bool certified = false;      ///< every mode Schur-stable and a finite dwell found
    int dwell_ticks = 0;         ///< N_d: switches at least this many ticks apart are exponentially stable
    double rate = 1;             ///< lambda: ||A_i^n|| <= constant lambda^n for every mode
    double constant = HUGE_VAL;  ///< M
    double switched_rate = 1;    ///< M^(1 / N_d) lambda < 1: the decay per tick under the dwell
    double largest_spectral_radius = 0;
    int unstable_mode = -1;  ///< a mode with spectral radius >= 1, when not certified for that reason
};

/// ||x_t|| / ||x_0|| <= M^(1 + N_0) (M^(1/tau_a) lambda)^t, written for t ticks with `switches` switches:
/// M^(switches + 1) lambda^t (the proof's product of block norms).
inline double switched_norm_bound(const DwellCertificate& c, int ticks, int switches) {
    return std::pow(c.constant, switches + 1) * std::pow(c.rate, ticks);
}

/// The smallest dwell over `rate_samples` rates spread between the largest spectral radius and 1 (header comment).
/// Throws InvalidParameter for an empty family, matrices of different sizes or non-finite entries, or fewer than 2
/// rate samples.
HAPTICOPT_DEFERRED inline DwellCertificate minimum_dwell(const std::vector<DynamicMatrix<double>>& modes,
                                                         int rate_samples = 48) {
    constexpr const char* kFunction = "hapticopt::minimum_dwell";
    if (modes.empty()) throw InvalidParameter(kFunction, "modes", 0.0, "at least one matrix");
    detail::require_in_range(kFunction, "rate_samples", rate_samples, 2.0, false, 1e6, "2 <= rate_samples <= 1e6");
    std::vector<ModeSchurForm> forms;
    forms.reserve(modes.size());
    DwellCertificate best;
    for (std::size_t i = 0; i < modes.size(); ++i) {
        if (modes[i].rows() != modes.front().rows() || modes[i].cols() != modes.front().cols()) {
            throw InvalidParameter(kFunction, "mode size", static_cast<double>(modes[i].rows()),
                                   "every mode of the first mode's size (" + std::to_string(modes.front().rows()) +
                                       "): the modes act on one state");
        }
        forms.push_back(mode_schur_form(modes[i]));
        if (forms.back().spectral_radius >= best.largest_spectral_radius) {
            best.largest_spectral_radius = forms.back().spectral_radius;
            if (!(forms.back().spectral_radius < 1.0)) best.unstable_mode = static_cast<int>(i);
        }
    }
    if (best.unstable_mode >= 0) return best;
    const double rho = best.largest_spectral_radius;
    for (int k = 1; k < rate_samples; ++k) {
        // Rates spread geometrically in the gap 1 - lambda: the best one lies close to rho when M grows slowly.
        const double gap = (1.0 - rho) * std::pow(1e-3, 1.0 - static_cast<double>(k) / rate_samples);
        const double rate = 1.0 - gap;
        if (!(rate > rho)) continue;
        double constant = 1.0;
        bool valid = true;
        for (const ModeSchurForm& f : forms) {
            const PowerBound b = lyapunov_power_bound(f, rate);
            if (!b.valid) {
                valid = false;
                break;
            }
            constant = std::max(constant, b.constant);
        }
        if (!valid) continue;
        const double ticks = std::floor(std::log(constant) / -std::log(rate)) + 1.0;
        if (!(ticks < 1e9)) continue;
        if (!best.certified || ticks < best.dwell_ticks) {
            best.certified = true;
            best.dwell_ticks = static_cast<int>(ticks);
            best.rate = rate;
            best.constant = constant;
            best.switched_rate = std::pow(constant, 1.0 / ticks) * rate;
        }
    }
    return best;
}

/// The power certificate of the header comment.
struct PowerDwellCertificate {
    bool certified = false;
    int dwell_ticks = 0;     ///< N: ||A_i^n|| <= contraction for every mode and n in [N, 2N)
    double contraction = 1;  ///< q < 1
    double short_block = 1;  ///< M_s: max ||A_i^n|| over n < N (n = 0 gives 1)
    int horizon = 0;         ///< the largest power computed
};

/// The smallest N <= max_ticks / 2 with every mode's ||A^n||_2 below 1 over [N, 2N) (header comment), from the
/// powers up to `max_ticks`. Not certified when no such N is found within the horizon. Throws InvalidParameter as
/// minimum_dwell, or for max_ticks outside 2 .. 1e7.
HAPTICOPT_DEFERRED inline PowerDwellCertificate power_dwell(const std::vector<DynamicMatrix<double>>& modes,
                                                            int max_ticks) {
    constexpr const char* kFunction = "hapticopt::power_dwell";
    if (modes.empty()) throw InvalidParameter(kFunction, "modes", 0.0, "at least one matrix");
    detail::require_in_range(kFunction, "max_ticks", max_ticks, 2.0, false, 1e7, "2 <= max_ticks <= 1e7");
    const Eigen::Index size = modes.front().rows();
    std::vector<double> largest(static_cast<std::size_t>(max_ticks) + 1, 0.0);  // max over modes of the bound
    largest[0] = 1.0;
    for (const DynamicMatrix<double>& a : modes) {
        if (a.rows() != size || a.cols() != size || size == 0) {
            throw InvalidParameter(kFunction, "mode size", static_cast<double>(a.rows()),
                                   "every mode square and of the first mode's size (" + std::to_string(size) + ")");
        }
        for (Eigen::Index i = 0; i < a.size(); ++i) detail::require_finite(kFunction, "matrix entry", a.data()[i]);
        const double a_norm = a.norm();
        const double unit = std::numeric_limits<double>::epsilon() * static_cast<double>(size) * a_norm;
        DynamicMatrix<double> power = a;
        double seen = 1.0;  // max_k ||A^k||_F so far (k = 0: ||I||_2 = 1)
        double rounding = 0.0;
        for (int n = 1; n <= max_ticks; ++n) {
            const double f = power.norm();
            if (!std::isfinite(f)) {
                largest[static_cast<std::size_t>(n)] = HUGE_VAL;
                break;
            }
            seen = std::max(seen, f);
            rounding += unit * seen * seen;
            largest[static_cast<std::size_t>(n)] = std::max(largest[static_cast<std::size_t>(n)], f + rounding);
            if (n < max_ticks) power = (a * power).eval();
        }
    }
    PowerDwellCertificate c;
    c.horizon = max_ticks;
    // next_bad[n]: the smallest k >= n with a bound >= 1 (max_ticks + 1 when none).
    std::vector<int> next_bad(static_cast<std::size_t>(max_ticks) + 2, max_ticks + 1);
    for (int n = max_ticks; n >= 0; --n) {
        next_bad[static_cast<std::size_t>(n)] =
            largest[static_cast<std::size_t>(n)] >= 1.0 ? n : next_bad[static_cast<std::size_t>(n) + 1];
    }
    double short_block = 1.0;
    for (int n = 1; 2 * n - 1 <= max_ticks; ++n) {
        if (next_bad[static_cast<std::size_t>(n)] > 2 * n - 1) {
            c.certified = true;
            c.dwell_ticks = n;
            c.short_block = short_block;
            c.contraction = 0.0;
            for (int k = n; k <= 2 * n - 1; ++k)
                c.contraction = std::max(c.contraction, largest[static_cast<std::size_t>(k)]);
            return c;
        }
        short_block = std::max(short_block, largest[static_cast<std::size_t>(n)]);
    }
    return c;
}

}  // namespace hapticopt
