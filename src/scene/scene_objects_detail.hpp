// SPDX-License-Identifier: Apache-2.0
// Small vector helpers shared by the files of SceneObjects (scene_objects*.cpp); not part of its interface.
#pragma once

#include <array>
#include <cmath>

#include "common/axis_vector.hpp"

namespace hapticd::scene_objects_detail {

inline double dot(const AxisVector& a, const AxisVector& b) noexcept { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }
inline double norm1(const AxisVector& a) noexcept { return std::fabs(a[0]) + std::fabs(a[1]) + std::fabs(a[2]); }

// The unit quaternion between a and b at w in [0, 1] by normalised linear interpolation along the shorter arc
// (b negated when a.b < 0); w = 1 gives b exactly. A mesh's orientation during a first-order hold.
inline void interpolate_orientation(const std::array<double, 4>& a, const std::array<double, 4>& b, double w,
                                    std::array<double, 4>& out) noexcept {
    if (w >= 1.0) {
        out = b;
        return;
    }
    const double sign = a[0] * b[0] + a[1] * b[1] + a[2] * b[2] + a[3] * b[3] < 0.0 ? -1.0 : 1.0;
    double n2 = 0.0;
    for (std::size_t i = 0; i < 4; ++i) {
        out[i] = (1.0 - w) * a[i] + w * sign * b[i];
        n2 += out[i] * out[i];
    }
    const double inv = n2 > 0.0 ? 1.0 / std::sqrt(n2) : 0.0;
    for (double& c : out) c *= inv;
}

// The rotation matrix of the unit quaternion q = (w, x, y, z), rows.
inline std::array<AxisVector, 3> rotation_of(const std::array<double, 4>& q) noexcept {
    const double w = q[0], x = q[1], y = q[2], z = q[3];
    return {AxisVector{1.0 - 2.0 * (y * y + z * z), 2.0 * (x * y - w * z), 2.0 * (x * z + w * y)},
            AxisVector{2.0 * (x * y + w * z), 1.0 - 2.0 * (x * x + z * z), 2.0 * (y * z - w * x)},
            AxisVector{2.0 * (x * z - w * y), 2.0 * (y * z + w * x), 1.0 - 2.0 * (x * x + y * y)}};
}

}  // namespace hapticd::scene_objects_detail
