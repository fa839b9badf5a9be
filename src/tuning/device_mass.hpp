// SPDX-License-Identifier: Apache-2.0
// The device's mass model: the plant's mass matrix M with the mass along a direction and M^-1/2, used by the
// gain checks (object_checks.hpp), the simulated device and the device profile (config/profile_keys.hpp).
#pragma once

#include <array>
#include <cstddef>
#include <string>

#include <Eigen/Core>

#include "common/axis_vector.hpp"

namespace hapticd {

using MassMatrix = std::array<std::array<double, kMaxAxes>, kMaxAxes>;

// The device's mass (inertia) matrix M of  M x'' + b x' + k x = F  on its first `axes` axes (symmetric
// positive definite there; rows and columns beyond `axes` are 0), with what the checks and the simulated
// device need of it. Computed once at start-up (Eigen, allocates); the accessors are cheap.
//  * The mass along a unit direction n: a force along n that depends only on x_n = n^T x (a plane, a spring
//    to a plane) moves x_n as  n^T x'' = (n^T M^-1 n) f, the scalar loop of mass m_n = 1 / (n^T M^-1 n)
//    (exact when b = k = 0; n^T M n is the kinetic-energy mass of a motion along n, which is not the
//    motion such a force produces unless n is an eigenvector of M).
//  * M^-1/2: in y = M^1/2 x the plant has unit mass on every axis (gain matrices A = T^2 M^-1/2 K M^-1/2).
struct DeviceMass {
    std::size_t axes = 1;
    MassMatrix matrix{};        // M
    MassMatrix inverse{};       // M^-1
    MassMatrix inverse_sqrt{};  // M^-1/2 (symmetric, positive definite)
    bool isotropic = true;      // M = m I
    bool diagonal = true;       // off-diagonal entries exactly 0

    // m I on `axes` axes (m > 0, finite; axes 1 .. 3).
    static DeviceMass isotropic_mass(double mass, std::size_t axes);
    // A symmetric positive-definite M on `axes` axes (validated by validate_mass_keys; symmetrised here).
    static DeviceMass from_matrix(const MassMatrix& M, std::size_t axes);

    // 1 / (n^T M^-1 n) for a unit n in the device's axes (m itself when isotropic). kg.
    [[nodiscard]] double along(const AxisVector& n) const noexcept;
    // The mass along axis a: 1 / (M^-1)_aa (= M_aa for a diagonal M). kg.
    [[nodiscard]] double of_axis(std::size_t a) const noexcept {
        return isotropic ? matrix[0][0] : diagonal ? matrix[a][a] : 1.0 / inverse[a][a];
    }
    // Smallest and largest eigenvalue of M (kg).
    [[nodiscard]] double smallest() const noexcept { return smallest_; }
    [[nodiscard]] double largest() const noexcept { return largest_; }
    // "0.3 kg", "[0.3, 0.3, 0.45] kg per axis" or "matrix [[...], ...] kg" (for messages).
    [[nodiscard]] std::string describe() const;

  private:
    double smallest_ = 0.0, largest_ = 0.0;
};

// The first `axes` rows and columns of M as a 3 x 3 Eigen matrix, zero elsewhere.
Eigen::Matrix3d mass_matrix_eigen(const MassMatrix& m, std::size_t axes);

}  // namespace hapticd
