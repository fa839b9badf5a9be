// SPDX-License-Identifier: Apache-2.0
#include "scene/wall.hpp"

#include <cmath>
#include <stdexcept>
#include <string>

namespace hapticd {

std::string_view to_string(WallMode mode) noexcept { return mode == WallMode::Bilateral ? "bilateral" : "unilateral"; }

VirtualWall::VirtualWall(const WallGeometry& geometry, double stiffness, double damping, double period)
    : geometry_(geometry), stiffness_(stiffness), damping_(damping), period_(period) {
    auto bad = [](const char* name, double value, const char* range) {
        throw std::invalid_argument(std::string("wall: ") + name + " = " + std::to_string(value) +
                                    " is invalid; accepted range: " + range);
    };
    if (!std::isfinite(stiffness) || stiffness < 0.0) bad("stiffness K", stiffness, "finite, >= 0 N/m");
    if (!std::isfinite(damping) || damping < 0.0) bad("damping B", damping, "finite, >= 0 N s/m");
    if (!std::isfinite(period) || period <= 0.0) bad("period", period, "finite, > 0 s");
    if (geometry.direction != 1.0 && geometry.direction != -1.0) bad("direction", geometry.direction, "+1 or -1");
    if (!std::isfinite(geometry.position)) bad("position", geometry.position, "finite");
    if (geometry.axis >= kMaxAxes) bad("axis", static_cast<double>(geometry.axis), "0 .. 2");
}

}  // namespace hapticd
