// SPDX-License-Identifier: Apache-2.0
// Time-domain passivity control at the device port (after Hannaford and Ryu, "Time-domain passivity control of
// haptic interfaces", IEEE Trans. Robotics and Automation 18(1), 1-10, 2002): a passivity observer
// integrates the energy that flows into the rendered environment, a variable damper dissipates what the
// environment generated.
//
// Where the energy is observed, and the delay. The one-port is everything between the sampled position and
// the force written to the device: the scene (walls) AND the delay buffer. The controller runs after the
// delay ring, on the force about to be written, so its damper acts in the same period it is computed and the
// buffered delay sits inside the observed port (it is what makes the port active). It does not see the
// device's own inherent delay (a profile's inherent_delay): that is outside the port.
//
// Per axis, with F_j the force on the device written at tick j (constant over [jT, (j+1)T): zero-order hold)
// and x_j the sampled position:
//   port energy (what the environment absorbed; exact for the hold, known one tick late):
//     W_j = W_{j-1} - F_{j-1} (x_j - x_{j-1}),
//   observed energy (the prediction of W_{j+1} with the force about to be written and the displacement
//   v_j T, v_j = (x_j - x_{j-1}) / T):  P_j = W_j - F_j v_j T.
//   Why not Hannaford-Ryu's E = T sum F_j v_j: with F_j computed from x_j and the backward velocity it is
//   sum K x_j (x_j - x_{j-1}) >= 0 for any spring, so it never sees the energy the hold generates (measured:
//   a wall at 1.5 alpha_max diverges with E >= 0 throughout); the force acts over the NEXT period.
//   Controller: if P_j < 0 and |v_j| >= v_guard, add a damper F_j <- F_j - b v_j with
//   b = min(b_cap, -P_j / (v_j^2 T)) (P_j becomes 0, or stays negative when capped); saturate |F_j| <= F_max;
//   book P_j with the force actually written. Guard: below v_guard no damper (-P / v^2 would blow up; a damper
//   cannot dissipate without motion); cap: b <= b_cap. Both, and the saturation, are counted.
// Bound (tested at every tick): W_j >= -(S_j + E_j), where S_j (`shortfall`) sums over the capped / guarded /
// saturated / limited ticks (limited: the force limiter after the controller changed the force) how far P fell
// below min(0, W) there, and E_j (`prediction_error`) sums |W_{k+1} - P_k|, the
// observer's error (the "imprecise energy observation": velocity changes inside a period). Induction: on any
// other tick P_k >= 0, and W_{k+1} = P_k + (W_{k+1} - P_k). With an exact prediction and no binding cap the
// port would be passive (W >= 0).
// Real time: no allocation, no locks, no exceptions; a non-finite input or result zeroes the axis's force and
// is counted (the scene has already latched its own fault for non-finite positions).
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <string>

#include "common/axis_vector.hpp"

namespace hapticd {

struct PassivityControlConfig {
    double period = 0.001;         // T [s], > 0
    double damping_cap = 0.0;      // b_cap [N s/m], finite, > 0
    double velocity_guard = 1e-4;  // v_guard [m/s], finite, > 0
    double max_force = 0.0;        // F_max [N], finite, > 0 (the device's maximum)
    std::size_t axes = 1;          // 1 .. kMaxAxes
};

struct PassivityControlStats {
    std::uint64_t damper_ticks = 0;      // ticks (summed over axes) with the damper engaged
    std::uint64_t capped_ticks = 0;      // ... of which b hit b_cap
    std::uint64_t guarded_ticks = 0;     // P < 0 but |v| < v_guard: no damper
    std::uint64_t saturated_ticks = 0;   // the damped force was saturated to F_max
    std::uint64_t nonfinite_events = 0;  // non-finite input or result: the axis's force zeroed
    std::uint64_t limited_ticks = 0;     // the force written differed from the proposed (the force limiter)
    double max_added_damping = 0.0;      // largest b used [N s/m]
    double dissipated = 0.0;             // sum of b v^2 T [J]
    double shortfall = 0.0;              // S: sum over capped/guarded/saturated ticks of the energy left negative [J]
    double prediction_error = 0.0;       // E: sum of |W_{j+1} - P_j| [J]
    double min_observed_energy = 0.0;    // min over ticks and axes of P_j [J]
    double min_port_energy = 0.0;        // min over ticks and axes of W_j [J]
};

// Throws std::invalid_argument naming the parameter and its accepted range.
void validate(const PassivityControlConfig& config);

class PassivityController {
  public:
    explicit PassivityController(const PassivityControlConfig& config);

    // Adjusts `force` (device frame, about to be written) for the sampled `position` and books it as written:
    // propose() then commit(force). Real-time safe.
    void apply(const AxisVector& position, AxisVector& force) noexcept;
    // The two halves, for a stage between the controller and the device (scene/force_limiter.hpp):
    // propose() adjusts `force` and books the port energy W_j; commit() books the force the device really
    // got (P_j = W_j - F_j v_j T with it, and it is the F_{j-1} of the next W). A tick whose written force
    // differs from the proposed one counts as constrained (limited_ticks; its P below min(0, W) goes into the
    // shortfall S), so the bound W_j >= -(S_j + E_j) holds for the force written. One commit per propose.
    void propose(const AxisVector& position, AxisVector& force) noexcept;
    void commit(const AxisVector& written) noexcept;

    [[nodiscard]] const PassivityControlStats& stats() const noexcept { return stats_; }
    [[nodiscard]] const PassivityControlConfig& config() const noexcept { return config_; }
    [[nodiscard]] double observed_energy(std::size_t axis) const noexcept { return energy_[axis]; }
    [[nodiscard]] double port_energy(std::size_t axis) const noexcept { return port_energy_[axis]; }
    [[nodiscard]] double last_added_damping(std::size_t axis) const noexcept { return last_damping_[axis]; }
    void reset() noexcept;

  private:
    PassivityControlConfig config_;
    PassivityControlStats stats_;
    AxisVector previous_position_{};
    AxisVector previous_force_{};
    AxisVector energy_{};
    AxisVector port_energy_{};
    AxisVector last_damping_{};
    // propose()'s per-axis results, booked by commit().
    struct Pending {
        double W = 0.0, v = 0.0, x = 0.0, force = 0.0;
        bool short_booked = false, nonfinite = false, skip = false;
    };
    std::array<Pending, kMaxAxes> pending_{};
    bool primed_ = false;
};

std::string describe(const PassivityControlConfig& config);

}  // namespace hapticd
