// SPDX-License-Identifier: Apache-2.0
// The Falcon's homing gate (pure state machine): no force until the firmware reports every axis homed.
//
// Homing procedure (source: libnifalcon include/falcon/core/FalconFirmware.h, "Homing Mode" section):
// send every packet with the homing-mode bit set; the user pulls the grip all the way out, then pushes
// it in; the Falcon then sets one "homed" flag per encoder. The homing bit must stay set in every packet
// for the Falcon to stay homed. The LED shows the state to the user: red while waiting, green when homed.
#pragma once

#include <cstdint>
#include <string>

#include "devices/falcon_protocol.hpp"

namespace hapticd::falcon {

enum class HomingState : std::uint8_t { Waiting, Homed, TimedOut };

inline constexpr const char* kHomingInstructions =
    "Falcon not homed: pull the grip all the way out towards you, then push it all the way in "
    "(the LED is red until every axis is homed, then green)";

class HomingGate {
  public:
    // timeout_polls: status updates (or polls without one) after which waiting gives up; 0: never.
    explicit HomingGate(std::uint64_t timeout_polls = 0) noexcept : timeout_polls_(timeout_polls) {}

    // One poll: `frame` says whether a valid status frame arrived (then `homed_mask` is its flags).
    HomingState update(bool frame, std::uint8_t homed_mask) noexcept;

    [[nodiscard]] HomingState state() const noexcept { return state_; }
    [[nodiscard]] bool force_allowed() const noexcept { return state_ == HomingState::Homed; }
    [[nodiscard]] std::uint8_t leds() const noexcept { return state_ == HomingState::Homed ? kLedGreen : kLedRed; }
    [[nodiscard]] std::uint8_t homed_mask() const noexcept { return mask_; }
    // "axis 1 and 3 not homed" style text (not for the real-time path).
    [[nodiscard]] std::string describe() const;
    void reset() noexcept;

  private:
    std::uint64_t timeout_polls_;
    std::uint64_t polls_ = 0;
    std::uint8_t mask_ = 0;
    HomingState state_ = HomingState::Waiting;
};

}  // namespace hapticd::falcon
