// SPDX-License-Identifier: Apache-2.0
// One trial of the Sect. V experiments (Hulin et al., IROS 2011): the bilateral wall
//     f_j = K x_j + B (x_j - x_{j-1}) / T          (x: penetration, along the wall's axis)
// behind the delay buffer, plus the paper's step input F (the external force of Fig. 2) applied through
// the actuator from tick 0; the device gets u_j = F - f_{j-N} (N: delay buffer), in the device frame
// direction * u_j. The trial runs in the RealtimeLoop (lockstep on the simulated device) and records x_j
// and u_j into buffers preallocated before it starts; the callback does not allocate, lock, throw or do
// I/O other than the device's.
//
// Limits (every tick): |u| > force cap, |x| > position limit: the trial ends as unstable with zero force
// written in that same tick. Non-finite position, device error, SIGINT/SIGTERM: zero force at once, the
// trial ends and the experiment stops. The last tick of every trial writes zero force.
//
// Instability detection (boundary experiment): the energy about the step's equilibrium,
//     e_j = 1/2 (K + k) (x_j - x_inf)^2 + 1/2 m ((x_j - x_{j-1}) / T)^2,   x_inf = F / (K + k)   (eq. 4),
// summed over windows of W ticks, S_w. The loop is declared unstable when S_w / S_{w-1} > g for c
// consecutive windows (each S_w above 1e-6 of the largest window so far, so that decayed, rounding-level
// energies are never compared), or when S_w > cap W E(0) (E(0) = F^2 / (2 (K + k)), eq. 5). Once the
// slowest mode dominates, S_w / S_{w-1} = rho^(2W) (rho: spectral radius of the loop), so loops with
// rho > g^(1/(2W)) are detected and loops with rho < 1 never are: the detected boundary lies between the
// exact one (rho = 1) and rho = g^(1/(2W)) (docs/experiments.md).
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "scene/delay_ring.hpp"
#include "devices/device.hpp"

namespace hapticd::experiment {

struct DetectionSettings {
    std::size_t window = 100;   // W, ticks per energy window
    double growth = 1.05;       // g, window-to-window energy ratio counted as growth
    int consecutive = 3;        // c, windows of growth in a row
    double energy_cap = 100.0;  // S_w > energy_cap W E(0): unstable
};

struct TrialSettings {
    std::size_t axis = 0;
    double direction = 1.0;        // +1 / -1: device frame direction of the wall's penetration
    double period = 1e-3;          // T, s
    std::size_t delay_buffer = 0;  // N samples of the wall force (the step force is not delayed)
    double mass = 0.3;             // m of the profile (energy of the detection)
    double stiffness = 0.0;        // k of the profile
    double K = 0.0, B = 0.0;       // wall gains, N/m, N s/m
    double step_force = 0.1;       // F, N, signed (along the penetration)
    std::size_t ticks = 1000;      // trial length
    bool detect = true;            // stop at detected instability (boundary); optimal: record only
    DetectionSettings detection;
    double force_cap = 1.0;        // |u| limit, N
    double position_limit = 0.01;  // |x| limit, m (relative to the trial's start position)
};

enum class TrialOutcome : std::uint8_t {
    Stable,         // ran to its end without growth
    Growing,        // energy growth detected
    EnergyCap,      // window energy above the cap
    ForceCap,       // |u| would have exceeded the force cap
    PositionLimit,  // |x| exceeded the position limit
    NonFinite,      // non-finite position: the experiment stops (exit 7)
    DeviceFault,    // device error: the experiment stops (exit 7)
    Stopped,        // SIGINT / SIGTERM: the experiment stops (exit 0)
};
[[nodiscard]] const char* to_string(TrialOutcome outcome) noexcept;
[[nodiscard]] inline bool counts_as_unstable(TrialOutcome o) noexcept {
    return o == TrialOutcome::Growing || o == TrialOutcome::EnergyCap || o == TrialOutcome::ForceCap ||
           o == TrialOutcome::PositionLimit;
}
[[nodiscard]] inline bool ends_experiment(TrialOutcome o) noexcept {
    return o == TrialOutcome::NonFinite || o == TrialOutcome::DeviceFault || o == TrialOutcome::Stopped;
}

struct TrialRecord {
    std::vector<double> x;    // penetration at each tick, m (relative to the start position)
    std::vector<double> u;    // force written at each tick along the penetration, N (0 on the last)
    std::size_t samples = 0;  // ticks recorded
    TrialOutcome outcome = TrialOutcome::Stable;
    std::size_t end_tick = 0;       // tick of the outcome (samples - 1)
    double max_growth = 0.0;        // largest S_w / S_{w-1} seen (0 before two windows)
    double max_abs_force = 0.0;     // N
    double max_abs_position = 0.0;  // m
    std::string device_error;       // DeviceFault: the device's last_error()
};

// Gentle return to the experiment's home position between trials: the wall law towards `home` with gains
// analysed stable (the CE2 optimum of the profile), force-capped, then zero force for `zero_ticks`.
struct SettleSettings {
    std::size_t axis = 0;
    double period = 1e-3;
    std::size_t delay_buffer = 0;
    double K = 0.0, B = 0.0;      // return gains
    double home = 0.0;            // device-frame position, m
    std::size_t ticks = 500;      // return phase
    std::size_t zero_ticks = 50;  // zero force at the end
    double force_cap = 1.0;
    double position_limit = 0.02;  // |p - home| beyond this: fault
};

struct SettleResult {
    TrialOutcome outcome = TrialOutcome::Stable;  // Stable, PositionLimit, NonFinite, DeviceFault, Stopped
    double final_offset = 0.0;                    // p - home at the end, m
    std::string device_error;
};

class TrialRunner {
  public:
    // The device must be open and homed; it must outlive the runner.
    TrialRunner(Device& device, std::int64_t period_ns, bool lockstep);

    // Runs one trial; `record` is resized here (before the loop) and filled by the loop.
    void run(const TrialSettings& settings, TrialRecord& record);
    SettleResult settle(const SettleSettings& settings);
    // The device-frame position now (one read; NaN on error): the home position of the experiment.
    double read_position(std::size_t axis);

  private:
    Device& device_;
    std::int64_t period_ns_;
    bool lockstep_;
};

}  // namespace hapticd::experiment
