// SPDX-License-Identifier: Apache-2.0
// The simulated device: the continuous plant of eq. 1,  M x'' + b x' + k x = F_ext + u,  advanced exactly
// (zero-order hold) by one period per tick. M is one mass for every axis, a mass per axis (a diagonal M:
// each axis its own exact ZOH of m_a x'' + b x' + k x = F), or a full symmetric positive-definite matrix
// with b = k = 0, whose exact ZOH over h with u constant is  x+ = x + h v + h^2/2 M^-1 u,  v+ = v + h M^-1 u
// (per axis the unit-mass ZOH of w = M^-1 u: the same numbers). u is the force written by the loop; it acts
// after the device's inherent delay (which may be a non-integer number of periods: the period is then
// split into two exactly-integrated sub-intervals). The spring's rest position is the wall surface of the
// scenario axis (the analysis' x = 0) and 0 on the other axes.
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "devices/device.hpp"
#include "devices/zoh_plant.hpp"

namespace hapticd {

enum class Scenario : std::uint8_t {
    Step,  // at rest on the wall surface; external force step_force into the wall from t = 0 (the paper's step)
    Push,  // starts push_distance outside the wall moving towards it at push_speed (a collision)
    Hold,  // starts at rest hold_distance outside; the human pushes with hold_force from t = 0
};

std::string_view to_string(Scenario scenario) noexcept;

struct SimScenario {
    Scenario kind = Scenario::Step;
    std::size_t axis = 0;     // the axis the scenario acts on
    double surface = 0.0;     // wall surface on that axis, m
    double direction = 1.0;   // +1: the wall is entered moving in +axis direction; -1: in -axis direction
    double step_force = 1.0;  // N
    double push_speed = 0.1;  // m/s
    double push_distance = 0.002;  // m
    double push_force = 0.0;  // N, external force during the push (0: free collision)
    double hold_force = 2.0;  // N
    double hold_distance = 0.001;  // m
};

struct SimDeviceConfig {
    DeviceCapabilities capabilities;   // capabilities.inherent_delay is simulated
    PlantParameters plant;             // b, k; and the mass of every axis unless mass_matrix is set
    // M on the device's axes (rows/columns beyond them ignored), symmetric positive definite. Diagonal: per
    // axis its own mass with plant's b and k; otherwise plant.damping = plant.stiffness = 0 is required.
    std::optional<std::array<AxisVector, kMaxAxes>> mass_matrix;
    double period = 1e-3;              // s
    double position_noise = 0.0;       // standard deviation of additive Gaussian noise, m (0: off)
    double position_resolution = 0.0;  // quantisation step of the reported position, m (0: off)
    std::uint64_t noise_seed = 1;
    std::int64_t fail_at_tick = -1;    // fault injection for tests: Disconnected from this tick on (-1: never)
    SimScenario scenario;
};

class SimDevice final : public Device {
public:
    // Throws std::invalid_argument naming the parameter for a non-diagonal mass_matrix with b or k != 0, or
    // one that is not positive definite.
    explicit SimDevice(const SimDeviceConfig& config);

    DeviceStatus open() override;
    DeviceStatus home() override;
    void close() noexcept override;

    DeviceStatus read_position(AxisVector& position) noexcept override;
    DeviceStatus write_force(const AxisVector& force) noexcept override;
    // The simulated plant's commanded force is memory of this process: zeroing it is a store.
    bool zero_force_from_signal_handler() noexcept override;
    DeviceStatus read_external_force(AxisVector& force) noexcept override;

    [[nodiscard]] const DeviceCapabilities& capabilities() const noexcept override { return config_.capabilities; }
    [[nodiscard]] std::string_view name() const noexcept override { return "sim"; }
    [[nodiscard]] std::string last_error() const override;

    // Exact (noise-free) state, for tests and diagnostics.
    [[nodiscard]] double true_position(std::size_t axis) const noexcept { return rest_[axis] + x_[axis]; }
    [[nodiscard]] double true_velocity(std::size_t axis) const noexcept { return v_[axis]; }

private:
    void reset_state() noexcept;
    void advance_period(std::int64_t tick) noexcept;  // integrates [tick T, (tick+1) T)
    [[nodiscard]] const AxisVector& written(std::int64_t tick) const noexcept;
    double noise() noexcept;

    SimDeviceConfig config_;
    // Per axis (the same on every axis for one mass; unit mass when coupled_).
    std::array<ZohStep, kMaxAxes> full_{};    // h = T
    std::array<ZohStep, kMaxAxes> first_{};   // h = phi T       (fractional part of the delay)
    std::array<ZohStep, kMaxAxes> second_{};  // h = (1 - phi) T
    bool coupled_ = false;                    // a non-diagonal M: the input is u' = M^-1 u
    std::array<AxisVector, kMaxAxes> inverse_mass_{};
    void apply(const std::array<ZohStep, kMaxAxes>& steps, const AxisVector& written_force) noexcept;
    std::int64_t delay_periods_ = 0;  // integer part n of t_inh / T
    bool fractional_ = false;
    std::vector<AxisVector> history_;  // written forces of ticks tick-n-1 .. tick, ring of n + 2
    AxisVector zero_{};
    AxisVector x_{}, v_{}, rest_{}, external_{};
    std::int64_t next_tick_ = 0;
    std::int64_t tick_ = -1;
    bool open_ = false;
    DeviceStatus error_ = DeviceStatus::Ok;
    std::uint64_t rng_ = 1;
    bool have_spare_ = false;
    double spare_ = 0.0;
};

}  // namespace hapticd
