// SPDX-License-Identifier: Apache-2.0
// One value per device axis (m, rad, N or N m in the device frame); axes at and above the device's count are unused.
#pragma once

#include <array>
#include <cstddef>

namespace hapticd {

inline constexpr std::size_t kMaxAxes = 3;
using AxisVector = std::array<double, kMaxAxes>;

}  // namespace hapticd
