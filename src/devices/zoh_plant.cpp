// SPDX-License-Identifier: Apache-2.0
#include "devices/zoh_plant.hpp"

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

}  // namespace hapticd
