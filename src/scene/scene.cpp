// SPDX-License-Identifier: Apache-2.0
#include "scene/scene.hpp"

#include <cmath>
#include <sstream>
#include <stdexcept>

#include "common/criterion_names.hpp"

namespace hapticd {

std::string_view to_string(SceneFault fault) noexcept {
    switch (fault) {
        case SceneFault::None:
            return "none";
        case SceneFault::NonFinitePosition:
            return "non-finite position";
        case SceneFault::NonFiniteForce:
            return "non-finite force";
    }
    return "unknown";
}

namespace {

bool parse_double(const std::string& s, double& out) {
    if (s.empty()) return false;
    std::size_t used = 0;
    try {
        out = std::stod(s, &used);
    } catch (const std::exception&) {
        return false;
    }
    return used == s.size();
}

}  // namespace

std::optional<WallSpec> parse_wall_spec(const std::string& text, std::string& error) {
    WallSpec spec;
    std::istringstream in(text);
    std::string token;
    bool any = false;
    while (in >> token) {
        any = true;
        const auto eq = token.find('=');
        if (eq == std::string::npos || eq == 0) {
            error = "wall '" + text + "': expected key=value, got '" + token +
                    "'; keys: axis, position, direction, mode, criterion";
            return std::nullopt;
        }
        const std::string key = token.substr(0, eq);
        const std::string value = token.substr(eq + 1);
        double number = 0.0;
        if (key == "axis") {
            if (value != "0" && value != "1" && value != "2") {
                error = "wall '" + text + "': axis = " + value + " is invalid; accepted range: 0, 1, 2";
                return std::nullopt;
            }
            spec.axis = static_cast<std::size_t>(value[0] - '0');
        } else if (key == "position") {
            if (!parse_double(value, number) || !std::isfinite(number)) {
                error = "wall '" + text + "': position = " + value + " is invalid; accepted range: finite number (m)";
                return std::nullopt;
            }
            spec.position = number;
        } else if (key == "direction") {
            if (value == "+1" || value == "1") {
                spec.direction = 1.0;
            } else if (value == "-1") {
                spec.direction = -1.0;
            } else {
                error = "wall '" + text + "': direction = " + value + " is invalid; accepted range: +1, -1";
                return std::nullopt;
            }
        } else if (key == "mode") {
            if (value == "unilateral") {
                spec.mode = WallMode::Unilateral;
            } else if (value == "bilateral") {
                spec.mode = WallMode::Bilateral;
            } else {
                error = "wall '" + text + "': mode = " + value + " is invalid; accepted range: unilateral, bilateral";
                return std::nullopt;
            }
        } else if (key == "criterion") {
            spec.criterion = hapticopt::parse_criterion(value);
            if (!spec.criterion) {
                error = "wall '" + text + "': criterion = " + invalid_criterion_text(value);
                return std::nullopt;
            }
        } else {
            error = "wall '" + text + "': unknown key '" + key + "'; keys: axis, position, direction, mode, criterion";
            return std::nullopt;
        }
    }
    if (!any) {
        error = "wall '': empty specification; expected e.g. 'axis=0 position=0.0 direction=+1'";
        return std::nullopt;
    }
    return spec;
}

std::string to_string(const WallSpec& spec) {
    std::ostringstream out;
    out.precision(17);
    out << "axis=" << spec.axis << " position=" << spec.position << " direction=" << (spec.direction > 0 ? "+1" : "-1");
    if (spec.mode) out << " mode=" << to_string(*spec.mode);
    if (spec.criterion) out << " criterion=" << hapticopt::to_string(*spec.criterion);
    return out.str();
}

Scene::Scene(std::vector<VirtualWall> walls, std::size_t axes, double max_force, const VelocityEstimatorSpec& velocity,
             double period)
    : walls_(std::move(walls)), axes_(axes), max_force_(max_force) {
    if (!velocity.is_backward()) velocity_.emplace(velocity, period);
    if (axes_ == 0 || axes_ > kMaxAxes) {
        throw std::invalid_argument("scene: axes = " + std::to_string(axes_) + " is invalid; accepted range: 1 .. 3");
    }
    if (!std::isfinite(max_force_) || max_force_ <= 0.0) {
        throw std::invalid_argument("scene: max_force = " + std::to_string(max_force_) +
                                    " is invalid; accepted range: finite, > 0");
    }
    for (const auto& w : walls_) {
        if (w.geometry().axis >= axes_) {
            throw std::invalid_argument("scene: wall axis = " + std::to_string(w.geometry().axis) +
                                        " is invalid; accepted range: 0 .. " + std::to_string(axes_ - 1) +
                                        " (the device has " + std::to_string(axes_) + " axes)");
        }
    }
}

SceneFault Scene::evaluate(const AxisVector& position, AxisVector& force) noexcept {
    force = AxisVector{};
    contact_mask_ = 0;
    if (fault_ != SceneFault::None) {
        return fault_;
    }
    for (std::size_t a = 0; a < axes_; ++a) {
        if (!std::isfinite(position[a])) {
            fault_ = SceneFault::NonFinitePosition;
            return fault_;
        }
    }
    std::uint64_t mask = 0;
    std::size_t i = 0;
    const AxisVector* v = velocity_ ? &velocity_->update(position) : nullptr;
    for (auto& wall : walls_) {
        const WallGeometry& g = wall.geometry();
        const double x = wall.penetration(position);
        const double f = v ? wall.normal_force(x, g.direction * (*v)[g.axis]) : wall.normal_force(x);
        force[g.axis] -= g.direction * f;
        if (i < 64) mask |= static_cast<std::uint64_t>(x > 0.0) << i;
        ++i;
    }
    contact_mask_ = mask;
    for (std::size_t a = 0; a < axes_; ++a) {
        if (!std::isfinite(force[a])) {
            force = AxisVector{};
            contact_mask_ = 0;
            fault_ = SceneFault::NonFiniteForce;
            return fault_;
        }
    }
    return SceneFault::None;
}

void Scene::reset() noexcept {
    for (auto& w : walls_) {
        w.reset();
    }
    if (velocity_) velocity_->reset();
    fault_ = SceneFault::None;
}

}  // namespace hapticd
