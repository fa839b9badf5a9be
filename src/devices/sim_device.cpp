// SPDX-License-Identifier: Apache-2.0
#include "devices/sim_device.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <stdexcept>
#include <string>

#include <Eigen/Eigenvalues>

namespace hapticd {

std::string_view to_string(Scenario scenario) noexcept {
    switch (scenario) {
        case Scenario::Step:
            return "step";
        case Scenario::Push:
            return "push";
        case Scenario::Hold:
            return "hold";
        case Scenario::Rest:
            return "rest";
        case Scenario::Path:
            return "path";
    }
    return "unknown";
}

namespace {

void check_hand_parameter(const char* name, double value, const char* unit) {
    if (!(value >= 0.0) || !std::isfinite(value)) {
        throw std::invalid_argument(std::string("SimDevice: hand.") + name + " = " + std::to_string(value) +
                                    " is invalid; accepted range: finite, >= 0 " + unit);
    }
}

}  // namespace

SimDevice::SimDevice(const SimDeviceConfig& config) : config_(config) {
    const double T = config_.period;
    const double d = config_.capabilities.inherent_delay / T;
    // A delay within 1e-9 periods of an integer is that integer (t_d = N/rate is not exact in binary).
    const double nearest = std::round(d);
    const double whole = std::abs(d - nearest) < 1e-9 ? nearest : std::floor(d);
    delay_periods_ = static_cast<std::int64_t>(whole);
    const double phi = d - whole;
    fractional_ = std::abs(d - nearest) >= 1e-9;
    const SimHand& hand = config_.scenario.hand;
    check_hand_parameter("mass", hand.mass, "kg");
    check_hand_parameter("damping", hand.damping, "N s/m");
    check_hand_parameter("stiffness", hand.stiffness, "N/m");
    total_ = PlantParameters{config_.plant.mass + hand.mass, config_.plant.damping + hand.damping,
                             config_.plant.stiffness + hand.stiffness};
    const std::size_t axes = std::min(config_.capabilities.axes, kMaxAxes);
    // M on the device's axes, plus the hand's mass on the diagonal; its eigen-decomposition Q diag(m_i) Q^T.
    const auto n = static_cast<Eigen::Index>(axes);
    Eigen::MatrixXd m = Eigen::MatrixXd::Identity(n, n) * total_.mass;
    if (config_.mass_matrix) {
        const auto& M = *config_.mass_matrix;
        for (Eigen::Index i = 0; i < n; ++i) {
            for (Eigen::Index j = 0; j < n; ++j) {
                const double mij = M[static_cast<std::size_t>(i)][static_cast<std::size_t>(j)];
                const double mji = M[static_cast<std::size_t>(j)][static_cast<std::size_t>(i)];
                if (!std::isfinite(mij)) {
                    throw std::invalid_argument("SimDevice: mass_matrix[" + std::to_string(i) + "][" +
                                                std::to_string(j) + "] = " + std::to_string(mij) +
                                                " is invalid; accepted range: finite");
                }
                m(i, j) = 0.5 * (mij + mji) + (i == j ? hand.mass : 0.0);
            }
        }
    }
    std::array<double, kMaxAxes> modal_mass{};
    modal_mass.fill(total_.mass);
    for (std::size_t a = 0; a < kMaxAxes; ++a) modes_[a][a] = 1.0;
    bool diagonal = true;
    for (Eigen::Index i = 0; i < n; ++i) {
        for (Eigen::Index j = 0; j < n; ++j) diagonal = diagonal && (i == j || m(i, j) == 0.0);
    }
    if (diagonal) {
        for (std::size_t a = 0; a < axes; ++a) {
            const double ma = m(static_cast<Eigen::Index>(a), static_cast<Eigen::Index>(a));
            if (!(ma > 0.0) || !std::isfinite(ma)) {
                throw std::invalid_argument("SimDevice: mass_matrix[" + std::to_string(a) + "][" + std::to_string(a) +
                                            "] = " + std::to_string(ma) +
                                            " is invalid; accepted range: finite, > 0 kg");
            }
            modal_mass[a] = ma;
        }
    } else {
        const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(m);
        if (eig.info() != Eigen::Success || !(eig.eigenvalues().minCoeff() > 0.0)) {
            throw std::invalid_argument("SimDevice: mass_matrix is invalid; accepted: symmetric positive definite");
        }
        for (std::size_t a = 0; a < axes; ++a) {
            modal_mass[a] = eig.eigenvalues()(static_cast<Eigen::Index>(a));
            for (std::size_t i = 0; i < axes; ++i) {
                modes_[i][a] = eig.eigenvectors()(static_cast<Eigen::Index>(i), static_cast<Eigen::Index>(a));
            }
        }
    }
    for (std::size_t a = 0; a < axes; ++a) {
        const double fc = config_.coulomb_friction[a];
        if (!(fc >= 0.0) || !std::isfinite(fc)) {
            throw std::invalid_argument("SimDevice: coulomb_friction[" + std::to_string(a) + "] = " +
                                        std::to_string(fc) + " is invalid; accepted range: finite, >= 0 N (N m)");
        }
        if (fc > 0.0 && !diagonal) {
            throw std::invalid_argument("SimDevice: coulomb_friction[" + std::to_string(a) +
                                        "] = " + std::to_string(fc) +
                                        " is invalid with a non-diagonal mass_matrix (friction along the axes "
                                        "couples the modes); accepted: coulomb_friction = 0, or a diagonal mass");
        }
    }
    for (std::size_t a = axes; a < kMaxAxes; ++a) config_.coulomb_friction[a] = 0.0;
    h_first_ = phi * T;
    h_second_ = (1.0 - phi) * T;
    for (std::size_t a = 0; a < kMaxAxes; ++a) {
        const PlantParameters mode{modal_mass[a], total_.damping, total_.stiffness};
        mode_plant_[a] = mode;
        // The velocity's zeros while sliding are pi / omega_d apart when underdamped (model above); half of that.
        const double sigma = mode.damping / (2.0 * mode.mass);
        const double w2 = mode.stiffness / mode.mass - sigma * sigma;
        slide_piece_[a] = w2 > 0.0 ? 0.5 * std::numbers::pi / std::sqrt(w2) : HUGE_VAL;
        full_[a] = discretize(mode, T);
        if (fractional_) {
            first_[a] = discretize(mode, phi * T);
            second_[a] = discretize(mode, (1.0 - phi) * T);
        }
    }
    history_.assign(static_cast<std::size_t>(delay_periods_ + 2), AxisVector{});
    rng_ = config_.noise_seed == 0 ? 0x9E3779B97F4A7C15ULL : config_.noise_seed;
    reset_state();
}

double SimDevice::physical(const AxisVector& modal, std::size_t axis) const noexcept {
    const std::size_t axes = std::min(config_.capabilities.axes, kMaxAxes);
    double s = 0.0;
    for (std::size_t m = 0; m < axes; ++m) s += modes_[axis][m] * modal[m];
    return axis < axes ? s : 0.0;
}

// The rest position x_H is rest_ plus, for a path, A sin(w t) along the axis; the spring and damper of eq. 1
// act on x - x_H and x' - x_H', so a moving rest is the input k (x_H - rest_) + b x_H' on the displacement
// from rest_, besides the intent's force. Both at the period's middle (t = (tick + 1/2) T): the hand's motion
// is held over a period like the loop's force (error O(T^2) of the path's second derivative).
AxisVector SimDevice::hand_force(std::int64_t tick) const noexcept {
    AxisVector f = external_;
    const SimScenario& s = config_.scenario;
    const double t = (static_cast<double>(tick) + 0.5) * config_.period;
    if (s.kind == Scenario::Path && s.axis < kMaxAxes) {
        const double w = 2.0 * std::numbers::pi * s.path_frequency;
        f[s.axis] += total_.stiffness * s.path_amplitude * std::sin(w * t) +
                     total_.damping * s.path_amplitude * w * std::cos(w * t);
    }
    if (s.kind == Scenario::Push && s.axis < kMaxAxes && s.push_speed > 0.0) {
        // The hand moves in at push_speed until its rest position is on the wall surface, then stays there.
        const bool moving = s.push_speed * t < s.push_distance;
        const double travelled = moving ? s.push_speed * t : s.push_distance;
        f[s.axis] += s.direction * (total_.stiffness * travelled + (moving ? total_.damping * s.push_speed : 0.0));
    }
    return f;
}

void SimDevice::reset_state() noexcept {
    AxisVector x{}, v{};
    external_ = {};
    const SimScenario& s = config_.scenario;
    // The hand's rest position is where the handle starts (hand_force moves it for Path and Push).
    rest_ = s.centre;
    if (s.kind != Scenario::Rest && s.kind != Scenario::Path) rest_[s.axis] = s.surface;
    switch (s.kind) {
        case Scenario::Step:
            external_[s.axis] = s.direction * s.step_force;
            break;
        case Scenario::Push:
            rest_[s.axis] -= s.direction * s.push_distance;
            v[s.axis] = s.direction * s.push_speed;
            external_[s.axis] = s.direction * s.push_force;
            break;
        case Scenario::Hold:
            rest_[s.axis] -= s.direction * s.hold_distance;
            external_[s.axis] = s.direction * s.hold_force;
            break;
        case Scenario::Rest:
        case Scenario::Path:
            break;
    }
    // Into the modal coordinates: y = Q^T x.
    x_ = {};
    v_ = {};
    const std::size_t axes = std::min(config_.capabilities.axes, kMaxAxes);
    for (std::size_t m = 0; m < axes; ++m) {
        for (std::size_t a = 0; a < axes; ++a) {
            x_[m] += modes_[a][m] * x[a];
            v_[m] += modes_[a][m] * v[a];
        }
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

void SimDevice::apply(const std::array<ZohStep, kMaxAxes>& steps, double h, const AxisVector& written_force,
                      const AxisVector& hand) noexcept {
    const std::size_t axes = std::min(config_.capabilities.axes, kMaxAxes);
    AxisVector u{};
    for (std::size_t m = 0; m < axes; ++m) {  // Q^T (F_H + u)
        for (std::size_t a = 0; a < axes; ++a) u[m] += modes_[a][m] * (hand[a] + written_force[a]);
    }
    for (std::size_t m = 0; m < axes; ++m) {
        if (config_.coulomb_friction[m] > 0.0) {  // only with a diagonal M: mode m is axis m
            apply_with_friction(m, steps[m], h, u[m]);
        } else {
            steps[m].apply(x_[m], v_[m], u[m]);
        }
    }
}

void SimDevice::apply_with_friction(std::size_t a, const ZohStep& whole, double h, double u) noexcept {
    const PlantParameters& p = mode_plant_[a];
    const double fc = config_.coulomb_friction[a];
    double& x = x_[a];
    double& v = v_[a];
    double left = h;  // time still to integrate
    for (int stops = 0; stops <= 64 && left > 0.0; ++stops) {
        double s = 0.0;  // the sliding direction
        if (v == 0.0) {
            const double net = u - p.stiffness * x;
            if (std::abs(net) <= fc) return;  // sticks: nothing changes for the rest of the interval
            s = net > 0.0 ? 1.0 : -1.0;
        } else {
            s = v > 0.0 ? 1.0 : -1.0;
        }
        const double force = u - s * fc;
        bool stopped = false;
        while (left > 0.0 && !stopped) {
            const double piece = std::min(left, slide_piece_[a]);
            const ZohStep step = piece == h ? whole : discretize_series(p, piece);
            double xe = x, ve = v;
            step.apply(xe, ve, force);
            if (s * ve > 0.0) {  // still sliding at the piece's end: no zero inside (at most one per piece)
                x = xe;
                v = ve;
                left -= piece;
                continue;
            }
            // The velocity's one zero in (0, piece]: bisection on the exact solution from the piece's start.
            double lo = 0.0, hi = piece, x_hi = xe;
            for (int i = 0; i < 60 && hi - lo > 0.0; ++i) {
                const double mid = 0.5 * (lo + hi);
                if (mid <= lo || mid >= hi) break;
                double xm = x, vm = v;
                discretize_series(p, mid).apply(xm, vm, force);
                if (s * vm > 0.0) {
                    lo = mid;
                } else {
                    hi = mid;
                    x_hi = xm;
                }
            }
            x = x_hi;
            v = 0.0;
            left -= hi;
            stopped = true;
        }
    }
    if (left > 0.0) v = 0.0;  // more than 64 stops in one interval: ends at rest (model above)
}

void SimDevice::advance_period(std::int64_t tick) noexcept {
    const AxisVector hand = hand_force(tick);
    const AxisVector& late = written(tick - delay_periods_);
    if (!fractional_) {
        apply(full_, config_.period, late, hand);
        return;
    }
    apply(first_, h_first_, written(tick - delay_periods_ - 1), hand);
    apply(second_, h_second_, late, hand);
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
        double p = rest_[a] + physical(x_, a);
        if (config_.position_noise > 0.0) {
            p += config_.position_noise * noise();
        }
        if (config_.position_resolution[a] > 0.0) {
            p = std::round(p / config_.position_resolution[a]) * config_.position_resolution[a];
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
