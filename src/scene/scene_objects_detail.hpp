// SPDX-License-Identifier: Apache-2.0
// Small vector helpers shared by the files of SceneObjects (scene_objects*.cpp); not part of its interface.
#pragma once

#include <cmath>

#include "common/axis_vector.hpp"

namespace hapticd::scene_objects_detail {

inline double dot(const AxisVector& a, const AxisVector& b) noexcept { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }
inline double norm1(const AxisVector& a) noexcept { return std::fabs(a[0]) + std::fabs(a[1]) + std::fabs(a[2]); }

}  // namespace hapticd::scene_objects_detail
