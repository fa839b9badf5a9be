// SPDX-License-Identifier: Apache-2.0
#include "devices/zoh_plant.hpp"

#include <algorithm>
#include <array>
#include <cmath>

#include <Eigen/Core>
#include <unsupported/Eigen/MatrixFunctions>

namespace hapticd {

ZohStep discretize(const PlantParameters& plant, double h) {
    ZohStep step;
    if (h == 0.0) {
        return step;
    }
    Eigen::Matrix3d m = Eigen::Matrix3d::Zero();
    m(0, 1) = 1.0;
    m(1, 0) = -plant.stiffness / plant.mass;
    m(1, 1) = -plant.damping / plant.mass;
    m(1, 2) = 1.0 / plant.mass;
    const Eigen::Matrix3d e = (m * h).exp();
    step.phi = {e(0, 0), e(0, 1), e(1, 0), e(1, 1)};
    step.gamma = {e(0, 2), e(1, 2)};
    return step;
}

ZohStep discretize_series(const PlantParameters& plant, double h) noexcept {
    using M3 = std::array<double, 9>;  // row-major 3x3
    auto mul = [](const M3& a, const M3& b) noexcept {
        M3 c{};
        for (int i = 0; i < 3; ++i) {
            for (int j = 0; j < 3; ++j) {
                double s = 0.0;
                for (int k = 0; k < 3; ++k) s += a[3 * i + k] * b[3 * k + j];
                c[3 * i + j] = s;
            }
        }
        return c;
    };
    ZohStep step;
    if (h == 0.0) return step;
    M3 a{0.0, h,   0.0, -plant.stiffness / plant.mass * h, -plant.damping / plant.mass * h, h / plant.mass,
         0.0, 0.0, 0.0};
    double norm = 0.0;
    for (int i = 0; i < 3; ++i) {
        norm = std::max(norm, std::abs(a[3 * i]) + std::abs(a[3 * i + 1]) + std::abs(a[3 * i + 2]));
    }
    int squarings = 0;
    if (norm > 0.5) squarings = static_cast<int>(std::ceil(std::log2(norm / 0.5)));
    const double scale = std::ldexp(1.0, -squarings);
    for (double& e : a) e *= scale;
    M3 e{1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0};
    M3 term = e;
    for (int n = 1; n <= 20; ++n) {
        term = mul(term, a);
        for (double& t : term) t /= n;
        for (int i = 0; i < 9; ++i) e[i] += term[i];
    }
    for (int s = 0; s < squarings; ++s) e = mul(e, e);
    step.phi = {e[0], e[1], e[3], e[4]};
    step.gamma = {e[2], e[5]};
    return step;
}

}  // namespace hapticd
