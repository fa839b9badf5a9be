// SPDX-License-Identifier: Apache-2.0
// How the loop estimates the handle's velocity from the sampled position, in the device's physical terms (the
// profile key `velocity_estimator`, docs/velocity-estimation.md). The same three estimators as
// hapticopt::VelocityEstimator (include/hapticopt/estimator_types.hpp), whose kind it uses; the tuning checks
// every scene with them:
//   backward      v_j = (x_j - x_{j-1}) / T                                    (the paper's; the default)
//   lowpass:F Hz  v_j = l v_{j-1} + (1 - l)(x_j - x_{j-1}) / T, l = exp(-2 pi F T)  (normalised cutoff nu = F T)
//   window:N      v_j = (x_j - x_{j-N}) / (N T), 1 <= N <= kMaxLoopVelocityWindow
// The first tick takes the earlier positions equal to its own (v = 0).
#pragma once

#include <optional>
#include <string>
#include <string_view>

#include <hapticopt/estimator_types.hpp>

namespace hapticd {

// Longest window the loop accepts, periods: each object check solves an eigenproblem of size ~3 (d + 3 + N).
inline constexpr int kMaxLoopVelocityWindow = 50;

struct VelocityEstimatorSpec {
    hapticopt::VelocityEstimatorKind kind = hapticopt::VelocityEstimatorKind::backward;
    double cutoff_hz = 0.0;  // LowPass: F, Hz, finite and > 0 (at most the Nyquist frequency 1 / (2 T): options check)
    int window = 1;          // Window: N

    [[nodiscard]] bool is_backward() const noexcept { return kind == hapticopt::VelocityEstimatorKind::backward; }
    friend bool operator==(const VelocityEstimatorSpec&, const VelocityEstimatorSpec&) = default;
};

// "backward", "lowpass:50Hz" or "window:15". On error returns std::nullopt and sets `error` to a message naming the
// value and the accepted forms.
std::optional<VelocityEstimatorSpec> parse_velocity_estimator(std::string_view text, std::string& error);
// The text parse_velocity_estimator reads back ("lowpass:50Hz": the cutoff with up to 17 significant digits).
std::string to_string(const VelocityEstimatorSpec& spec);

}  // namespace hapticd
