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

AxisVector ForceLimiter::step(const AxisVector& target, const LawChange& change) noexcept {
    double g[3] = {target[0], axes_ > 1 ? target[1] : 0.0, axes_ > 2 ? target[2] : 0.0};
    const double m = max_force_;
    const bool saturated = saturate(g[0], m) | saturate(g[1], m) | saturate(g[2], m);  // no short circuit
    stats_.saturated_ticks += saturated ? 1U : 0U;
    double o[3];
    for (std::size_t a = 0; a < 3; ++a) {
        o[a] = change.whole ? last_[a] - g[a] : offset_[a] - (a < axes_ ? change.shift[a] : 0.0);
    }
    // A non-finite shift (the scene's sums are checked finite, its change is not) counts as a whole change.
    if (!std::isfinite(o[0]) || !std::isfinite(o[1]) || !std::isfinite(o[2])) {
        for (std::size_t a = 0; a < 3; ++a) o[a] = last_[a] - g[a];
    }
    const double o0 = std::fabs(o[0]), o1 = std::fabs(o[1]), o2 = std::fabs(o[2]);
    const double o01 = o0 > o1 ? o0 : o1;
    const double held = o01 > o2 ? o01 : o2;
    const double keep = held > max_step_ ? 1.0 - max_step_ / held : 0.0;  // shrink(o): ||o||_inf less max_step
    double f[3];
    const bool changed = change.whole || change.shift != AxisVector{};
    for (std::size_t a = 0; a < 3; ++a) {
        o[a] *= keep;
        f[a] = g[a] + o[a];
        if (changed) {  // between the force written last and the law's, per axis; o what that leaves
            const double lo = last_[a] < g[a] ? last_[a] : g[a], hi = last_[a] < g[a] ? g[a] : last_[a];
            f[a] = f[a] < lo ? lo : f[a] > hi ? hi : f[a];
            o[a] = f[a] - g[a];
        }
    }
    stats_.rate_limited_ticks += o[0] != 0.0 || o[1] != 0.0 || o[2] != 0.0 ? 1U : 0U;
    // Without a change g + o may lie beyond the limit (g moved, o decays on its own).
    (void)(saturate(f[0], m) | saturate(f[1], m) | saturate(f[2], m));
    const double c0 = std::fabs(f[0] - last_[0]), c1 = std::fabs(f[1] - last_[1]), c2 = std::fabs(f[2] - last_[2]);
    const double c01 = c0 > c1 ? c0 : c1;
    const double largest = c01 > c2 ? c01 : c2;
    if (largest > stats_.largest_step) stats_.largest_step = largest;
    offset_ = {o[0], o[1], o[2]};
    last_ = {f[0], f[1], f[2]};
    return last_;
}

}  // namespace hapticd
