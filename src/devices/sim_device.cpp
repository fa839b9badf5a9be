#include "devices/sim_device.hpp"

#include <cmath>
#include <numbers>

namespace hapticd {

std::string_view to_string(Scenario scenario) noexcept {
    switch (scenario) {
        case Scenario::Step: return "step";
        case Scenario::Push: return "push";
        case Scenario::Hold: return "hold";
    }
    return "unknown";
}

SimDevice::SimDevice(const SimDeviceConfig& config) : config_(config) {
    const double T = config_.period;
    const double d = config_.capabilities.inherent_delay / T;
    // A delay within 1e-9 periods of an integer is that integer (t_d = N/rate is not exact in binary).
    const double nearest = std::round(d);
    const double whole = std::abs(d - nearest) < 1e-9 ? nearest : std::floor(d);
    delay_periods_ = static_cast<std::int64_t>(whole);
    const double phi = d - whole;
    fractional_ = std::abs(d - nearest) >= 1e-9;
    full_ = discretize(config_.plant, T);
    if (fractional_) {
        first_ = discretize(config_.plant, phi * T);
        second_ = discretize(config_.plant, (1.0 - phi) * T);
    }
    history_.assign(static_cast<std::size_t>(delay_periods_ + 2), AxisVector{});
    rng_ = config_.noise_seed == 0 ? 0x9E3779B97F4A7C15ULL : config_.noise_seed;
    reset_state();
}

void SimDevice::reset_state() noexcept {
    x_ = {};
    v_ = {};
    rest_ = {};
    external_ = {};
    const SimScenario& s = config_.scenario;
    rest_[s.axis] = s.surface;
    switch (s.kind) {
        case Scenario::Step:
            external_[s.axis] = s.direction * s.step_force;
            break;
        case Scenario::Push:
            x_[s.axis] = -s.direction * s.push_distance;
            v_[s.axis] = s.direction * s.push_speed;
            external_[s.axis] = s.direction * s.push_force;
            break;
        case Scenario::Hold:
            x_[s.axis] = -s.direction * s.hold_distance;
            external_[s.axis] = s.direction * s.hold_force;
            break;
    }
    for (auto& h : history_) {
        h = AxisVector{};
    }
    next_tick_ = 0;
    tick_ = -1;
}

DeviceStatus SimDevice::open() {
    open_ = true;
    error_ = DeviceStatus::Ok;
    reset_state();
    return DeviceStatus::Ok;
}

DeviceStatus SimDevice::home() {
    if (!open_) {
        return error_ = DeviceStatus::NotOpen;
    }
    reset_state();
    return DeviceStatus::Ok;
}

void SimDevice::close() noexcept {
    for (auto& h : history_) {
        h = AxisVector{};
    }
    open_ = false;
}

const AxisVector& SimDevice::written(std::int64_t tick) const noexcept {
    if (tick < 0) {
        return zero_;
    }
    return history_[static_cast<std::size_t>(tick) % history_.size()];
}

void SimDevice::advance_period(std::int64_t tick) noexcept {
    const std::size_t axes = config_.capabilities.axes;
    const AxisVector& late = written(tick - delay_periods_);
    if (!fractional_) {
        for (std::size_t a = 0; a < axes; ++a) {
            full_.apply(x_[a], v_[a], external_[a] + late[a]);
        }
        return;
    }
    const AxisVector& early = written(tick - delay_periods_ - 1);
    for (std::size_t a = 0; a < axes; ++a) {
        first_.apply(x_[a], v_[a], external_[a] + early[a]);
        second_.apply(x_[a], v_[a], external_[a] + late[a]);
    }
}

double SimDevice::noise() noexcept {
    // xorshift64* and Box-Muller: deterministic for a seed, no allocation.
    auto uniform = [this]() noexcept {
        rng_ ^= rng_ >> 12U;
        rng_ ^= rng_ << 25U;
        rng_ ^= rng_ >> 27U;
        const std::uint64_t r = rng_ * 0x2545F4914F6CDD1DULL;
        return (static_cast<double>(r >> 11U) + 0.5) * 0x1.0p-53;  // (0, 1)
    };
    if (have_spare_) {
        have_spare_ = false;
        return spare_;
    }
    const double u1 = uniform();
    const double u2 = uniform();
    const double r = std::sqrt(-2.0 * std::log(u1));
    spare_ = r * std::sin(2.0 * std::numbers::pi * u2);
    have_spare_ = true;
    return r * std::cos(2.0 * std::numbers::pi * u2);
}

DeviceStatus SimDevice::read_position(AxisVector& position) noexcept {
    if (!open_) {
        return error_ = DeviceStatus::NotOpen;
    }
    if (config_.fail_at_tick >= 0 && next_tick_ >= config_.fail_at_tick) {
        return error_ = DeviceStatus::Disconnected;
    }
    if (next_tick_ > 0) {
        advance_period(next_tick_ - 1);
    }
    tick_ = next_tick_++;
    // Zero-order hold: until the loop writes, the device keeps the previous command.
    history_[static_cast<std::size_t>(tick_) % history_.size()] = written(tick_ - 1);
    const std::size_t axes = config_.capabilities.axes;
    for (std::size_t a = 0; a < kMaxAxes; ++a) {
        if (a >= axes) {
            position[a] = 0.0;
            continue;
        }
        double p = rest_[a] + x_[a];
        if (config_.position_noise > 0.0) {
            p += config_.position_noise * noise();
        }
        if (config_.position_resolution > 0.0) {
            p = std::round(p / config_.position_resolution) * config_.position_resolution;
        }
        position[a] = p;
    }
    return DeviceStatus::Ok;
}

DeviceStatus SimDevice::write_force(const AxisVector& force) noexcept {
    if (!open_) {
        return error_ = DeviceStatus::NotOpen;
    }
    if (tick_ < 0) {
        return error_ = DeviceStatus::NotHomed;
    }
    const std::size_t axes = config_.capabilities.axes;
    for (std::size_t a = 0; a < axes; ++a) {
        if (!std::isfinite(force[a]) || std::abs(force[a]) > config_.capabilities.max_force) {
            return error_ = DeviceStatus::InvalidArgument;
        }
    }
    AxisVector& slot = history_[static_cast<std::size_t>(tick_) % history_.size()];
    for (std::size_t a = 0; a < kMaxAxes; ++a) {
        slot[a] = a < axes ? force[a] : 0.0;
    }
    return DeviceStatus::Ok;
}

DeviceStatus SimDevice::read_external_force(AxisVector& force) noexcept {
    force = external_;
    return DeviceStatus::Ok;
}

std::string SimDevice::last_error() const {
    std::string msg(to_string(error_));
    if (error_ == DeviceStatus::Disconnected && config_.fail_at_tick >= 0) {
        msg += " (simulated: fail_at_tick = " + std::to_string(config_.fail_at_tick) + ")";
    }
    return msg;
}

}  // namespace hapticd
