// SPDX-License-Identifier: Apache-2.0
#include "devices/falcon_kinematics.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>

namespace hapticd::falcon {

namespace {

struct LegPoint {
    double u, v, w;
};

LegPoint to_leg(const Vec3& p, double phi, const Geometry& g) noexcept {
    const double cp = std::cos(phi);
    const double sp = std::sin(phi);
    return {cp * p[0] + sp * p[1] - g.r, -sp * p[0] + cp * p[1] - g.s, p[2]};
}

struct LegSolution {
    double theta1 = 0.0;
    double cos3 = 0.0, sin3 = 0.0, L = 0.0;
};

bool solve_leg(const LegPoint& q, const Geometry& g, LegSolution& out) noexcept {
    const double cos3 = (q.v + g.f) / g.b;
    if (!(std::abs(cos3) < 1.0)) return false;
    const double sin3 = std::sqrt(1.0 - cos3 * cos3);
    const double L = g.d + g.e + g.b * sin3;
    const double X = q.u + g.c;
    const double rho = std::hypot(X, q.w);
    if (!(rho > 0.0)) return false;
    const double cos_beta = (rho * rho + g.a * g.a - L * L) / (2.0 * g.a * rho);
    if (!(std::abs(cos_beta) <= 1.0)) return false;
    out.theta1 = std::atan2(q.w, X) - std::acos(cos_beta);
    out.cos3 = cos3;
    out.sin3 = sin3;
    out.L = L;
    return true;
}

}  // namespace

Geometry Geometry::published() noexcept {
    Geometry g;
    constexpr double pi = std::numbers::pi;
    constexpr double offset = pi / 12.0;  // each leg is tilted 15 deg from the desk plane
    g.leg_angle = {pi / 2.0 + offset, -pi / 6.0 + offset, -5.0 * pi / 6.0 + offset};
    g.theta_offset = 35.0 * pi / 180.0;
    return g;
}

double encoder_to_angle(std::int32_t count, const Geometry& g) noexcept {
    // Shaft arc per count divided by the capstan radius: (pi d_shaft / (4 slots)) / (D_arm / 2).
    const double rad_per_count = (std::numbers::pi * g.shaft_diameter / (4.0 * g.wheel_slots)) / (g.arm_diameter / 2.0);
    return g.theta_offset + rad_per_count * static_cast<double>(count);
}

bool inverse_kinematics(const Vec3& p, const Geometry& g, Vec3& theta) noexcept {
    for (std::size_t i = 0; i < 3; ++i) {
        LegSolution s;
        if (!solve_leg(to_leg(p, g.leg_angle[i], g), g, s)) return false;
        theta[i] = s.theta1;
    }
    return true;
}

bool angle_jacobian(const Vec3& p, const Geometry& g, Mat3& A) noexcept {
    for (std::size_t i = 0; i < 3; ++i) {
        const double phi = g.leg_angle[i];
        const LegPoint q = to_leg(p, phi, g);
        LegSolution s;
        if (!solve_leg(q, g, s)) return false;
        // G(u, v, w, theta1) = (X - a cos t)^2 + (w - a sin t)^2 - L(v)^2 = 0,  X = u + c.
        const double X = q.u + g.c;
        const double ct = std::cos(s.theta1);
        const double st = std::sin(s.theta1);
        const double dG_dtheta = 2.0 * g.a * (X * st - q.w * ct);
        if (!(std::abs(dG_dtheta) > 1e-12)) return false;
        const double dG_du = 2.0 * (X - g.a * ct);
        const double dG_dw = 2.0 * (q.w - g.a * st);
        // dL/dv = b d(sin theta3)/dv = -cos3 / sin3  (cos3 = (v + f) / b).
        const double dG_dv = 2.0 * s.L * s.cos3 / s.sin3;
        const double cp = std::cos(phi);
        const double sp = std::sin(phi);
        const double dG_dx = dG_du * cp - dG_dv * sp;
        const double dG_dy = dG_du * sp + dG_dv * cp;
        A[i] = {-dG_dx / dG_dtheta, -dG_dy / dG_dtheta, -dG_dw / dG_dtheta};
    }
    return true;
}

bool invert(const Mat3& m, Mat3& inv, double min_det) noexcept {
    const double c00 = m[1][1] * m[2][2] - m[1][2] * m[2][1];
    const double c01 = m[1][2] * m[2][0] - m[1][0] * m[2][2];
    const double c02 = m[1][0] * m[2][1] - m[1][1] * m[2][0];
    const double det = m[0][0] * c00 + m[0][1] * c01 + m[0][2] * c02;
    if (!(std::abs(det) > min_det) || !std::isfinite(det)) return false;
    const double k = 1.0 / det;
    inv[0] = {c00 * k, (m[0][2] * m[2][1] - m[0][1] * m[2][2]) * k, (m[0][1] * m[1][2] - m[0][2] * m[1][1]) * k};
    inv[1] = {c01 * k, (m[0][0] * m[2][2] - m[0][2] * m[2][0]) * k, (m[0][2] * m[1][0] - m[0][0] * m[1][2]) * k};
    inv[2] = {c02 * k, (m[0][1] * m[2][0] - m[0][0] * m[2][1]) * k, (m[0][0] * m[1][1] - m[0][1] * m[1][0]) * k};
    return true;
}

ForwardResult forward_kinematics(const Vec3& theta, const Geometry& g, Vec3& p, int max_iterations, double tolerance,
                                 double max_step) noexcept {
    ForwardResult r;
    Vec3 x = p;
    for (int it = 0; it <= max_iterations; ++it) {
        Vec3 th{};
        Mat3 A{};
        Mat3 Ainv{};
        if (!inverse_kinematics(x, g, th) || !angle_jacobian(x, g, A) || !invert(A, Ainv)) {
            r.iterations = it;
            r.residual = INFINITY;
            return r;
        }
        Vec3 err{theta[0] - th[0], theta[1] - th[1], theta[2] - th[2]};
        r.residual = std::max({std::abs(err[0]), std::abs(err[1]), std::abs(err[2])});
        r.iterations = it;
        if (r.residual <= tolerance) {
            r.converged = true;
            p = x;
            return r;
        }
        if (it == max_iterations) break;
        Vec3 step{};
        for (std::size_t i = 0; i < 3; ++i) step[i] = Ainv[i][0] * err[0] + Ainv[i][1] * err[1] + Ainv[i][2] * err[2];
        const double len = std::sqrt(step[0] * step[0] + step[1] * step[1] + step[2] * step[2]);
        const double scale = len > max_step ? max_step / len : 1.0;
        for (std::size_t i = 0; i < 3; ++i) x[i] += scale * step[i];
    }
    return r;
}

bool force_to_torque(const Vec3& p, const Vec3& F, const Geometry& g, Vec3& tau) noexcept {
    Mat3 A{};
    Mat3 Ainv{};
    if (!angle_jacobian(p, g, A) || !invert(A, Ainv)) return false;
    // tau = (A^-1)^T F
    for (std::size_t j = 0; j < 3; ++j) tau[j] = Ainv[0][j] * F[0] + Ainv[1][j] * F[1] + Ainv[2][j] * F[2];
    return true;
}

}  // namespace hapticd::falcon
