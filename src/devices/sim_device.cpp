// SPDX-License-Identifier: Apache-2.0
#include "devices/sim_device.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <stdexcept>
#include <string>

#include <Eigen/Cholesky>

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
    const std::size_t axes = std::min(config_.capabilities.axes, kMaxAxes);
    std::array<PlantParameters, kMaxAxes> plants;
    plants.fill(config_.plant);
    if (config_.mass_matrix) {
        const auto& M = *config_.mass_matrix;
        bool diagonal = true;
        for (std::size_t i = 0; i < axes; ++i) {
            for (std::size_t j = 0; j < axes; ++j) diagonal = diagonal && (i == j || M[i][j] == 0.0);
        }
        if (diagonal) {
            for (std::size_t a = 0; a < axes; ++a) {
                if (!(M[a][a] > 0.0) || !std::isfinite(M[a][a])) {
                    throw std::invalid_argument("SimDevice: mass_matrix[" + std::to_string(a) + "][" + std::to_string(a) +
                                                "] = " + std::to_string(M[a][a]) + " is invalid; accepted range: finite, > 0 kg");
                }
                plants[a].mass = M[a][a];
            }
        } else {
            if (config_.plant.damping != 0.0 || config_.plant.stiffness != 0.0) {
                throw std::invalid_argument("SimDevice: a non-diagonal mass_matrix needs damping = stiffness = 0 (got " +
                                            std::to_string(config_.plant.damping) + " N s/m, " +
                                            std::to_string(config_.plant.stiffness) + " N/m): its ZOH is then x+ = x + h v + "
                                            "h^2/2 M^-1 u, v+ = v + h M^-1 u");
            }
            const auto n = static_cast<Eigen::Index>(axes);
            Eigen::MatrixXd m(n, n);
            for (Eigen::Index i = 0; i < n; ++i) {
                for (Eigen::Index j = 0; j < n; ++j) {
                    m(i, j) = 0.5 * (M[static_cast<std::size_t>(i)][static_cast<std::size_t>(j)] +
                                     M[static_cast<std::size_t>(j)][static_cast<std::size_t>(i)]);
                }
            }
            const Eigen::LLT<Eigen::MatrixXd> llt(m);
            if (llt.info() != Eigen::Success) {
                throw std::invalid_argument("SimDevice: mass_matrix is invalid; accepted: symmetric positive definite");
            }
            const Eigen::MatrixXd inv = llt.solve(Eigen::MatrixXd::Identity(n, n));
            for (std::size_t i = 0; i < axes; ++i) {
                for (std::size_t j = 0; j < axes; ++j) {
                    inverse_mass_[i][j] = 0.5 * (inv(static_cast<Eigen::Index>(i), static_cast<Eigen::Index>(j)) +
                                                 inv(static_cast<Eigen::Index>(j), static_cast<Eigen::Index>(i)));
                }
            }
            coupled_ = true;
            plants.fill(PlantParameters{1.0, 0.0, 0.0});  // the unit-mass ZOH of w = M^-1 u
        }
    }
    for (std::size_t a = 0; a < kMaxAxes; ++a) {
        full_[a] = discretize(plants[a], T);
        if (fractional_) {
            first_[a] = discretize(plants[a], phi * T);
            second_[a] = discretize(plants[a], (1.0 - phi) * T);
        }
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

void SimDevice::apply(const std::array<ZohStep, kMaxAxes>& steps, const AxisVector& written_force) noexcept {
    const std::size_t axes = config_.capabilities.axes;
    AxisVector u{};
    for (std::size_t a = 0; a < axes; ++a) u[a] = external_[a] + written_force[a];
    if (coupled_) {  // w = M^-1 u, then the unit-mass step per axis
        AxisVector w{};
        for (std::size_t i = 0; i < axes; ++i) {
            for (std::size_t j = 0; j < axes; ++j) w[i] += inverse_mass_[i][j] * u[j];
        }
        u = w;
    }
    for (std::size_t a = 0; a < axes; ++a) steps[a].apply(x_[a], v_[a], u[a]);
}

void SimDevice::advance_period(std::int64_t tick) noexcept {
    const AxisVector& late = written(tick - delay_periods_);
    if (!fractional_) {
        apply(full_, late);
        return;
    }
    apply(first_, written(tick - delay_periods_ - 1));
    apply(second_, late);
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

bool SimDevice::zero_force_from_signal_handler() noexcept {
    for (AxisVector& slot : history_) slot = AxisVector{};  // the delayed forces too: nothing more is applied
    return true;
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
