// SPDX-License-Identifier: Apache-2.0
// The simulated hand's schedule (--hand-schedule, docs/simulated-hand.md "Grip and release"): at stated times
// from the start of the run the hand lets go of the handle, grips it again, or changes its arm's k_H and b_H.
//   release@T            the hand's mass leaves the handle, k_H = b_H = 0 and its intent force is off
//   grip@T               the hand's mass joins (moving with the handle), k_H and b_H back, x_H = the handle
//   arm@T:k=K:b=B        the arm's k_H (N/m) and/or b_H (N s/m) from T on (while released: at the next grip)
// Events are comma-separated, T in s (a decimal number), strictly increasing; a release needs the hand on the
// handle (the run starts with it held), a grip needs it off.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace hapticd {

enum class HandEventKind : std::uint8_t { Release, Grip, Arm };

std::string_view to_string(HandEventKind kind) noexcept;

struct HandEvent {
    HandEventKind kind = HandEventKind::Release;
    double time = 0.0;                // s from the start of the run
    std::optional<double> stiffness;  // Arm: the new k_H, N/m (none: unchanged)
    std::optional<double> damping;    // Arm: the new b_H, N s/m (none: unchanged)
};

// Accepted ranges, as for --hand-stiffness, --hand-damping and --duration.
inline constexpr double kHandScheduleMaxTime = 1e7;       // s
inline constexpr double kHandScheduleMaxStiffness = 1e9;  // N/m
inline constexpr double kHandScheduleMaxDamping = 1e6;    // N s/m

// The text's events (empty text: none). Throws std::invalid_argument whose message starts with
// "hand-schedule = '<text>' is invalid" and names the event, what is wrong and the accepted form or range.
std::vector<HandEvent> parse_hand_schedule(std::string_view text);

// "release@2,grip@4,arm@5:k=400:b=8": the events in the accepted form (shortest round-trip numbers).
std::string describe(const std::vector<HandEvent>& events);

}  // namespace hapticd
