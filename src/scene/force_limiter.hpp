// SPDX-License-Identifier: Apache-2.0
// The last stage before the device (docs/hapticd.md, "Force limits") and the only place on the real-time path that
// saturates or rate-limits the force (the config walls' scene and the clients' objects compute and check their sums
// and leave both to it; passivity control bounds only its own damped force; src/daemon/tick.cpp calls it): every
// force the loop writes is saturated
// per axis to the device's max_force, and its change from the force written the tick before is limited to
// max_force_rate T (infinity norm, the change scaled as a whole so its direction is kept). It runs on the
// force about to be written, after the scene, the clients' objects, the delay buffer and passivity control,
// so no path reaches the device around it: a departure whose objects are cut, a ramp, a stop. The one
// exception is a fault (device error, non-finite value, watchdog, fatal signal): zero force at once (zero()).
//
// A stop (SIGINT/SIGTERM, the end of --duration, of a replay) is not a fault: the loop runs stop_ticks() more
// ticks with zero as the target and the limiter brings the force there; the last of them writes exactly zero.
//
// The default rate (default_max_force_rate) takes the whole range of one axis, max_force, in
// kFullScaleTime = 4 ms, and never more than kMaxStepFraction = 1/4 of max_force in one tick: at 1 kHz a
// step of at most max_force / 4 per tick. Above the largest step of every regime the analysis certifies on
// the shipped profiles (the Falcon's encoder chatter with the backward difference: 1.70 N of 9 N; the paper's
// 1 N step: 0.75 N), so the limiter does not act there (docs/hapticd.md, "Force limits"). A rate whose step
// max_force_rate T is max_force or more limits nothing a saturated force could do and is refused
// (max_force_rate_error).
// No allocation, lock, exception or I/O in step() and zero().
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>

#include "common/axis_vector.hpp"

namespace hapticd {

inline constexpr double kFullScaleTime = 0.004;   // s: the default rate's time for a step of max_force
inline constexpr double kMaxStepFraction = 0.25;  // the default rate's largest step per tick, of max_force

// max_force / max(kFullScaleTime, T / kMaxStepFraction), N/s.
[[nodiscard]] double default_max_force_rate(double max_force, double period) noexcept;

// Empty when 0 < rate and rate T < max_force (finite); otherwise the message, naming --max-force-rate, the
// step it gives and the accepted range.
[[nodiscard]] std::string max_force_rate_error(double rate, double max_force, double period);

struct ForceLimiterStats {
    std::uint64_t rate_limited_ticks = 0;  // ticks whose change was scaled down to max_step
    std::uint64_t saturated_ticks = 0;     // ticks with an axis saturated to max_force
    double largest_step = 0.0;             // the largest change written, N (infinity norm; zero() not counted)
};

class ForceLimiter {
  public:
    // Throws std::invalid_argument with max_force_rate_error's message, or naming max_force / the period.
    ForceLimiter(double max_force, double max_force_rate, double period, std::size_t axes);

    // The force to write for `target` (axes beyond axes() are zero). Real-time safe.
    AxisVector step(const AxisVector& target) noexcept;
    // A fault: the force written is zero at once, whatever was written before.
    void zero() noexcept { last_ = AxisVector{}; }

    [[nodiscard]] const AxisVector& last() const noexcept { return last_; }
    [[nodiscard]] double max_force() const noexcept { return max_force_; }
    [[nodiscard]] double max_step() const noexcept { return max_step_; }
    // Ticks of a stop: enough for steps of max_step to bring any saturated force to zero, with one to spare for
    // rounding: ceil(max_force / max_step) + 1 (>= 3, since max_step < max_force).
    [[nodiscard]] std::uint64_t stop_ticks() const noexcept { return stop_ticks_; }
    [[nodiscard]] const ForceLimiterStats& stats() const noexcept { return stats_; }

  private:
    double max_force_;
    double max_step_;
    std::size_t axes_;
    std::uint64_t stop_ticks_;
    AxisVector last_{};
    ForceLimiterStats stats_;
};

}  // namespace hapticd
