// SPDX-License-Identifier: Apache-2.0
#include "scene/force_limiter.hpp"

#include <cmath>
#include <stdexcept>

#include "common/number_text.hpp"

namespace hapticd {

namespace {

// f <- min(max(f, -limit), limit) for a finite f and limit > 0; true when it changed f. The one saturation of the
// force on the real-time path (force_limiter.hpp).
[[nodiscard]] inline bool saturate(double& f, double limit) noexcept {
    const double clamped = f > limit ? limit : f < -limit ? -limit : f;
    const bool changed = clamped != f;
    f = clamped;
    return changed;
}

}  // namespace

double default_max_force_rate(double max_force, double period) noexcept {
    const double full_scale = period / kMaxStepFraction > kFullScaleTime ? period / kMaxStepFraction : kFullScaleTime;
    return max_force / full_scale;
}

std::string max_force_rate_error(double rate, double max_force, double period) {
    const double upper = max_force / period;
    if (std::isfinite(rate) && rate > 0.0 && rate * period < max_force) return "";
    return "--max-force-rate = " + short_number(rate) +
           " N/s is invalid: its step per tick (x T = " + short_number(period) + " s) is " +
           short_number(rate * period) + " N, not below the device's max_force = " + short_number(max_force) +
           " N, so one tick could still step the force by the whole limit; accepted range: > 0 and < max_force / T = " +
           short_number(upper) + " N/s, or 0 for the default (max_force per " + short_number(kFullScaleTime * 1e3) +
           " ms: " + short_number(default_max_force_rate(max_force, period)) + " N/s)";
}

ForceLimiter::ForceLimiter(double max_force, double max_force_rate, double period, std::size_t axes)
    : max_force_(max_force), max_step_(max_force_rate * period), axes_(axes), stop_ticks_(0) {
    if (!(period > 0.0) || !std::isfinite(period)) {
        throw std::invalid_argument("ForceLimiter: period = " + short_number(period) +
                                    " s is invalid; accepted range: finite, > 0 s");
    }
    if (!(max_force > 0.0) || !std::isfinite(max_force)) {
        throw std::invalid_argument("ForceLimiter: max_force = " + short_number(max_force) +
                                    " N is invalid; accepted range: finite, > 0 N");
    }
    if (axes < 1 || axes > 3) {
        throw std::invalid_argument("ForceLimiter: axes = " + std::to_string(axes) +
                                    " is invalid; accepted range: 1 .. 3");
    }
    const std::string error = max_force_rate_error(max_force_rate, max_force, period);
    if (!error.empty()) throw std::invalid_argument(error);
    // 1e-9: a step a rounding below max_force / n still counts n steps (the spare tick takes the rest).
    stop_ticks_ = static_cast<std::uint64_t>(std::ceil(max_force / max_step_ - 1e-9)) + 1U;
}

AxisVector ForceLimiter::step(const AxisVector& target) noexcept {
    double f[3] = {target[0], axes_ > 1 ? target[1] : 0.0, axes_ > 2 ? target[2] : 0.0};
    const double m = max_force_;
    const bool saturated = saturate(f[0], m) | saturate(f[1], m) | saturate(f[2], m);  // no short circuit
    stats_.saturated_ticks += saturated ? 1U : 0U;
    const double c0 = std::fabs(f[0] - last_[0]), c1 = std::fabs(f[1] - last_[1]), c2 = std::fabs(f[2] - last_[2]);
    const double c01 = c0 > c1 ? c0 : c1;
    double largest = c01 > c2 ? c01 : c2;
    if (largest > max_step_) {
        const double scale = max_step_ / largest;
        for (std::size_t a = 0; a < 3; ++a) f[a] = last_[a] + scale * (f[a] - last_[a]);
        largest = max_step_;
        ++stats_.rate_limited_ticks;
    }
    if (largest > stats_.largest_step) stats_.largest_step = largest;
    last_ = {f[0], f[1], f[2]};
    return last_;
}

}  // namespace hapticd
