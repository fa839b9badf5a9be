// SPDX-License-Identifier: Apache-2.0
#include "scene/passivity_controller.hpp"

#include <algorithm>
#include <cmath>
#include <sstream>
#include <stdexcept>

namespace hapticd {

void validate(const PassivityControlConfig& c) {
    auto bad = [](const char* name, double value, const char* range) {
        std::ostringstream out;
        out << "passivity control: " << name << " = " << value << " is invalid; accepted range: " << range;
        throw std::invalid_argument(out.str());
    };
    if (!std::isfinite(c.period) || c.period <= 0.0) bad("period", c.period, "finite, > 0 s");
    if (!std::isfinite(c.damping_cap) || c.damping_cap <= 0.0) bad("damping cap", c.damping_cap, "finite, > 0 N s/m");
    if (!std::isfinite(c.velocity_guard) || c.velocity_guard <= 0.0) {
        bad("velocity guard", c.velocity_guard, "finite, > 0 m/s");
    }
    if (!std::isfinite(c.max_force) || c.max_force <= 0.0) bad("max force", c.max_force, "finite, > 0 N");
    if (c.axes == 0 || c.axes > kMaxAxes) bad("axes", static_cast<double>(c.axes), "1 .. 3");
}

PassivityController::PassivityController(const PassivityControlConfig& config) : config_(config) { validate(config_); }

void PassivityController::apply(const AxisVector& position, AxisVector& force) noexcept {
    propose(position, force);
    commit(force);
}

void PassivityController::propose(const AxisVector& position, AxisVector& force) noexcept {
    const double T = config_.period;
    for (std::size_t a = 0; a < config_.axes; ++a) {
        Pending& q = pending_[a];
        double F = force[a];
        const double x = position[a];
        last_damping_[a] = 0.0;
        q = Pending{};
        if (!std::isfinite(F) || !std::isfinite(x)) {
            force[a] = 0.0;
            ++stats_.nonfinite_events;
            q.skip = true;
            continue;
        }
        const double dx = primed_ ? x - previous_position_[a] : 0.0;
        const double v = dx / T;
        // Port energy, exact for the hold: the force written last tick acted over dx.
        const double W = port_energy_[a] - previous_force_[a] * dx;
        // Its error against last tick's prediction (the observer's imprecision: velocity changes in a period).
        if (primed_) stats_.prediction_error += std::abs(W - energy_[a]);
        port_energy_[a] = W;
        q.W = W;
        q.v = v;
        q.x = x;
        double P = W - F * v * T;  // predicted port energy after this tick's force, displacement v T
        if (P < 0.0) {
            if (std::abs(v) >= config_.velocity_guard) {
                const double needed = -P / (v * v * T);
                double b = needed;
                if (b > config_.damping_cap) {
                    b = config_.damping_cap;
                    ++stats_.capped_ticks;
                    q.short_booked = true;
                }
                double damped = F - b * v;
                if (damped > config_.max_force || damped < -config_.max_force) {
                    damped = std::clamp(damped, -config_.max_force, config_.max_force);
                    ++stats_.saturated_ticks;
                    q.short_booked = true;
                }
                const double added = (F - damped) / v;  // the damping the written force really adds
                F = damped;
                ++stats_.damper_ticks;
                last_damping_[a] = added;
                stats_.max_added_damping = std::max(stats_.max_added_damping, added);
                stats_.dissipated += added * v * v * T;
                P = W - F * v * T;
            } else {
                ++stats_.guarded_ticks;
                q.short_booked = true;
            }
        }
        if (!std::isfinite(F) || !std::isfinite(P)) {
            force[a] = 0.0;
            ++stats_.nonfinite_events;
            q.nonfinite = true;
            continue;
        }
        force[a] = F;
        q.force = F;
    }
    primed_ = true;
}

void PassivityController::commit(const AxisVector& written) noexcept {
    const double T = config_.period;
    for (std::size_t a = 0; a < config_.axes; ++a) {
        const Pending& q = pending_[a];
        if (q.skip) continue;
        const double F = std::isfinite(written[a]) ? written[a] : 0.0;
        previous_position_[a] = q.x;
        previous_force_[a] = F;
        if (q.nonfinite) {
            energy_[a] = q.W - F * q.v * T;
            continue;
        }
        const double P = q.W - F * q.v * T;
        const bool limited = F != q.force;  // the force limiter after this controller changed it
        stats_.limited_ticks += limited ? 1U : 0U;
        if (q.short_booked || limited) stats_.shortfall += std::max(0.0, std::min(0.0, q.W) - P);
        energy_[a] = P;
        stats_.min_observed_energy = std::min(stats_.min_observed_energy, P);
        stats_.min_port_energy = std::min(stats_.min_port_energy, q.W);
    }
}

void PassivityController::reset() noexcept {
    stats_ = PassivityControlStats{};
    previous_position_ = AxisVector{};
    previous_force_ = AxisVector{};
    energy_ = AxisVector{};
    port_energy_ = AxisVector{};
    last_damping_ = AxisVector{};
    pending_ = {};
    primed_ = false;
}

std::string describe(const PassivityControlConfig& c) {
    std::ostringstream out;
    out << "passivity control (Hannaford-Ryu observer + variable damper at the device port, after the delay buffer): "
        << "damping cap " << c.damping_cap << " N s/m, velocity guard " << c.velocity_guard << " m/s";
    return out.str();
}

}  // namespace hapticd
