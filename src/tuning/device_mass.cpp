// SPDX-License-Identifier: Apache-2.0
#include "tuning/device_mass.hpp"

#include "common/number_text.hpp"

#include <cmath>
#include <vector>

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>

namespace hapticd {

namespace {

MassMatrix from_eigen(const Eigen::MatrixXd& e) {
    MassMatrix m{};
    for (Eigen::Index i = 0; i < e.rows(); ++i) {
        for (Eigen::Index j = 0; j < e.cols(); ++j)
            m[static_cast<std::size_t>(i)][static_cast<std::size_t>(j)] = e(i, j);
    }
    return m;
}

}  // namespace

Eigen::Matrix3d mass_matrix_eigen(const MassMatrix& m, std::size_t axes) {
    Eigen::Matrix3d e = Eigen::Matrix3d::Zero();
    for (std::size_t i = 0; i < axes; ++i) {
        for (std::size_t j = 0; j < axes; ++j) e(static_cast<int>(i), static_cast<int>(j)) = m[i][j];
    }
    return e;
}

DeviceMass DeviceMass::isotropic_mass(double mass, std::size_t axes) {
    DeviceMass d;
    d.axes = axes;
    for (std::size_t a = 0; a < axes; ++a) {
        d.matrix[a][a] = mass;
        d.inverse[a][a] = 1.0 / mass;
        d.inverse_sqrt[a][a] = 1.0 / std::sqrt(mass);
    }
    d.smallest_ = d.largest_ = mass;
    return d;
}

DeviceMass DeviceMass::from_matrix(const MassMatrix& M, std::size_t axes) {
    const auto n = static_cast<Eigen::Index>(axes);
    const Eigen::Matrix3d full = mass_matrix_eigen(M, axes);
    const Eigen::MatrixXd m = 0.5 * (full.topLeftCorner(n, n) + full.topLeftCorner(n, n).transpose());
    bool diagonal = true, isotropic = true;
    for (Eigen::Index i = 0; i < n; ++i) {
        for (Eigen::Index j = 0; j < n; ++j) {
            if (i != j && m(i, j) != 0.0) diagonal = false;
        }
        if (m(i, i) != m(0, 0)) isotropic = false;
    }
    if (diagonal && isotropic) return isotropic_mass(m(0, 0), axes);
    DeviceMass d;
    d.axes = axes;
    d.isotropic = false;
    d.diagonal = diagonal;
    d.matrix = from_eigen(m);
    if (diagonal) {  // exact per axis: no eigen-decomposition rounding
        for (std::size_t a = 0; a < axes; ++a) {
            d.inverse[a][a] = 1.0 / d.matrix[a][a];
            d.inverse_sqrt[a][a] = 1.0 / std::sqrt(d.matrix[a][a]);
        }
        d.smallest_ = m.diagonal().minCoeff();
        d.largest_ = m.diagonal().maxCoeff();
        return d;
    }
    // M = V diag(lambda) V^T: M^-1 = V diag(1/lambda) V^T, M^-1/2 = V diag(lambda^-1/2) V^T (symmetric).
    const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> es(m);
    const Eigen::MatrixXd& V = es.eigenvectors();
    const Eigen::VectorXd lambda = es.eigenvalues();
    const Eigen::MatrixXd inv = V * lambda.cwiseInverse().asDiagonal() * V.transpose();
    const Eigen::MatrixXd inv_sqrt = V * lambda.cwiseSqrt().cwiseInverse().asDiagonal() * V.transpose();
    d.inverse = from_eigen(0.5 * (inv + inv.transpose()));
    d.inverse_sqrt = from_eigen(0.5 * (inv_sqrt + inv_sqrt.transpose()));
    d.smallest_ = lambda.minCoeff();
    d.largest_ = lambda.maxCoeff();
    return d;
}

double DeviceMass::along(const AxisVector& n) const noexcept {
    if (isotropic) return matrix[0][0];
    double q = 0.0;  // n^T M^-1 n
    for (std::size_t i = 0; i < axes; ++i) {
        for (std::size_t j = 0; j < axes; ++j) q += n[i] * inverse[i][j] * n[j];
    }
    return 1.0 / q;
}

std::string DeviceMass::describe() const {
    if (isotropic) return short_number(matrix[0][0]) + " kg";
    if (diagonal) {
        std::vector<double> v;
        for (std::size_t a = 0; a < axes; ++a) v.push_back(matrix[a][a]);
        return number_list(v) + " kg per axis";
    }
    std::string out = "matrix [";
    for (std::size_t i = 0; i < axes; ++i) {
        std::vector<double> row(matrix[i].begin(), matrix[i].begin() + static_cast<std::ptrdiff_t>(axes));
        out += (i ? ", " : "") + number_list(row);
    }
    return out + "] kg";
}

}  // namespace hapticd
