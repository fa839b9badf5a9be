// SPDX-License-Identifier: Apache-2.0
// The loop's velocity estimate of every axis (common/velocity_estimator_spec.hpp), computed once per tick from the
// sampled position: the same difference equation that hapticopt::make_estimator_loop analyses
// (include/hapticopt/estimator_types.hpp), in physical units:
//   backward  v_j = (x_j - x_{j-1}) / T
//   lowpass   v_j = l v_{j-1} + (1 - l)(x_j - x_{j-1}) / T,  l = exp(-2 pi F T)
//   window    v_j = (x_j - x_{j-N}) / (N T)
// The first update after construction or reset() takes every earlier position equal to its own and every earlier
// estimate zero (v = 0), as the analysis's step response starts from rest. The window's N past positions live in a
// ring allocated by the constructor; update() does not allocate, lock or throw.
#pragma once

#include <cmath>
#include <cstddef>
#include <numbers>
#include <stdexcept>
#include <string>
#include <vector>

#include "common/axis_vector.hpp"
#include "common/velocity_estimator_spec.hpp"

namespace hapticd {

class VelocityFilter {
  public:
    // Throws std::invalid_argument for a period that is not finite and > 0, a cutoff that is not finite and > 0, or
    // a window outside 1 .. kMaxLoopVelocityWindow.
    VelocityFilter(const VelocityEstimatorSpec& spec, double period) : spec_(spec), inverse_period_(1.0 / period) {
        if (!std::isfinite(period) || !(period > 0.0)) {
            throw std::invalid_argument("VelocityFilter: period = " + std::to_string(period) +
                                        " is invalid; accepted range: finite, > 0 s");
        }
        if (spec.kind == hapticopt::VelocityEstimatorKind::lowpass &&
            (!std::isfinite(spec.cutoff_hz) || !(spec.cutoff_hz > 0.0))) {
            throw std::invalid_argument("VelocityFilter: cutoff = " + std::to_string(spec.cutoff_hz) +
                                        " Hz is invalid; accepted range: finite, > 0 Hz");
        }
        if (spec.kind == hapticopt::VelocityEstimatorKind::window &&
            (spec.window < 1 || spec.window > kMaxLoopVelocityWindow)) {
            throw std::invalid_argument("VelocityFilter: window = " + std::to_string(spec.window) +
                                        " is invalid; accepted range: 1 .. " + std::to_string(kMaxLoopVelocityWindow));
        }
        lambda_ = spec.kind == hapticopt::VelocityEstimatorKind::lowpass
                      ? std::exp(-2.0 * std::numbers::pi * spec.cutoff_hz * period)
                      : 0.0;
        const std::size_t n =
            spec.kind == hapticopt::VelocityEstimatorKind::window ? static_cast<std::size_t>(spec.window) : 1;
        history_.assign(n, AxisVector{});
        window_scale_ = inverse_period_ / static_cast<double>(n);
    }

    // The estimate for the sampled position x_j (every axis; unused axes cost three flops).
    const AxisVector& update(const AxisVector& x) noexcept {
        if (!primed_) {
            for (auto& h : history_) h = x;
            velocity_ = AxisVector{};
            primed_ = true;
            return velocity_;
        }
        AxisVector& oldest = history_[head_];  // x_{j-1} (backward, lowpass) or x_{j-N} (window)
        switch (spec_.kind) {
            case hapticopt::VelocityEstimatorKind::backward:
                for (std::size_t a = 0; a < kMaxAxes; ++a) velocity_[a] = (x[a] - oldest[a]) * inverse_period_;
                break;
            case hapticopt::VelocityEstimatorKind::lowpass:
                for (std::size_t a = 0; a < kMaxAxes; ++a) {
                    velocity_[a] = lambda_ * velocity_[a] + (1.0 - lambda_) * ((x[a] - oldest[a]) * inverse_period_);
                }
                break;
            case hapticopt::VelocityEstimatorKind::window:
                for (std::size_t a = 0; a < kMaxAxes; ++a) velocity_[a] = (x[a] - oldest[a]) * window_scale_;
                break;
        }
        oldest = x;
        head_ = head_ + 1 == history_.size() ? 0 : head_ + 1;
        return velocity_;
    }

    [[nodiscard]] const AxisVector& velocity() const noexcept { return velocity_; }
    [[nodiscard]] const VelocityEstimatorSpec& spec() const noexcept { return spec_; }
    // The next update() starts from rest again (v = 0).
    void reset() noexcept {
        primed_ = false;
        head_ = 0;
        velocity_ = AxisVector{};
    }

  private:
    VelocityEstimatorSpec spec_;
    double inverse_period_;
    double lambda_ = 0.0;
    double window_scale_ = 0.0;
    std::vector<AxisVector> history_;  // ring: x_{j-1} .. x_{j-N} (one entry unless a window)
    std::size_t head_ = 0;             // the oldest entry
    AxisVector velocity_{};
    bool primed_ = false;
};

}  // namespace hapticd
