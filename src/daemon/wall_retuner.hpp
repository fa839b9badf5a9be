// SPDX-License-Identifier: Apache-2.0
// --retune's part of the tick (docs/robust-stability.md, "Online re-tuning"): the online identifier
// (identification/online_mass.hpp) updated with the position and the force written on the watched axis, and the
// config walls' gains moved to the row of the re-tuning table (daemon/retune.hpp) that its decision names, row 0
// for the held mass, row 1 for the released one, when the decision differs from the active row and the last switch
// is at least `min_gap` ticks back (the daemon's own switches 2 N_d apart). A switch changes the gains of the forces
// computed from the next tick on; the forces already in the delay buffer keep the gains they were computed with
// (the switched loop of hapticopt/switching_loop.hpp). Real-time: after construction no allocation, lock, exception
// or I/O; the switches are kept in a fixed array (the first kSwitchCapacity, all counted).
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <vector>

#include "common/axis_vector.hpp"
#include "identification/online_mass.hpp"
#include "scene/scene.hpp"

namespace hapticd {

// The config walls' gains of one row: stiffness[i], damping[i] for Scene::walls()[i].
struct GainRow {
    std::vector<double> stiffness;  // N/m
    std::vector<double> damping;    // N s/m
};

struct GainSwitch {
    std::uint64_t tick = 0;  // the tick whose force was the last with the old gains
    std::uint8_t row = 0;    // the row from the next tick on
};

class WallRetuner {
  public:
    static constexpr std::size_t kSwitchCapacity = 1024;
    static constexpr std::uint8_t kHeld = 0;
    static constexpr std::uint8_t kReleased = 1;

    // rows[0] held, rows[1] released, each one gain pair per config wall (validated by the caller: finite, >= 0);
    // axis: the axis the identifier watches; min_gap >= 1 ticks between switches. The walls start on row 0.
    // Throws std::invalid_argument (the identifier's settings, rows of different sizes, min_gap 0).
    WallRetuner(const OnlineMassSettings& identifier, std::size_t axis, std::uint64_t min_gap, GainRow held,
                GainRow released);

    // One tick, after the force was written: the identifier's update, then decide(). Returns true when the gains
    // of `scene` changed (to row()).
    bool update(std::uint64_t tick, const AxisVector& position, const AxisVector& written, Scene& scene) noexcept;

    // The dwell rule alone, for the decision `gripped` at `tick`: true when the walls' gains switched.
    bool decide(std::uint64_t tick, bool gripped, Scene& scene) noexcept;

    [[nodiscard]] std::uint8_t row() const noexcept { return row_; }
    [[nodiscard]] std::uint64_t switch_count() const noexcept { return switch_count_; }
    // The first min(switch_count, kSwitchCapacity) switches.
    [[nodiscard]] const GainSwitch* switches() const noexcept { return switches_.data(); }
    [[nodiscard]] std::size_t stored_switches() const noexcept {
        return switch_count_ < kSwitchCapacity ? static_cast<std::size_t>(switch_count_) : kSwitchCapacity;
    }
    [[nodiscard]] const OnlineMassIdentifier& identifier() const noexcept { return identifier_; }
    [[nodiscard]] std::uint64_t min_gap() const noexcept { return min_gap_; }
    [[nodiscard]] const GainRow& gains(std::uint8_t row) const noexcept { return rows_[row]; }

  private:
    OnlineMassIdentifier identifier_;
    std::size_t axis_;
    std::uint64_t min_gap_;
    std::array<GainRow, 2> rows_;
    std::uint8_t row_ = kHeld;
    std::uint64_t switch_count_ = 0;
    std::uint64_t last_switch_tick_ = 0;
    std::array<GainSwitch, kSwitchCapacity> switches_{};
};

}  // namespace hapticd
