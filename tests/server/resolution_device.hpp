// SPDX-License-Identifier: Apache-2.0
// The device the in-process object-resolution tests resolve against: 0.3 kg per axis, T = 1 ms, a delay of one
// period, 10 N, workspace +-0.06 m (tests/server/test_object_resolution.cpp, test_mesh_store.cpp).
#pragma once

#include <cstddef>
#include <optional>

#include "server/object_resolution.hpp"

namespace hapticd::server::resolution_device {

inline constexpr double kMass = 0.3, kT = 1e-3;

inline ServerConfig config(std::size_t axes) {
    ServerConfig c;
    c.axes = axes;
    c.period = kT;
    c.delay = kT;
    c.max_force = 10.0;
    c.workspace_min = {-0.06, -0.06, -0.06};
    c.workspace_max = {0.06, 0.06, 0.06};
    return c;
}

inline GainCheckPlant plant(std::size_t axes, std::optional<double> max_stiffness = std::nullopt) {
    GainCheckPlant p;
    p.mass = kMass;
    p.period = kT;
    p.time_delay = kT;
    p.mass_matrix = DeviceMass::isotropic_mass(kMass, axes);
    p.max_stiffness = max_stiffness;
    return p;
}

}  // namespace hapticd::server::resolution_device
