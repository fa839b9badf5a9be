// SPDX-License-Identifier: Apache-2.0
// A random orthogonal projector of rank 1 .. 3 on R^3 (the span of `rank` normally distributed vectors): a mesh
// proxy's contact configuration P at a random orientation, for the tests that judge every configuration.
#pragma once

#include <random>

#include <Eigen/Core>
#include <Eigen/QR>

namespace test_projector {

inline Eigen::Matrix3d random_projector(std::mt19937& rng, int rank) {
    std::normal_distribution<double> normal(0.0, 1.0);
    Eigen::MatrixXd V(3, rank);
    for (int i = 0; i < 3; ++i) {
        for (int j = 0; j < rank; ++j) V(i, j) = normal(rng);
    }
    const Eigen::HouseholderQR<Eigen::MatrixXd> qr(V);
    const Eigen::MatrixXd U = qr.householderQ() * Eigen::MatrixXd::Identity(3, rank);
    return U * U.transpose();
}

}  // namespace test_projector
