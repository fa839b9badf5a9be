// SPDX-License-Identifier: Apache-2.0
#include "daemon/wall_retuner.hpp"

#include <stdexcept>
#include <string>
#include <utility>

namespace hapticd {

WallRetuner::WallRetuner(const OnlineMassSettings& identifier, std::size_t axis, std::uint64_t min_gap, GainRow held,
                         GainRow released)
    : identifier_(identifier), axis_(axis), min_gap_(min_gap), rows_{std::move(held), std::move(released)} {
    if (axis_ >= kMaxAxes) {
        throw std::invalid_argument("re-tuning: axis = " + std::to_string(axis_) + " is invalid; accepted: 0 .. " +
                                    std::to_string(kMaxAxes - 1));
    }
    if (min_gap_ == 0) throw std::invalid_argument("re-tuning: min_gap = 0 is invalid; accepted: >= 1 tick");
    for (const GainRow& r : rows_) {
        if (r.stiffness.size() != rows_[0].stiffness.size() || r.damping.size() != rows_[0].stiffness.size()) {
            throw std::invalid_argument(
                "re-tuning: the rows' gains are invalid; accepted: one K and one B per wall "
                "in each row");
        }
    }
}

bool WallRetuner::update(std::uint64_t tick, const AxisVector& position, const AxisVector& written,
                         Scene& scene) noexcept {
    identifier_.update(position[axis_], written[axis_]);
    return decide(tick, identifier_.gripped(), scene);
}

bool WallRetuner::decide(std::uint64_t tick, bool gripped, Scene& scene) noexcept {
    const std::uint8_t wanted = gripped ? kHeld : kReleased;
    if (wanted == row_) return false;
    if (switch_count_ > 0 && tick - last_switch_tick_ < min_gap_) return false;
    const GainRow& r = rows_[wanted];
    const std::size_t walls = r.stiffness.size() < scene.walls().size() ? r.stiffness.size() : scene.walls().size();
    for (std::size_t i = 0; i < walls; ++i) scene.set_wall_gains(i, r.stiffness[i], r.damping[i]);
    row_ = wanted;
    if (switch_count_ < kSwitchCapacity) switches_[static_cast<std::size_t>(switch_count_)] = GainSwitch{tick, row_};
    ++switch_count_;
    last_switch_tick_ = tick;
    return true;
}

}  // namespace hapticd
