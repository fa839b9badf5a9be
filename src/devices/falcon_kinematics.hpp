// SPDX-License-Identifier: Apache-2.0
// Delta kinematics of the Novint Falcon: encoder counts -> motor (upper-arm) angles -> Cartesian
// position, and Cartesian force -> motor torques by the Jacobian transpose.
//
// Geometry and leg model: R. E. Stamper's parallel manipulator with the Falcon's published dimensions
// (libnifalcon include/falcon/core/FalconGeometry.h, values a..s and the leg angles phy; model of
// libnifalcon FalconKinematicStamper.cpp). For leg i at angle phi_i the end-effector position p is
// seen in the leg frame as
//   u = cos(phi) x + sin(phi) y - r,   v = -sin(phi) x + cos(phi) y - s,   w = z,
// and the leg closes when
//   v = b cos(theta3) - f,
//   (u + c - a cos(theta1))^2 + (w - a sin(theta1))^2 = L^2,   L = d + e + b sin(theta3),
// theta1 being the motor angle (the upper arm's rotation). The inverse kinematics solves this in
// closed form (the elbow-out branch the Falcon is built in); the forward kinematics runs Newton's
// method on it; the Jacobian A = d theta1 / d p follows by implicit differentiation.
// Encoder -> angle (libnifalcon FalconKinematic.h getTheta()): 320-slot wheel read in quadrature
// (4 counts per slot) on a 14.25 mm shaft driving a 110 mm arm capstan; 35 deg at count 0.
// Torque -> protocol (libnifalcon FalconKinematicStamper::getForces): command = -10000 * torque (N m).
#pragma once

#include <array>
#include <cstdint>

namespace hapticd::falcon {

using Vec3 = std::array<double, 3>;
using Mat3 = std::array<Vec3, 3>;  // row-major

struct Geometry {
    double a = 0.060;     // m, leg base to knee
    double b = 0.1025;    // m, shin parallelogram side
    double c = 0.01443;   // m, shin connection to effector centre, u component
    double d = 0.01125;   // m, shin to effector joint
    double e = 0.01125;   // m, knee to shin joint (= d)
    double f = -0.025;    // m, shin connection to effector centre, v component
    double r = 0.0400;    // m, frame origin to leg base, u component
    double s = -0.02309;  // m, frame origin to leg base, v component
    Vec3 leg_angle{};     // rad, phy[i]: pi/2 + pi/12, -pi/6 + pi/12, -5 pi/6 + pi/12
    double wheel_slots = 320.0;
    double shaft_diameter = 0.01425;  // m
    double arm_diameter = 0.110;      // m
    double theta_offset = 0.0;        // rad, angle at encoder count 0 (35 deg)
    double torque_to_command = -10000.0;

    static Geometry published() noexcept;
};

// Motor angle (rad) of an encoder count.
double encoder_to_angle(std::int32_t count, const Geometry& g) noexcept;

// Motor angles of position p (m). false when p is outside the reachable set.
bool inverse_kinematics(const Vec3& p, const Geometry& g, Vec3& theta) noexcept;

// A = d theta / d p at p (rad/m), rows = legs. false outside the reachable set or at a singularity.
bool angle_jacobian(const Vec3& p, const Geometry& g, Mat3& A) noexcept;

// Inverse of a 3x3 matrix; false when |det| is below `min_det`.
bool invert(const Mat3& m, Mat3& inverse, double min_det = 1e-300) noexcept;

struct ForwardResult {
    bool converged = false;
    int iterations = 0;
    double residual = 0.0;  // max |theta(p) - theta| at the end, rad
};

// Newton on the inverse kinematics: p holds the initial guess (e.g. the previous position) on entry
// and the solution on exit. Step length is limited to max_step (m) for robustness far from the guess.
ForwardResult forward_kinematics(const Vec3& theta, const Geometry& g, Vec3& p, int max_iterations = 30,
                                 double tolerance = 1e-12, double max_step = 0.01) noexcept;

// Motor torques tau (N m) that produce the Cartesian force F (N) at p: tau = A^-T F (virtual work:
// tau . theta_dot = F . p_dot with theta_dot = A p_dot). false at a singularity / outside.
bool force_to_torque(const Vec3& p, const Vec3& F, const Geometry& g, Vec3& tau) noexcept;

}  // namespace hapticd::falcon
