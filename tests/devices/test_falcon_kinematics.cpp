// SPDX-License-Identifier: Apache-2.0
// Falcon delta kinematics (geometry: libnifalcon FalconGeometry.h; model: Stamper, as in
// falcon_kinematics.hpp).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <numbers>
#include <random>

#include "common/test_paths.hpp"
#include "config/options.hpp"
#include "devices/falcon_kinematics.hpp"

namespace hapticd::falcon {
namespace {

const Geometry kGeometry = Geometry::published();
const Vec3 kCentre{0.0, 0.0, 0.125};

double max_abs_diff(const Vec3& a, const Vec3& b) {
    return std::max({std::abs(a[0] - b[0]), std::abs(a[1] - b[1]), std::abs(a[2] - b[2])});
}

TEST(FalconKinematics, EncoderToAngle) {
    // libnifalcon getTheta(): 35 deg at count 0; per count (pi 0.01425 / (4 * 320)) / (0.110 / 2) rad
    // = 0.0447677 / 1280 / 0.055 = 6.359053e-4 rad. Tolerance 1e-9 rad: only rounding of the constants.
    EXPECT_NEAR(encoder_to_angle(0, kGeometry), 35.0 * std::numbers::pi / 180.0, 1e-12);
    EXPECT_NEAR(encoder_to_angle(1000, kGeometry) - encoder_to_angle(0, kGeometry), 0.6359053, 1e-6);
    EXPECT_NEAR(encoder_to_angle(-1, kGeometry) - encoder_to_angle(0, kGeometry), -6.359053e-4, 1e-9);
}

TEST(FalconKinematics, SymmetricAnglesGiveAPointOnTheAxis) {
    // Equal motor angles: by the 3-fold symmetry of the legs the handle is on the z axis.
    Vec3 p = kCentre;
    const double t = encoder_to_angle(0, kGeometry);
    const ForwardResult r = forward_kinematics({t, t, t}, kGeometry, p);
    ASSERT_TRUE(r.converged);
    EXPECT_NEAR(p[0], 0.0, 1e-12);
    EXPECT_NEAR(p[1], 0.0, 1e-12);
    EXPECT_GT(p[2], 0.10);
    EXPECT_LT(p[2], 0.16);
}

// Positions across the workspace (a +-40 mm box around the centre, 9^3 points); those the legs can
// reach (the box's corners partly cannot) must round-trip. Tolerances: forward_kinematics stops at a
// residual of 1e-12 rad; |A^-1| is below 0.2 m/rad in this box, so the position error is < 1e-12 m;
// 1e-10 m / 1e-11 rad leave room for floating-point rounding in acos/atan2 near their limits.
TEST(FalconKinematics, InverseOfForwardIsIdentityAcrossTheWorkspace) {
    int solved = 0;
    for (int i = -4; i <= 4; ++i) {
        for (int j = -4; j <= 4; ++j) {
            for (int k = -4; k <= 4; ++k) {
                const Vec3 p{kCentre[0] + 0.01 * i, kCentre[1] + 0.01 * j, kCentre[2] + 0.01 * k};
                Vec3 q{};
                if (!inverse_kinematics(p, kGeometry, q)) continue;
                Vec3 back = kCentre;  // cold start from the centre, not from the answer
                const ForwardResult r = forward_kinematics(q, kGeometry, back, 60);
                ASSERT_TRUE(r.converged) << "p = " << p[0] << ", " << p[1] << ", " << p[2];
                EXPECT_LT(max_abs_diff(back, p), 1e-10);
                Vec3 q2{};
                ASSERT_TRUE(inverse_kinematics(back, kGeometry, q2));
                EXPECT_LT(max_abs_diff(q2, q), 1e-11);
                ++solved;
            }
        }
    }
    EXPECT_GT(solved, 500);  // most of the 729 points are reachable
}

TEST(FalconKinematics, ForwardOfInverseOverMotorAngles) {
    // q on a grid of motor angles (-10 .. 80 deg); where the forward kinematics finds a pose,
    // the inverse kinematics must give q back (same tolerance reasoning as above).
    int solved = 0;
    for (int a = -10; a <= 80; a += 15) {
        for (int b = -10; b <= 80; b += 15) {
            for (int c = -10; c <= 80; c += 15) {
                const double d2r = std::numbers::pi / 180.0;
                const Vec3 q{a * d2r, b * d2r, c * d2r};
                Vec3 p = kCentre;
                if (!forward_kinematics(q, kGeometry, p, 80).converged) continue;
                Vec3 q2{};
                ASSERT_TRUE(inverse_kinematics(p, kGeometry, q2));
                EXPECT_LT(max_abs_diff(q2, q), 1e-11);
                ++solved;
            }
        }
    }
    EXPECT_GT(solved, 100);
}

// A = d theta / d p against central differences, h = 1e-6 m. Error of a central difference:
// h^2/6 |theta'''| + eps |theta| / h. |theta'''| is of order 1/(0.06 m)^3 ~ 5e3 rad/m^3 -> 1e-9 rad/m;
// rounding 2.2e-16 * 2 / 1e-6 ~ 5e-10 rad/m. Entries of A are 5..50 rad/m: tolerance 1e-6 rad/m
// (relative ~1e-7) is a safe bound that still catches any wrong term.
TEST(FalconKinematics, JacobianMatchesFiniteDifferences) {
    const double h = 1e-6;
    int checked = 0;
    for (int i = -3; i <= 3; ++i) {
        for (int j = -3; j <= 3; ++j) {
            for (int k = -3; k <= 3; ++k) {
                const Vec3 p{0.01 * i, 0.01 * j, kCentre[2] + 0.01 * k};
                Mat3 A{};
                if (!angle_jacobian(p, kGeometry, A)) continue;
                for (std::size_t axis = 0; axis < 3; ++axis) {
                    Vec3 plus = p;
                    Vec3 minus = p;
                    plus[axis] += h;
                    minus[axis] -= h;
                    Vec3 qp{};
                    Vec3 qm{};
                    ASSERT_TRUE(inverse_kinematics(plus, kGeometry, qp));
                    ASSERT_TRUE(inverse_kinematics(minus, kGeometry, qm));
                    for (std::size_t leg = 0; leg < 3; ++leg) {
                        EXPECT_NEAR(A[leg][axis], (qp[leg] - qm[leg]) / (2 * h), 1e-6);
                    }
                }
                ++checked;
            }
        }
    }
    EXPECT_GT(checked, 200);
}

// Jacobian-transpose torques obey virtual work: tau . dtheta = F . dp for a small displacement dp.
// With |dp| ~ 1e-7 m the work is ~3e-7 J; the second-order remainder |tau| |theta''| |dp|^2 is ~1e-13 J
// and the rounding of q1 - q0 (eps |q| / |dq| ~ 1e-10 relative) less still: tolerance 1e-5 relative.
TEST(FalconKinematics, TorquesSatisfyVirtualWork) {
    const Vec3 p{0.01, -0.015, 0.13};
    const Vec3 F{2.0, -1.0, 3.0};
    Vec3 tau{};
    ASSERT_TRUE(force_to_torque(p, F, kGeometry, tau));
    const Vec3 dp{3e-8, -5e-8, 8e-8};
    Vec3 q0{};
    Vec3 q1{};
    ASSERT_TRUE(inverse_kinematics(p, kGeometry, q0));
    ASSERT_TRUE(inverse_kinematics({p[0] + dp[0], p[1] + dp[1], p[2] + dp[2]}, kGeometry, q1));
    const double work_joint = tau[0] * (q1[0] - q0[0]) + tau[1] * (q1[1] - q0[1]) + tau[2] * (q1[2] - q0[2]);
    const double work_cart = F[0] * dp[0] + F[1] * dp[1] + F[2] * dp[2];
    EXPECT_NEAR(work_joint, work_cart, 1e-5 * std::abs(work_cart));
}

TEST(FalconKinematics, UnreachablePositionIsReported) {
    Vec3 q{};
    EXPECT_FALSE(inverse_kinematics({0.0, 0.0, 0.5}, kGeometry, q));
    Mat3 A{};
    EXPECT_FALSE(angle_jacobian({0.0, 0.0, 0.5}, kGeometry, A));
    Vec3 tau{};
    EXPECT_FALSE(force_to_torque({0.0, 0.0, 0.5}, {1.0, 0.0, 0.0}, kGeometry, tau));
}

// The encoder step seen along each Cartesian axis at p: one count turns motor i by dtheta (encoder_to_angle), and
// the reported position follows the rounded angles, so near p the position error is e = A^-1 e_theta with e_theta
// independent and uniform over one count on each motor (variance dtheta^2 / 12). Along axis a the error's
// variance is (dtheta^2 / 12) sum_i (A^-1)_ai^2: a rounding quantiser of step q_a = dtheta sqrt(sum_i (A^-1)_ai^2)
// has the same variance, and that q_a is what the white-noise model of the force noise needs.
Vec3 equivalent_position_step(const Vec3& p) {
    Mat3 A{};
    Mat3 A_inv{};
    EXPECT_TRUE(angle_jacobian(p, kGeometry, A));
    EXPECT_TRUE(invert(A, A_inv));
    const double dtheta = encoder_to_angle(1, kGeometry) - encoder_to_angle(0, kGeometry);
    Vec3 q{};
    for (std::size_t a = 0; a < 3; ++a) {
        q[a] = dtheta * std::sqrt(A_inv[a][0] * A_inv[a][0] + A_inv[a][1] * A_inv[a][1] + A_inv[a][2] * A_inv[a][2]);
    }
    return q;
}

// Checked a second way without the Jacobian: positions drawn uniformly within 1 mm of the workspace centre,
// their exact motor angles (inverse kinematics) rounded to whole counts, the position of the rounded angles
// (forward kinematics) less the true one; sqrt(12) times that error's standard deviation per axis against
// q_a. 40000 draws: the sample standard deviation's relative standard error is 1 / sqrt(2 N) = 0.35 %, the
// Jacobian's variation over 1 mm is below 1 %; tolerance 3 %.
TEST(FalconKinematics, TheEquivalentPositionStepMatchesRoundedAnglesThroughTheKinematics) {
    const Vec3 q = equivalent_position_step(kCentre);
    const double dtheta = encoder_to_angle(1, kGeometry) - encoder_to_angle(0, kGeometry);
    const double theta0 = encoder_to_angle(0, kGeometry);
    std::mt19937_64 rng(7);
    std::uniform_real_distribution<double> offset(-1e-3, 1e-3);
    Vec3 sum_sq{};
    const int n = 40000;
    for (int k = 0; k < n; ++k) {
        const Vec3 p{kCentre[0] + offset(rng), kCentre[1] + offset(rng), kCentre[2] + offset(rng)};
        Vec3 theta{};
        ASSERT_TRUE(inverse_kinematics(p, kGeometry, theta));
        Vec3 rounded{};
        for (std::size_t i = 0; i < 3; ++i) rounded[i] = theta0 + dtheta * std::round((theta[i] - theta0) / dtheta);
        Vec3 measured = p;
        ASSERT_TRUE(forward_kinematics(rounded, kGeometry, measured).converged);
        for (std::size_t a = 0; a < 3; ++a) sum_sq[a] += (measured[a] - p[a]) * (measured[a] - p[a]);
    }
    for (std::size_t a = 0; a < 3; ++a) {
        const double simulated = std::sqrt(12.0 * sum_sq[a] / n);
        EXPECT_NEAR(simulated, q[a], 0.03 * q[a]) << "axis " << a;
    }
}

// The shipped falcon profile's position_resolution is each axis's equivalent step at the workspace centre (the
// kinematic frame's z = 0.125 m, the driver's default origin), written to three significant digits: tolerance 0.5 %.
TEST(FalconKinematics, TheFalconProfileCarriesTheEncoderStepAtTheWorkspaceCentre) {
    const Vec3 q = equivalent_position_step(kCentre);
    hapticd::Options o;
    o.device = HAPTICD_SOURCE_CONFIG_DIR + "/devices/falcon.toml";
    const hapticd::DeviceProfile profile = hapticd::load_device_profile(o);
    std::printf("equivalent steps at the centre: x %.6g m, y %.6g m, z %.6g m\n", q[0], q[1], q[2]);
    for (std::size_t a = 0; a < 3; ++a) {
        EXPECT_NEAR(profile.position_resolution[a], q[a], 0.005 * q[a]) << "axis " << a;
    }
}

}  // namespace
}  // namespace hapticd::falcon
