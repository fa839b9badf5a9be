// SPDX-License-Identifier: Apache-2.0
#include "experiment/experiment_trial.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "loop/realtime_loop.hpp"
#include "common/stop_flag.hpp"

namespace hapticd::experiment {

const char* to_string(TrialOutcome outcome) noexcept {
    switch (outcome) {
        case TrialOutcome::Stable:
            return "stable";
        case TrialOutcome::Growing:
            return "energy_growth";
        case TrialOutcome::EnergyCap:
            return "energy_cap";
        case TrialOutcome::ForceCap:
            return "force_cap";
        case TrialOutcome::PositionLimit:
            return "position_limit";
        case TrialOutcome::NonFinite:
            return "non_finite";
        case TrialOutcome::DeviceFault:
            return "device_fault";
        case TrialOutcome::Stopped:
            return "stopped";
    }
    return "unknown";
}

TrialRunner::TrialRunner(Device& device, std::int64_t period_ns, bool lockstep)
    : device_(device), period_ns_(period_ns), lockstep_(lockstep) {}

double TrialRunner::read_position(std::size_t axis) {
    AxisVector p{};
    if (device_.read_position(p) != DeviceStatus::Ok) return std::numeric_limits<double>::quiet_NaN();
    (void)device_.write_force(AxisVector{});
    return p[axis];
}

void TrialRunner::run(const TrialSettings& s, TrialRecord& r) {
    // Everything the loop touches is allocated here, before it starts.
    r.x.assign(s.ticks, 0.0);
    r.u.assign(s.ticks, 0.0);
    r.samples = 0;
    r.outcome = TrialOutcome::Stable;
    r.end_tick = 0;
    r.max_growth = 0.0;
    r.max_abs_force = 0.0;
    r.max_abs_position = 0.0;
    r.device_error.clear();
    DelayRing<double> delay(s.delay_buffer);

    const double T = s.period;
    const double total_stiffness = s.K + s.stiffness;
    const double x_inf = s.step_force / total_stiffness;
    const double e0 = s.step_force * s.step_force / (2.0 * total_stiffness);
    const DetectionSettings& det = s.detection;
    double start = 0.0, x_prev = 0.0;
    double window_sum = 0.0, previous_window = -1.0, largest_window = 0.0;
    std::size_t in_window = 0;
    int growth_run = 0;

    RealtimeLoop loop(LoopConfig{period_ns_, lockstep_});
    loop.run([&](const TickInput& in) noexcept -> TickOutput {
        const std::size_t j = static_cast<std::size_t>(in.tick);
        AxisVector position{};
        auto finish = [&](TrialOutcome outcome) noexcept {
            r.outcome = outcome;
            r.end_tick = j;
            r.samples = j + 1;
            return TickOutput{.stop = true};
        };
        auto write_zero = [&]() noexcept { return device_.write_force(AxisVector{}) == DeviceStatus::Ok; };
        if (stop_requested()) {
            write_zero();
            return finish(TrialOutcome::Stopped);
        }
        if (device_.read_position(position) != DeviceStatus::Ok) {
            write_zero();
            return finish(TrialOutcome::DeviceFault);
        }
        const double p = position[s.axis];
        if (!std::isfinite(p)) {
            write_zero();
            return finish(TrialOutcome::NonFinite);
        }
        if (j == 0) start = p;
        const double x = s.direction * (p - start);
        if (j == 0) x_prev = x;
        r.x[j] = x;
        r.max_abs_position = std::max(r.max_abs_position, std::abs(x));
        if (std::abs(x) > s.position_limit) {
            write_zero();
            return finish(TrialOutcome::PositionLimit);
        }
        const double velocity = (x - x_prev) / T;
        const double wall = s.K * x + s.B * velocity;  // f_j, computed every tick (the ring keeps its timing)
        x_prev = x;
        const double u = s.step_force - delay.push_pop(wall);
        const bool last = j + 1 >= s.ticks;
        TrialOutcome verdict = TrialOutcome::Stable;
        if (std::abs(u) > s.force_cap) verdict = TrialOutcome::ForceCap;
        if (s.detect) {
            const double dx = x - x_inf;
            window_sum += 0.5 * total_stiffness * dx * dx + 0.5 * s.mass * velocity * velocity;
            if (++in_window == det.window) {
                if (window_sum > det.energy_cap * static_cast<double>(det.window) * e0)
                    verdict = TrialOutcome::EnergyCap;
                if (previous_window > 0.0 && window_sum > 1e-6 * largest_window) {
                    const double ratio = window_sum / previous_window;
                    r.max_growth = std::max(r.max_growth, ratio);
                    growth_run = ratio > det.growth ? growth_run + 1 : 0;
                    if (growth_run >= det.consecutive && verdict == TrialOutcome::Stable)
                        verdict = TrialOutcome::Growing;
                } else {
                    growth_run = 0;
                }
                largest_window = std::max(largest_window, window_sum);
                previous_window = window_sum;
                window_sum = 0.0;
                in_window = 0;
            }
        }
        if (verdict != TrialOutcome::Stable || last) {
            r.u[j] = 0.0;
            if (!write_zero()) return finish(TrialOutcome::DeviceFault);
            return finish(verdict);
        }
        AxisVector force{};
        force[s.axis] = s.direction * u;
        r.u[j] = u;
        r.max_abs_force = std::max(r.max_abs_force, std::abs(u));
        if (device_.write_force(force) != DeviceStatus::Ok) {
            write_zero();
            return finish(TrialOutcome::DeviceFault);
        }
        return TickOutput{.stop = false};
    });
    if (r.outcome == TrialOutcome::DeviceFault) r.device_error = device_.last_error();
}

SettleResult TrialRunner::settle(const SettleSettings& s) {
    SettleResult result;
    DelayRing<double> delay(s.delay_buffer);
    double x_prev = 0.0;
    const std::size_t total = s.ticks + s.zero_ticks;
    RealtimeLoop loop(LoopConfig{period_ns_, lockstep_});
    loop.run([&](const TickInput& in) noexcept -> TickOutput {
        const std::size_t j = static_cast<std::size_t>(in.tick);
        AxisVector position{};
        auto finish = [&](TrialOutcome outcome) noexcept {
            (void)device_.write_force(AxisVector{});
            result.outcome = outcome;
            return TickOutput{.stop = true};
        };
        if (stop_requested()) return finish(TrialOutcome::Stopped);
        if (device_.read_position(position) != DeviceStatus::Ok) return finish(TrialOutcome::DeviceFault);
        const double p = position[s.axis];
        if (!std::isfinite(p)) return finish(TrialOutcome::NonFinite);
        const double x = p - s.home;  // towards home: the wall law about home, both directions
        result.final_offset = x;
        if (std::abs(x) > s.position_limit) return finish(TrialOutcome::PositionLimit);
        if (j == 0) x_prev = x;
        const double f = delay.push_pop(s.K * x + s.B * (x - x_prev) / s.period);
        x_prev = x;
        AxisVector force{};
        if (j < s.ticks) force[s.axis] = -std::clamp(f, -s.force_cap, s.force_cap);
        if (device_.write_force(force) != DeviceStatus::Ok) return finish(TrialOutcome::DeviceFault);
        return TickOutput{.stop = j + 1 >= total};
    });
    if (result.outcome == TrialOutcome::DeviceFault) result.device_error = device_.last_error();
    return result;
}

}  // namespace hapticd::experiment
