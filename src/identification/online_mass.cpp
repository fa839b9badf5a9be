// SPDX-License-Identifier: Apache-2.0
#include "identification/online_mass.hpp"

#include <cmath>
#include <stdexcept>
#include <string>

namespace hapticd {
namespace {

void require(bool ok, const char* name, double value, const char* range) {
    if (!ok) {
        throw std::invalid_argument(std::string("online identification: ") + name + " = " + std::to_string(value) +
                                    " is invalid; accepted: " + range);
    }
}

}  // namespace

OnlineMassIdentifier::OnlineMassIdentifier(const OnlineMassSettings& s) : settings_(s), gripped_(s.start_gripped) {
    require(std::isfinite(s.period) && s.period > 0, "period", s.period, "finite and > 0 s");
    require(s.delay_ticks >= 0 && s.delay_ticks <= kMaxDelayTicks, "delay_ticks", s.delay_ticks, "0 .. 64 periods");
    require(s.half_width >= 1 && s.half_width <= kMaxHalfWidth, "half_width", s.half_width, "1 .. 200 periods");
    require(std::isfinite(s.time_constant) && s.time_constant > 0, "time_constant", s.time_constant,
            "finite and > 0 s");
    require(std::isfinite(s.min_excitation) && s.min_excitation >= 0, "min_excitation", s.min_excitation,
            "finite and >= 0 N");
    require(std::isfinite(s.released_mass) && s.released_mass > 0, "released_mass", s.released_mass,
            "finite and > 0 kg");
    require(std::isfinite(s.mass_tolerance) && s.mass_tolerance >= 0 && s.mass_tolerance <= 0.5, "mass_tolerance",
            s.mass_tolerance, "0 .. 0.5 (relative)");
    require(std::isfinite(s.position_step) && s.position_step >= 0, "position_step", s.position_step,
            "finite and >= 0 m");
    require(s.confirm_release >= 1 && s.confirm_release <= 100000, "confirm_release", s.confirm_release,
            "1 .. 100000 ticks");
    require(s.confirm_grip >= 1 && s.confirm_grip <= 100000, "confirm_grip", s.confirm_grip, "1 .. 100000 ticks");
    forget_ = std::exp(-s.period / s.time_constant);
}

void OnlineMassIdentifier::update(double position, double force) noexcept {
    if (!std::isfinite(position) || !std::isfinite(force)) return;
    const int h = settings_.half_width;
    const int n = settings_.delay_ticks;
    const auto slot = [](std::int64_t tick) { return static_cast<std::size_t>(tick % kCapacity); };
    positions_[slot(count_)] = position;
    forces_[slot(count_)] = force;
    ++count_;
    ++ticks_since_change_;
    // The newest tick is k = count_ - 1 = j + h: the centre j needs u_{j-h-n} .. u_{j+h-1-n} and y_{j-h}.
    const std::int64_t k = count_ - 1;
    const std::int64_t j = k - h;
    if (j - h - n < 0) return;
    const double d = positions_[slot(j + h)] - 2.0 * positions_[slot(j)] + positions_[slot(j - h)];
    const double t2 = settings_.period * settings_.period;
    double u = 0.0;
    for (int i = -h; i < h; ++i) u += (h - std::abs(i + 0.5)) * forces_[slot(j + i - n)];
    u *= t2;
    s0_ = forget_ * s0_ + 1.0;
    su_ = forget_ * su_ + u;
    sd_ = forget_ * sd_ + d;
    suu_ = forget_ * suu_ + u * u;
    sud_ = forget_ * sud_ + u * d;
    const double mean_u = su_ / s0_, mean_d = sd_ / s0_;
    const double var_u = suu_ / s0_ - mean_u * mean_u;
    const double cov = sud_ / s0_ - mean_u * mean_d;
    const double kernel = static_cast<double>(h) * h * t2;  // (h T)^2: U / kernel is a force
    excitation_ = var_u > 0.0 ? std::sqrt(var_u) / kernel : 0.0;
    if (excitation_ >= settings_.min_excitation && cov > 0.0) mass_ = var_u / cov;
    const double m_r = settings_.released_mass;
    residual_ = d - u / m_r;
    residual_bound_ = 2.0 * settings_.position_step + settings_.mass_tolerance * std::abs(u) / m_r;
    const double r = std::abs(residual_);
    agree_ = r <= residual_bound_ ? agree_ + 1 : 0;
    disagree_ = r > 2.0 * residual_bound_ ? disagree_ + 1 : 0;
    const bool next = gripped_ ? agree_ < settings_.confirm_release : disagree_ >= settings_.confirm_grip;
    if (next != gripped_) {
        gripped_ = next;
        ticks_since_change_ = 0;
        s0_ = su_ = sd_ = suu_ = sud_ = 0.0;  // the estimate starts again from the new plant's data
    }
}

}  // namespace hapticd
