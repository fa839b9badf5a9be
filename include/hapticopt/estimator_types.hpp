// SPDX-License-Identifier: Apache-2.0
// The wall's velocity estimator: its kinds, their checks and their difference equations (normalised units
// m = T = 1, Hulin et al. 2011 Table I). The loop with the estimator and what is computed on it:
// estimator_loop.hpp (the loop model), estimator_stability.hpp (Schur-Cohn on p_est, the stability report),
// estimator_costs.hpp (C_E0..2, C_OV), estimator_gradient.hpp (the gradient of C_E0..2), estimator_noise.hpp
// (the quantisation force noise), estimator_region.hpp (the main stable region), estimator_optimum.hpp
// (the optimum); velocity_estimator.hpp and hapticopt.hpp include them all.
//
// Force law: f_j = alpha y_j + beta v_j, y_j the measured position. The estimators:
//   backward  v_j = y_j - y_{j-1}                                   (the paper's; the default)
//   lowpass   v_j = lambda v_{j-1} + (1 - lambda)(y_j - y_{j-1}),   lambda = exp(-2 pi nu), nu = f_c T
//             (a first-order low-pass, pole at lambda = exp(-omega_c T), after the backward difference)
//   window    v_j = (y_j - y_{j-N}) / N,  N >= 1                    (difference over N periods)
// All are v_j = sum_i b_i y_{j-i} + sum_{k>=1} a_k v_{j-k} with sum_i b_i = 0, so v = 0 and f = alpha x_inf
// at rest and the step's final position stays x_inf = 1 / (alpha + gamma).
#pragma once

#include <cmath>
#include <cstddef>
#include <vector>

#include "errors.hpp"

namespace hapticopt {

enum class VelocityEstimatorKind { backward, lowpass, window };

/// How the wall estimates velocity from the sampled position (header comment).
struct VelocityEstimator {
    VelocityEstimatorKind kind = VelocityEstimatorKind::backward;
    double cutoff = 0;  ///< lowpass: normalised cutoff nu = f_c T, finite and > 0
    int window = 1;     ///< window: N, 1 <= N <= kMaxVelocityWindow

    static VelocityEstimator backward_difference() { return {}; }
    /// Throws InvalidParameter unless nu is finite and > 0.
    static VelocityEstimator low_pass(double nu);
    /// Throws InvalidParameter unless 1 <= n <= kMaxVelocityWindow.
    static VelocityEstimator moving_window(int n);
};

/// Longest window accepted: 1000 periods (1 s at 1 kHz; the loop state grows by one per period).
inline constexpr int kMaxVelocityWindow = 1000;

/// Throws InvalidParameter (message starting with `function`) for a low-pass cutoff that is not finite and
/// > 0, or a window outside 1 .. kMaxVelocityWindow.
inline void validate(const VelocityEstimator& e, const char* function = "hapticopt::validate") {
    if (e.kind == VelocityEstimatorKind::lowpass) {
        detail::require_in_range(function, "cutoff", e.cutoff, 0.0, true, HUGE_VAL,
                                 "finite and > 0 (normalised cutoff nu = f_c T)");
    } else if (e.kind == VelocityEstimatorKind::window) {
        detail::require_in_range(function, "window", e.window, 1.0, false, kMaxVelocityWindow,
                                 "1 <= N <= 1000 periods");
    }
}

inline VelocityEstimator VelocityEstimator::low_pass(double nu) {
    VelocityEstimator e;
    e.kind = VelocityEstimatorKind::lowpass;
    e.cutoff = nu;
    validate(e, "hapticopt::VelocityEstimator::low_pass");
    return e;
}

inline VelocityEstimator VelocityEstimator::moving_window(int n) {
    VelocityEstimator e;
    e.kind = VelocityEstimatorKind::window;
    e.window = n;
    validate(e, "hapticopt::VelocityEstimator::moving_window");
    return e;
}

/// The estimator as a difference equation v_j = sum_i b[i] y_{j-i} + sum_k a[k-1] v_{j-k} (header).
template <typename Scalar>
struct EstimatorCoefficients {
    std::vector<Scalar> b;  ///< nb >= 2 coefficients on y_j, y_{j-1}, ...
    std::vector<Scalar> a;  ///< na coefficients on v_{j-1}, ... (empty for FIR)
};

template <typename Scalar>
EstimatorCoefficients<Scalar> estimator_coefficients(const VelocityEstimator& e) {
    EstimatorCoefficients<Scalar> c;
    switch (e.kind) {
        case VelocityEstimatorKind::backward:
            c.b = {Scalar(1), Scalar(-1)};
            break;
        case VelocityEstimatorKind::lowpass: {
            using std::exp;
            const Scalar pi = Scalar(3.141592653589793238462643383279502884L);
            const Scalar lambda = exp(-Scalar(2) * pi * Scalar(e.cutoff));
            c.b = {Scalar(1) - lambda, lambda - Scalar(1)};
            c.a = {lambda};
            break;
        }
        case VelocityEstimatorKind::window: {
            c.b.assign(static_cast<std::size_t>(e.window) + 1, Scalar(0));
            c.b.front() = Scalar(1) / Scalar(e.window);
            c.b.back() = -Scalar(1) / Scalar(e.window);
            break;
        }
    }
    return c;
}

}  // namespace hapticopt
