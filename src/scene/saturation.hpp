// SPDX-License-Identifier: Apache-2.0
// The saturation of one force component to the device's maximum, applied per axis by the config-wall scene
// (scene.hpp) and the client objects' scene (scene_objects.hpp) on the real-time path.
#pragma once

namespace hapticd {

// f <- min(max(f, -limit), limit) for a finite f and limit > 0; true when it changed f.
[[nodiscard]] inline bool saturate(double& f, double limit) noexcept {
    const double clamped = f > limit ? limit : f < -limit ? -limit : f;
    const bool changed = clamped != f;
    f = clamped;
    return changed;
}

}  // namespace hapticd
