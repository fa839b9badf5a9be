// SPDX-License-Identifier: Apache-2.0
#include "devices/falcon_homing.hpp"

namespace hapticd::falcon {

HomingState HomingGate::update(bool frame, std::uint8_t homed_mask) noexcept {
    ++polls_;
    if (frame) {
        mask_ = static_cast<std::uint8_t>(homed_mask & kAllAxesHomed);
        // Homing can also be lost (e.g. after a firmware reset): the gate closes again.
        state_ = mask_ == kAllAxesHomed ? HomingState::Homed : HomingState::Waiting;
    }
    if (state_ == HomingState::Waiting && timeout_polls_ != 0 && polls_ >= timeout_polls_) {
        state_ = HomingState::TimedOut;
    }
    return state_;
}

std::string HomingGate::describe() const {
    if (mask_ == kAllAxesHomed) return "all axes homed";
    std::string missing;
    for (int axis = 0; axis < 3; ++axis) {
        if ((mask_ & (1U << axis)) == 0) missing += (missing.empty() ? "" : ", ") + std::to_string(axis + 1);
    }
    return "motor(s) " + missing + " not homed";
}

void HomingGate::reset() noexcept {
    polls_ = 0;
    mask_ = 0;
    state_ = HomingState::Waiting;
}

}  // namespace hapticd::falcon
