// SPDX-License-Identifier: Apache-2.0
// The last stage before the device (docs/hapticd.md, "Force limits") and the only place on the real-time path that
// saturates or rate-limits the force (the config walls' scene and the clients' objects compute and check their sums
// and leave both to it; passivity control bounds only its own damped force; src/daemon/tick.cpp calls it). It runs
// on the force about to be written, after the scene, the clients' objects, the delay buffer and passivity control,
// so no path reaches the device around it. Per tick, with g the law's force saturated per axis to max_force, s =
// max_force_rate T, and o the offset the written force keeps from g:
//   o_j = shrink(o_{j-1})              a tick the scene did not change
//   o_j = shrink(o_{j-1} - J_j)        J_j: the change of the law the scene made this tick (LawChange::shift)
//   o_j = shrink(w_{j-1} - g_j)        a tick whose law changed as a whole (LawChange::whole)
//   w_j = sat(g_j + o_j)               the force written; on a tick the scene changed, per axis between w_{j-1}
//                                      and g_j instead (o_j then what that leaves: w_j - g_j)
// shrink(z) = z (1 - s / ||z||_inf) when ||z||_inf > s, else 0 (the direction kept). The clamp between the last
// force and the law's keeps a held-back change from rendering a force neither of them has: a surface that moves
// past the handle changes its law by its damping's jump B v as the contact opens or closes, which is the contact's
// response, not a force to keep. So:
//  * every change of the force the scene causes (a batch applied, a ramp step, a departure cut, a move, a stop)
//    reaches the device at most s per tick: before the clamp w_j - w_{j-1} = (g_j - g_{j-1} - J_j) +
//    (o_j - o_{j-1} + J_j), the second term at most s, the first what the handle's motion changes under the same
//    law, and the clamp (onto an interval that holds w_{j-1}) only brings w_j nearer to w_{j-1};
//  * on a tick the scene did not change (J = 0), o_j = shrink(o_{j-1}): the offset decays by s per tick whatever the
//    handle does. It is an input to the loop, not feedback: after the scene's last change the device renders the
//    law the checks certified (docs/protocol.md, section 5) plus an additive force that is zero after
//    ceil(||o||_inf / s) ticks. A rate limit on the whole force (the law's own response included) is a nonlinearity
//    inside the loop and can sustain a limit cycle the linear loop damps (tests/scene/test_scene_motion.cpp: with
//    the default step on the whole force the CE2 plane moved under the resting hand bounces between -4.19 and
//    -2.82 mm and does not stop).
// The law's own response (an impact, the damping of a fast hand) is saturated, not rate-limited.
// A fault (device error, non-finite value, watchdog, fatal signal): zero force at once (zero()).
// A stop (SIGINT/SIGTERM, the end of --duration, of a replay) is not a fault: the loop runs stop_ticks() more
// ticks with zero as the target, each a whole change, and the limiter brings the force there; the last of them
// writes exactly zero.
//
// The default rate (default_max_force_rate) takes the whole range of one axis, max_force, in
// kFullScaleTime = 4 ms, and never more than kMaxStepFraction = 1/4 of max_force in one tick: at 1 kHz a
// step of at most max_force / 4 per tick. A rate whose step max_force_rate T is max_force or more limits nothing a
// saturated force could do and is refused (max_force_rate_error).
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

// What the scene changed in the law whose force reaches the limiter this tick (after the delay buffer: the change
// travels with the force it belongs to). The clients' objects report it (SceneObjects::law_change()); the config
// walls change only when the run starts.
struct LawChange {
    bool whole = false;  // the law changed as a whole (a batch, a ramp step, a cut, the start, a stop)
    AxisVector shift{};  // otherwise its change at the handle's position this tick (moves), N
    [[nodiscard]] static LawChange whole_change() noexcept { return LawChange{true, {}}; }
};

struct ForceLimiterStats {
    std::uint64_t rate_limited_ticks = 0;  // ticks whose force written kept an offset from the law (o != 0)
    std::uint64_t saturated_ticks = 0;     // ticks with an axis saturated to max_force
    double largest_step = 0.0;             // the largest change written, N (infinity norm; zero() not counted)
};

class ForceLimiter {
  public:
    // Throws std::invalid_argument with max_force_rate_error's message, or naming max_force / the period.
    ForceLimiter(double max_force, double max_force_rate, double period, std::size_t axes);

    // The force to write for the law's force `target` (axes beyond axes() are zero) and what the scene changed in
    // that law this tick. Real-time safe.
    AxisVector step(const AxisVector& target, const LawChange& change) noexcept;
    // A fault: the force written is zero at once, whatever was written before.
    void zero() noexcept {
        last_ = AxisVector{};
        offset_ = AxisVector{};
    }

    [[nodiscard]] const AxisVector& last() const noexcept { return last_; }
    // o: the force written less the law's (saturated) force, before the written one's saturation.
    [[nodiscard]] const AxisVector& offset() const noexcept { return offset_; }
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
    AxisVector offset_{};
    ForceLimiterStats stats_;
};

}  // namespace hapticd
