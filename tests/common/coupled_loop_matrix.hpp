// SPDX-License-Identifier: Apache-2.0
// An independent model of the coupled loop on up to three axes for the tests, written without hapticopt's
// polynomials: the state-transition matrix of one period, built from Eigen's matrix exponential of the continuous
// unit-mass plant per axis (x'' = -gamma x - delta x' - u, m = T = 1) over each sub-interval of the period (two for a
// fractional delay), the delayed forces' histories and the velocity estimator's difference equation written out
// below. Its eigenvalues are the coupled loop's roots (with the state's extra zeros); the loop with gains
// f_j = A x_j + B v_j (r x r, any, normalised for unit mass) is stable iff its spectral radius is below 1.
#pragma once

#include <hapticopt/parameters.hpp>

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <unsupported/Eigen/MatrixFunctions>
#include <utility>
#include <vector>

namespace coupled_loop_matrix {

using hapticopt::NormalizedPlant;

// The estimator as the test writes it: v_j = sum_i b[i] x_{j-i} + sum_k a[k-1] v_{j-k}.
//   low-pass: lambda = exp(-2 pi nu), v_j = lambda v_{j-1} + (1 - lambda)(x_j - x_{j-1})
//   window N: v_j = (x_j - x_{j-N}) / N
struct Difference {
    std::vector<double> b, a;
};

inline Difference low_pass(double nu) {
    const double lambda = std::exp(-2.0 * 3.14159265358979323846 * nu);
    return {{1.0 - lambda, lambda - 1.0}, {lambda}};
}

inline Difference window(int n) {
    Difference d;
    d.b.assign(static_cast<std::size_t>(n) + 1, 0.0);
    d.b.front() = 1.0 / n;
    d.b.back() = -1.0 / n;
    return d;
}

// Per axis x'' = -gamma x - delta x' - u (m = T = 1), u constant over a sub-interval of length tau:
// (x, x')(tau) = phi (x, x')(0) + g u, from the exponential of the augmented 3x3 generator.
struct Zoh {
    Eigen::Matrix2d phi;
    Eigen::Vector2d g;
};

inline Zoh zoh(const NormalizedPlant& plant, double tau) {
    Eigen::Matrix3d c;
    c << 0, 1, 0, -plant.gamma, -plant.delta, -1, 0, 0, 0;
    const Eigen::Matrix3d e = (c * tau).exp();
    return {e.topLeftCorner<2, 2>(), e.topRightCorner<2, 1>()};
}

// The loop's state for r axes (r = the gains' size: 3, or fewer for the part of the space where the gains act):
// (x_j, x'_j, x_{j-1} .. x_{j-hx}, v_{j-1} .. v_{j-hv}), each an r-vector. f_j = A x_j + B v_j acts during
// [j + d, j + 1 + d): with d = n + phi (0 <= phi < 1) the period [j, j + 1) sees f_{j-n-1} during [j, j + phi) and
// f_{j-n} during [j + phi, j + 1).
struct Layout {
    int r, hx, hv, size;
    int x(int age) const { return age == 0 ? 0 : r * (age + 1); }
    int xdot() const { return r; }
    int v(int age) const { return r * (2 + hx + age - 1); }
};

inline Eigen::MatrixXd state_matrix(const NormalizedPlant& plant, const Eigen::MatrixXd& A, const Eigen::MatrixXd& B,
                                    const Difference& e) {
    const int n = static_cast<int>(std::floor(plant.delay));
    const double phi = plant.delay - n;
    const int nb = static_cast<int>(e.b.size()), na = static_cast<int>(e.a.size());
    const int r = static_cast<int>(A.rows());
    Layout l{};
    l.r = r;
    l.hx = std::max(n + 1, nb - 1);
    l.hv = std::max({n + 1, na, 1});
    l.size = r * (2 + l.hx + l.hv);
    const Eigen::MatrixXd I = Eigen::MatrixXd::Identity(r, r);
    // Row block (r x size) of v_{j-age}: written out for age 0, a state for age >= 1.
    auto velocity = [&](int age) {
        Eigen::MatrixXd row = Eigen::MatrixXd::Zero(r, l.size);
        if (age > 0) {
            row.block(0, l.v(age), r, r) = I;
            return row;
        }
        for (int i = 0; i < nb; ++i) row.block(0, l.x(i), r, r) += e.b[static_cast<std::size_t>(i)] * I;
        for (int k = 1; k <= na; ++k) row.block(0, l.v(k), r, r) += e.a[static_cast<std::size_t>(k - 1)] * I;
        return row;
    };
    auto force = [&](int age) {
        Eigen::MatrixXd row = B * velocity(age);
        row.block(0, l.x(age), r, r) += A;
        return row;
    };
    const Zoh first = zoh(plant, phi), second = zoh(plant, 1.0 - phi);
    // (x, x')_{j+1} = P2 P1 s + P2 g1 u1 + g2 u2, per axis (Kronecker with I).
    const Eigen::Matrix2d through = second.phi * first.phi;
    const Eigen::Vector2d g1 = second.phi * first.g, g2 = second.g;
    Eigen::MatrixXd M = Eigen::MatrixXd::Zero(l.size, l.size);
    const Eigen::MatrixXd u1 = force(n + 1), u2 = force(n);
    for (int row = 0; row < 2; ++row) {
        const int at = row == 0 ? l.x(0) : l.xdot();
        M.block(at, l.x(0), r, r) += through(row, 0) * I;
        M.block(at, l.xdot(), r, r) += through(row, 1) * I;
        // g carries the wall force's sign (the generator's -1: x'' = ... - f).
        M.block(at, 0, r, l.size) += g1(row) * u1 + g2(row) * u2;
    }
    for (int age = 1; age <= l.hx; ++age) M.block(l.x(age), l.x(age - 1), r, r) = I;
    M.block(l.v(1), 0, r, l.size) = velocity(0);
    for (int age = 2; age <= l.hv; ++age) M.block(l.v(age), l.v(age - 1), r, r) = I;
    return M;
}

inline double state_radius(const NormalizedPlant& plant, const Eigen::MatrixXd& A, const Eigen::MatrixXd& B,
                           const Difference& e) {
    const Eigen::EigenSolver<Eigen::MatrixXd> es(state_matrix(plant, A, B, e), false);
    return es.eigenvalues().cwiseAbs().maxCoeff();
}

// The gains restricted to the span of `normals` (an orthonormal basis from Gram-Schmidt, columns): where planes along
// those normals act. On the orthogonal complement A and B vanish, so the loop there is the free plant's, decoupled.
inline std::pair<Eigen::MatrixXd, Eigen::MatrixXd> on_span(const Eigen::MatrixXd& A, const Eigen::MatrixXd& B,
                                                           const std::vector<Eigen::Vector3d>& normals) {
    std::vector<Eigen::Vector3d> basis;
    for (const Eigen::Vector3d& n : normals) {
        Eigen::Vector3d u = n;
        for (const Eigen::Vector3d& b : basis) u -= u.dot(b) * b;
        if (u.norm() > 1e-9 * n.norm()) basis.push_back(u.normalized());
    }
    Eigen::MatrixXd Q(3, static_cast<Eigen::Index>(basis.size()));
    for (std::size_t i = 0; i < basis.size(); ++i) Q.col(static_cast<Eigen::Index>(i)) = basis[i];
    return {Q.transpose() * A * Q, Q.transpose() * B * Q};
}

}  // namespace coupled_loop_matrix
