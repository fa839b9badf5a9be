// SPDX-License-Identifier: Apache-2.0
// Outside consumer of the installed compiled-mode library hapticopt::compiled (see CMakeLists.txt).
#include <hapticopt/hapticopt.hpp>

#include <cstdio>

int main() {
    const hapticopt::PhysicalPlant plant{0.30, 0.0, 0.0, 0.001, 0.001};
    const hapticopt::WallTuning wall = hapticopt::optimal_wall(hapticopt::Criterion::CE2, plant);
    std::printf("K = %.1f N/m, B = %.2f N s/m\n", wall.K, wall.B);
    return wall.K > 0 ? 0 : 1;
}
