// SPDX-License-Identifier: Apache-2.0
// Shared pieces of the experiment tests: simulated devices for a plant, a device wrapper that remembers the
// last force command, and the standard setup of the experiments.
#pragma once

#include <memory>
#include <sstream>
#include <utility>
#include <vector>

#include "devices/sim_device.hpp"
#include "experiment/experiment_procedures.hpp"
#include "experiment/experiment_progress.hpp"

namespace hapticd::experiment::test {

struct Plant {
    double mass = 0.3, damping = 0.0, stiffness = 0.0;
    double inherent_delay_periods = 0.0;  // the device's own delay
    std::size_t buffer = 0;               // the experiment's delay buffer
    double period = 1e-3;
    [[nodiscard]] TheoryPlant theory() const {
        return {mass, damping, stiffness, period, (inherent_delay_periods + static_cast<double>(buffer)) * period};
    }
};

inline const Plant kDefault{};  // sim.toml: m = 0.3 kg, b = k = 0, d = 0

inline std::unique_ptr<SimDevice> make_sim(const Plant& p, std::int64_t fail_at_tick = -1) {
    SimDeviceConfig c;
    c.capabilities.axes = 1;
    c.capabilities.max_force = 10.0;
    c.capabilities.inherent_delay = p.inherent_delay_periods * p.period;
    c.plant = PlantParameters{p.mass, p.damping, p.stiffness};
    c.period = p.period;
    c.fail_at_tick = fail_at_tick;
    c.scenario.step_force = 0.0;  // no external force: the step goes through the actuator
    auto d = std::make_unique<SimDevice>(c);
    d->open();
    d->home();
    return d;
}

// Forwards to a device and remembers every force command (the last one must be zero after any abort).
class RecordingDevice final : public Device {
  public:
    explicit RecordingDevice(Device& inner) : inner_(inner) {}
    DeviceStatus open() override { return inner_.open(); }
    DeviceStatus home() override { return inner_.home(); }
    void close() noexcept override { inner_.close(); }
    DeviceStatus read_position(AxisVector& p) noexcept override { return inner_.read_position(p); }
    DeviceStatus write_force(const AxisVector& f) noexcept override {
        last_force = f;
        ++writes;
        return inner_.write_force(f);
    }
    [[nodiscard]] const DeviceCapabilities& capabilities() const noexcept override { return inner_.capabilities(); }
    [[nodiscard]] std::string_view name() const noexcept override { return "recording"; }
    [[nodiscard]] std::string last_error() const override { return inner_.last_error(); }
    AxisVector last_force{};
    std::size_t writes = 0;

  private:
    Device& inner_;
};

inline ExperimentSetup make_setup(const Plant& p, const Theory& theory, std::size_t trial_ticks) {
    ExperimentSetup s;
    s.trial.period = p.period;
    s.trial.delay_buffer = p.buffer;
    s.trial.mass = p.mass;
    s.trial.stiffness = p.stiffness;
    s.trial.step_force = 0.5;
    s.trial.ticks = trial_ticks;
    s.trial.force_cap = 5.0;
    s.trial.position_limit = 0.01;
    const auto [K, B] = theory.ce2_optimum();
    s.settle.period = p.period;
    s.settle.delay_buffer = p.buffer;
    s.settle.K = K;
    s.settle.B = B;
    s.settle.ticks = 400;
    s.settle.zero_ticks = 100;
    s.settle.force_cap = 5.0;
    s.settle.position_limit = 0.02;
    s.model = CostModel{p.mass, p.damping, p.stiffness, p.period, p.inherent_delay_periods * p.period};
    return s;
}

// The boundary experiment's K sweep: from K_max / steps in steps of K_max / steps up to 2 K_max, the last
// interval bisected to 1 / refine of a step (K_max analysed).
inline BoundarySettings k_sweep(const Theory& theory, std::vector<double> b_values, double steps, double refine) {
    BoundarySettings s;
    s.b_values = std::move(b_values);
    s.k_step = theory.max_stiffness() / steps;
    s.k_min = s.k_step;
    s.k_max = 2.0 * theory.max_stiffness();
    s.k_resolution = s.k_step / refine;
    return s;
}

// A plant's analysis, its simulated device in lockstep at 1 kHz and the standard setup homed where the
// device starts: what every experiment test on the simulated device begins with.
struct SimBench {
    SimBench(const Plant& plant, std::size_t trial_ticks)
        : theory(plant.theory()),
          sim(make_sim(plant)),
          runner(*sim, 1'000'000, true),
          setup(make_setup(plant, theory, trial_ticks)) {
        setup.settle.home = runner.read_position(0);
    }
    Theory theory;
    std::unique_ptr<SimDevice> sim;
    TrialRunner runner;
    ExperimentSetup setup;
};

// run_boundary with the progress display going nowhere.
inline BoundaryResult run_boundary_quietly(TrialRunner& runner, const ExperimentSetup& setup, const BoundarySettings& s,
                                           const Theory& theory) {
    std::ostringstream sink;
    Progress progress(sink, false, true);
    return run_boundary(runner, setup, s, theory, progress);
}

}  // namespace hapticd::experiment::test
