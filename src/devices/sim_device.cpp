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
    check_hand_parameter("release_mass", hand.release_mass, "kg");
    h_first_ = phi * T;
    h_second_ = (1.0 - phi) * T;
    const auto& schedule = config_.scenario.schedule;
    plants_.reserve(schedule.size() + 1);
    plants_.push_back(build_plant(hand.mass, true, hand.damping, hand.stiffness, phi, "the plant"));
    // The schedule's plants, in order (config/hand_schedule.hpp checks the order and the held/released sequence;
    // a grip while held or a release while released is refused here too).
    bool held = true;
    double b_H = hand.damping, k_H = hand.stiffness;
    double previous_time = -1.0;
    for (std::size_t i = 0; i < schedule.size(); ++i) {
        const HandEvent& e = schedule[i];
        const std::string what = "schedule[" + std::to_string(i) + "] (" + std::string(to_string(e.kind)) + " at " +
                                 std::to_string(e.time) + " s)";
        if (!std::isfinite(e.time) || !(e.time > previous_time) || e.time < 0.0) {
            throw std::invalid_argument("SimDevice: " + what +
                                        " is invalid; accepted: finite times >= 0 s, strictly increasing");
        }
        previous_time = e.time;
        switch (e.kind) {
            case HandEventKind::Release:
                if (!held) throw std::invalid_argument("SimDevice: " + what + ": the hand is already off the handle");
                held = false;
                break;
            case HandEventKind::Grip:
                if (held) throw std::invalid_argument("SimDevice: " + what + ": the hand already holds the handle");
                held = true;
                break;
            case HandEventKind::Arm:
                if (e.stiffness) {
                    check_hand_parameter("stiffness", *e.stiffness, "N/m");
                    k_H = *e.stiffness;
                }
                if (e.damping) {
                    check_hand_parameter("damping", *e.damping, "N s/m");
                    b_H = *e.damping;
                }
                break;
        }
        plants_.push_back(held ? build_plant(hand.mass, true, b_H, k_H, phi, what)
                               : build_plant(-hand.release_mass, false, 0.0, 0.0, phi, what));
        HandEventRecord r;
        r.event = e;
        events_.push_back(r);
        // The first period boundary at or after the event (a time within 1e-9 periods of one is that one).
        const double at = e.time / T;
        const double boundary = std::round(at);
        due_.push_back(static_cast<std::int64_t>(std::abs(at - boundary) < 1e-9 ? boundary : std::ceil(at)));
    }
    const std::size_t axes = std::min(config_.capabilities.axes, kMaxAxes);
    for (std::size_t a = 0; a < axes; ++a) {
        const double fc = config_.coulomb_friction[a];
        if (!(fc >= 0.0) || !std::isfinite(fc)) {
            throw std::invalid_argument("SimDevice: coulomb_friction[" + std::to_string(a) + "] = " +
                                        std::to_string(fc) + " is invalid; accepted range: finite, >= 0 N (N m)");
        }
        if (fc > 0.0 && !diagonal_) {
            throw std::invalid_argument("SimDevice: coulomb_friction[" + std::to_string(a) +
                                        "] = " + std::to_string(fc) +
                                        " is invalid with a non-diagonal mass_matrix (friction along the axes "
                                        "couples the modes); accepted: coulomb_friction = 0, or a diagonal mass");
        }
    }
    for (std::size_t a = axes; a < kMaxAxes; ++a) config_.coulomb_friction[a] = 0.0;
    plant_ = &plants_.front();
    history_.assign(static_cast<std::size_t>(delay_periods_ + 2), AxisVector{});
    rng_ = config_.noise_seed == 0 ? 0x9E3779B97F4A7C15ULL : config_.noise_seed;
    reset_state();
}

SimDevice::ModalPlant SimDevice::build_plant(double mass_delta, bool held, double hand_damping, double hand_stiffness,
                                             double phi, const std::string& what) {
    ModalPlant p;
    p.held = held;
    p.hand_damping = hand_damping;
    p.hand_stiffness = hand_stiffness;
    const double T = config_.period;
    p.total = PlantParameters{config_.plant.mass + mass_delta, config_.plant.damping + hand_damping,
                              config_.plant.stiffness + hand_stiffness};
    const std::size_t axes = std::min(config_.capabilities.axes, kMaxAxes);
    // M on the device's axes, plus the hand's mass on the diagonal; its eigen-decomposition Q diag(m_i) Q^T.
    const auto n = static_cast<Eigen::Index>(axes);
    Eigen::MatrixXd m = Eigen::MatrixXd::Identity(n, n) * p.total.mass;
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
                m(i, j) = 0.5 * (mij + mji) + (i == j ? mass_delta : 0.0);
            }
        }
    }
    // Without the hand (a release) the mass must stay positive: name the hand's part that made it not.
    const std::string released =
        held ? std::string()
             : " after " + what + ": the plant's mass less hand.release_mass = " + std::to_string(-mass_delta) +
                   " kg; accepted: hand.release_mass below the plant's mass";
    std::array<double, kMaxAxes> modal_mass{};
    modal_mass.fill(p.total.mass);
    for (std::size_t a = 0; a < kMaxAxes; ++a) p.modes[a][a] = 1.0;
    bool diagonal = true;
    for (Eigen::Index i = 0; i < n; ++i) {
        for (Eigen::Index j = 0; j < n; ++j) diagonal = diagonal && (i == j || m(i, j) == 0.0);
    }
    diagonal_ = diagonal;
    if (diagonal) {
        for (std::size_t a = 0; a < axes; ++a) {
            const double ma = m(static_cast<Eigen::Index>(a), static_cast<Eigen::Index>(a));
            if (!(ma > 0.0) || !std::isfinite(ma)) {
                throw std::invalid_argument("SimDevice: mass_matrix[" + std::to_string(a) + "][" + std::to_string(a) +
                                            "] = " + std::to_string(ma) +
                                            " is invalid; accepted range: finite, > 0 kg" + released);
            }
            modal_mass[a] = ma;
        }
    } else {
        const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(m);
        if (eig.info() != Eigen::Success || !(eig.eigenvalues().minCoeff() > 0.0)) {
            throw std::invalid_argument("SimDevice: mass_matrix is invalid; accepted: symmetric positive definite" +
                                        released);
        }
        for (std::size_t a = 0; a < axes; ++a) {
            modal_mass[a] = eig.eigenvalues()(static_cast<Eigen::Index>(a));
            for (std::size_t i = 0; i < axes; ++i) {
                p.modes[i][a] = eig.eigenvectors()(static_cast<Eigen::Index>(i), static_cast<Eigen::Index>(a));
            }
        }
    }
    for (std::size_t a = 0; a < kMaxAxes; ++a) {
        p.axis_mass[a] = a < axes ? m(static_cast<Eigen::Index>(a), static_cast<Eigen::Index>(a)) : p.total.mass;
    }
    for (std::size_t a = 0; a < kMaxAxes; ++a) {
        const PlantParameters mode{modal_mass[a], p.total.damping, p.total.stiffness};
        p.mode_plant[a] = mode;
        // The velocity's zeros while sliding are pi / omega_d apart when underdamped (model above); half of that.
        const double sigma = mode.damping / (2.0 * mode.mass);
        const double w2 = mode.stiffness / mode.mass - sigma * sigma;
        p.slide_piece[a] = w2 > 0.0 ? 0.5 * std::numbers::pi / std::sqrt(w2) : HUGE_VAL;
        p.full[a] = discretize(mode, T);
        if (fractional_) {
            p.first[a] = discretize(mode, phi * T);
            p.second[a] = discretize(mode, (1.0 - phi) * T);
        }
    }
    return p;
}

double SimDevice::physical(const AxisVector& modal, std::size_t axis) const noexcept {
    const std::size_t axes = std::min(config_.capabilities.axes, kMaxAxes);
    double s = 0.0;
    for (std::size_t m = 0; m < axes; ++m) s += plant_->modes[axis][m] * modal[m];
    return axis < axes ? s : 0.0;
}

// The rest position x_H is rest_ plus, for a path, A sin(w t) along the axis; the spring and damper of eq. 1
// act on x - x_H and x' - x_H', so a moving rest is the input k (x_H - rest_) + b x_H' on the displacement
// from rest_, besides the intent's force. Both at the period's middle (t = (tick + 1/2) T): the hand's motion
// is held over a period like the loop's force (error O(T^2) of the path's second derivative).
// After a grip the rest is offset by hand_offset_ (the input k_H hand_offset_). Released, the hand exerts nothing.
AxisVector SimDevice::hand_force(std::int64_t tick) const noexcept {
    AxisVector f = external_;
    if (!plant_->held) return f;  // external_ is zero while released
    const SimScenario& s = config_.scenario;
    const PlantParameters& total = plant_->total;
    const double t = (static_cast<double>(tick) + 0.5) * config_.period;
    if (s.kind == Scenario::Path && s.axis < kMaxAxes) {
        const double w = 2.0 * std::numbers::pi * s.path_frequency;
        f[s.axis] += total.stiffness * s.path_amplitude * std::sin(w * t) +
                     total.damping * s.path_amplitude * w * std::cos(w * t);
    }
    if (s.kind == Scenario::Push && s.axis < kMaxAxes && s.push_speed > 0.0) {
        // The hand moves in at push_speed until its rest position is on the wall surface, then stays there.
        const bool moving = s.push_speed * t < s.push_distance;
        const double travelled = moving ? s.push_speed * t : s.push_distance;
        f[s.axis] += s.direction * (total.stiffness * travelled + (moving ? total.damping * s.push_speed : 0.0));
    }
    if (next_event_ > 0) {  // gripped again at least once: x_H = rest_ + motion + hand_offset_
        for (std::size_t a = 0; a < kMaxAxes; ++a) f[a] += plant_->hand_stiffness * hand_offset_[a];
    }
    return f;
}

double SimDevice::intent_motion(double t) const noexcept {
    const SimScenario& s = config_.scenario;
    if (s.kind == Scenario::Path) return s.path_amplitude * std::sin(2.0 * std::numbers::pi * s.path_frequency * t);
    if (s.kind == Scenario::Push && s.push_speed > 0.0) {
        return s.direction * std::min(s.push_speed * t, s.push_distance);
    }
    return 0.0;
}

void SimDevice::apply_event(std::size_t index, std::int64_t tick) noexcept {
    const std::size_t axes = std::min(config_.capabilities.axes, kMaxAxes);
    AxisVector x{}, v{};  // the state in the device's axes (displacement from rest_)
    for (std::size_t a = 0; a < axes; ++a) {
        x[a] = physical(x_, a);
        v[a] = physical(v_, a);
    }
    const ModalPlant& next = plants_[index + 1];
    HandEventRecord& r = events_[index];
    if (r.event.kind == HandEventKind::Release) external_ = AxisVector{};
    if (r.event.kind == HandEventKind::Grip) {
        // x_H at the grip = the handle: the offset from the intent's own rest at t = n T.
        const SimScenario& s = config_.scenario;
        const double motion = intent_motion(static_cast<double>(tick) * config_.period);
        for (std::size_t a = 0; a < axes; ++a) hand_offset_[a] = x[a] - (a == s.axis ? motion : 0.0);
        external_ = intent_;
    }
    plant_ = &next;
    // Position and velocity are continuous: y = Q^T x in the new modes.
    x_ = {};
    v_ = {};
    for (std::size_t m = 0; m < axes; ++m) {
        for (std::size_t a = 0; a < axes; ++a) {
            x_[m] += plant_->modes[a][m] * x[a];
            v_[m] += plant_->modes[a][m] * v[a];
        }
    }
    const std::size_t axis = std::min(config_.scenario.axis, kMaxAxes - 1);
    r.tick = tick;
    r.mass = next.axis_mass[axis];
    r.stiffness = next.hand_stiffness;
    r.damping = next.hand_damping;
    r.position = rest_[axis] + x[axis];
    r.velocity = v[axis];
}

void SimDevice::reset_state() noexcept {
    AxisVector x{}, v{};
    external_ = {};
    plant_ = &plants_.front();
    next_event_ = 0;
    hand_offset_ = {};
    for (HandEventRecord& r : events_) r.tick = -1;
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
    intent_ = external_;
    // Into the modal coordinates: y = Q^T x.
    x_ = {};
    v_ = {};
    const std::size_t axes = std::min(config_.capabilities.axes, kMaxAxes);
    for (std::size_t m = 0; m < axes; ++m) {
        for (std::size_t a = 0; a < axes; ++a) {
            x_[m] += plant_->modes[a][m] * x[a];
            v_[m] += plant_->modes[a][m] * v[a];
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
        for (std::size_t a = 0; a < axes; ++a) u[m] += plant_->modes[a][m] * (hand[a] + written_force[a]);
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
    const PlantParameters& p = plant_->mode_plant[a];
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
            const double piece = std::min(left, plant_->slide_piece[a]);
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
    while (next_event_ < due_.size() && due_[next_event_] <= tick) {
        apply_event(next_event_, tick);
        ++next_event_;
    }
    const AxisVector hand = hand_force(tick);
    const AxisVector& late = written(tick - delay_periods_);
    if (!fractional_) {
        apply(plant_->full, config_.period, late, hand);
        return;
    }
    apply(plant_->first, h_first_, written(tick - delay_periods_ - 1), hand);
    apply(plant_->second, h_second_, late, hand);
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
