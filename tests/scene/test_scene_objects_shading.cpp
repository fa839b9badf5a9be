// SPDX-License-Identifier: Apache-2.0
// Force shading on a mesh object through the tick (SceneObjects::add_forces; docs/mesh-rendering.md, "Force
// shading"): a shaded sphere's force is closer to the analytic sphere's normal than the unshaded one; only a proxy on
// exactly one face is shaded (two or three constraints: the unshaded force, bitwise); a box at crease 30 deg renders
// bitwise as without shading; and the gains the server certifies for a shaded mesh (server::shaded_mesh_masses) are
// stable in every shaded contact configuration of a sphere mesh at the plant set's corners, by an independent model
// (the mass and the delayed, held force as a state matrix built here, not the daemon's code).
#include <gtest/gtest.h>

#include <Eigen/Eigenvalues>
#include <unsupported/Eigen/MatrixFunctions>

#include <algorithm>
#include <cmath>
#include <complex>
#include <cstdio>
#include <memory>
#include <numbers>
#include <random>
#include <vector>

#include "mesh/god_object_proxy.hpp"
#include "mesh/procedural_meshes.hpp"
#include "scene/scene_objects.hpp"
#include "server/object_resolution.hpp"
#include "tuning/object_checks.hpp"

namespace hapticd {
namespace shading_test {

constexpr double kPeriod = 1e-3;

// One mesh object (K, B, identity pose, no ramp) alone on a 3-axis scene; the forces of handle positions, a tick each.
class MeshScene {
  public:
    MeshScene(const std::shared_ptr<const mesh::MeshHierarchy>& h, const mesh::ShadingNormals* shading,
              double crease_deg, double K = 2000.0, double B = 5.0)
        : ring_(8), objects_(config(), ring_) {
        ObjectParams p;
        p.id = 1;
        p.kind = ObjectKind::Mesh;
        p.K = K;
        p.B = B;
        p.mesh = h.get();
        p.shading = shading;
        p.crease_angle_deg = shading != nullptr ? crease_deg : -1.0;
        ObjectCommit add;
        add.seq = 1;
        add.updates[add.count++] = SlotUpdate{0, SlotUpdate::Action::Set, p};
        ring_.try_push(add);
    }
    AxisVector force(const Eigen::Vector3d& x) {
        objects_.apply_commits();
        AxisVector f{};
        EXPECT_TRUE(objects_.add_forces({x.x(), x.y(), x.z()}, f));
        return f;
    }

  private:
    static SceneObjectsConfig config() {
        SceneObjectsConfig c;
        c.period = kPeriod;
        c.ramp_time = 0.0;
        c.axes = 3;
        return c;
    }
    CommitRing ring_;
    SceneObjects objects_;
};

Eigen::Vector3d as_vector(const AxisVector& f) { return {f[0], f[1], f[2]}; }

double angle_between(const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
    return std::atan2(a.cross(b).norm(), a.dot(b));
}

Eigen::Vector3d random_direction(std::mt19937& rng) {
    std::normal_distribution<double> g(0.0, 1.0);
    return Eigen::Vector3d(g(rng), g(rng), g(rng)).normalized();
}

// The handle from 1 cm outside to `depth` inside along u in 20 ticks, then held 5 ticks (the velocity estimate is
// then 0: the force is the spring's): the force at the end.
Eigen::Vector3d pressed_force(MeshScene& scene, const Eigen::Vector3d& u, double radius, double depth) {
    AxisVector f{};
    for (int k = 0; k <= 20; ++k) f = scene.force((radius + 0.01 - (0.01 + depth) * k / 20.0) * u);
    for (int k = 0; k < 5; ++k) f = scene.force((radius - depth) * u);
    return as_vector(f);
}

// An icosphere of R = 5 cm pressed 3 mm at 300 random directions: the angle between the force and the analytic
// sphere's normal there (the radius through the handle), unshaded and shaded (crease 30 deg). With 320 triangles
// (subdivisions 2) and 1280 (3). The shaded error is below the unshaded one in the mean and at the largest; the
// figures are printed (docs/mesh-rendering.md quotes them).
TEST(ForceShading, AShadedSpheresForceIsCloserToTheAnalyticNormalThanTheUnshadedOne) {
    const double R = 0.05;
    for (const int subdivisions : {2, 3}) {
        const auto h = mesh::MeshHierarchy::build(mesh::icosphere(R, subdivisions), mesh::MeshMode::solid);
        const mesh::ShadingNormals* s = h->shading(30.0);
        ASSERT_NE(s, nullptr);
        std::mt19937 rng(1996);
        double flat_max = 0.0, flat_sum = 0.0, shaded_max = 0.0, shaded_sum = 0.0;
        const int n = 300;
        for (int i = 0; i < n; ++i) {
            const Eigen::Vector3d u = random_direction(rng);
            MeshScene flat(h, nullptr, 0.0), shaded(h, s, 30.0);
            const Eigen::Vector3d f0 = pressed_force(flat, u, R, 0.003), f1 = pressed_force(shaded, u, R, 0.003);
            ASSERT_GT(f0.norm(), 1.0);
            ASSERT_GT(f1.norm(), 1.0);
            const double e0 = angle_between(f0, u), e1 = angle_between(f1, u);
            flat_max = std::max(flat_max, e0);
            shaded_max = std::max(shaded_max, e1);
            flat_sum += e0;
            shaded_sum += e1;
        }
        std::printf(
            "[ force shading ] icosphere %zu triangles, 300 directions, 3 mm: angle to the sphere's normal "
            "unshaded mean %.3e max %.3e rad, shaded mean %.3e max %.3e rad\n",
            h->mesh().triangles.size(), flat_sum / n, flat_max, shaded_sum / n, shaded_max);
        EXPECT_LT(shaded_sum, 0.5 * flat_sum);
        EXPECT_LT(shaded_max, flat_max);
    }
}

// A random path inside a sphere of 320 triangles wound inward (a one-sided concave surface: the handle 0 .. 4 mm
// beyond it, 0.3 mm a tick, across its valleys, where the proxy rests on two faces, and its vertices, on three),
// shaded and unshaded side by side, and an independent proxy fed the same handle for the constraint count: with 2 or
// 3 constraints the forces are equal bitwise; with one on a smooth face they differ. A box (2 x 2 cells a face) at
// crease 30 deg: equal bitwise at every tick (faces, edges, corners).
TEST(ForceShading, OnlyAProxyOnOneFaceIsShadedAndABoxAtThirtyDegreesIsUnchangedBitwise) {
    std::mt19937 rng(40);
    std::uniform_real_distribution<double> depth(0.0, 0.004);
    {
        const double R = 0.05;
        mesh::TriangleMesh inward = mesh::icosphere(R, 2);
        for (auto& t : inward.triangles) std::swap(t[1], t[2]);
        const auto h = mesh::MeshHierarchy::build(inward, mesh::MeshMode::surface);
        const mesh::ShadingNormals* s = h->shading(30.0);
        MeshScene flat(h, nullptr, 0.0), shaded(h, s, 30.0);
        mesh::GodObjectProxy proxy(h, {});
        int one = 0, several = 0, differ = 0;
        Eigen::Vector3d u = random_direction(rng);
        Eigen::Vector3d x = (R - 0.01) * u;
        proxy.reset(x);
        for (int k = 0; k < 20000; ++k) {
            if (k % 200 == 0) u = (u + 0.3 * random_direction(rng)).normalized();
            const Eigen::Vector3d goal = (R + depth(rng)) * u;
            x += (goal - x).normalized() * std::min(3e-4, (goal - x).norm());
            const AxisVector f0 = flat.force(x), f1 = shaded.force(x);
            const mesh::ProxyContact& c = proxy.step(x);
            if (c.constraints >= 2) {
                ++several;
                EXPECT_EQ(f0, f1) << "tick " << k << " constraints " << c.constraints;
            } else if (c.constraints == 1) {
                ++one;
                differ += f0 != f1 ? 1 : 0;
            }
        }
        std::printf("[ force shading ] sphere path: %d ticks on one face (%d shaded differently), %d on 2-3 faces\n",
                    one, differ, several);
        EXPECT_GT(several, 100);
        EXPECT_GT(differ, one / 2);
    }
    {
        const auto h = mesh::MeshHierarchy::build(mesh::box({0.02, 0.03, 0.025}, 2), mesh::MeshMode::solid);
        const mesh::ShadingNormals* s = h->shading(30.0);
        MeshScene flat(h, nullptr, 0.0), shaded(h, s, 30.0);
        Eigen::Vector3d x(0.0, 0.0, 0.04);
        std::uniform_real_distribution<double> coordinate(-0.035, 0.035);
        int pressed = 0;
        for (int k = 0; k < 20000; ++k) {
            if (k % 100 == 0) x = Eigen::Vector3d(coordinate(rng), coordinate(rng), coordinate(rng));
            const Eigen::Vector3d goal(std::clamp(x.x(), -0.024, 0.024), std::clamp(x.y(), -0.034, 0.034),
                                       std::clamp(x.z(), -0.029, 0.029));
            x += 0.001 * (goal - x);
            const AxisVector f0 = flat.force(x), f1 = shaded.force(x);
            EXPECT_EQ(f0, f1) << "tick " << k;
            pressed += as_vector(f0).norm() > 0.0 ? 1 : 0;
        }
        EXPECT_GT(pressed, 1000);
    }
}

// The loop state (x_j, v_j, x_{j-1} .. x_{j-d-1}) with M x'' = -u, u_j = K x_{j-d} + B (x_{j-d} - x_{j-d-1}) / T
// held over the period (K, B any 3 x 3 gain matrices, here K n_s n_f^T: the force along n_s of the spring along
// n_f); one period from Eigen's exponential of the augmented matrix [[0, I, 0], [0, 0, -M^-1], [0, 0, 0]] T. Its
// eigenvalues (built here, independently of hapticopt's polynomials and the daemon's tick).
Eigen::VectorXcd state_eigenvalues(const Eigen::Matrix3d& M, const Eigen::Matrix3d& K, const Eigen::Matrix3d& B,
                                   int d) {
    Eigen::Matrix<double, 9, 9> c = Eigen::Matrix<double, 9, 9>::Zero();
    c.block<3, 3>(0, 3) = Eigen::Matrix3d::Identity();
    c.block<3, 3>(3, 6) = -M.inverse();
    const Eigen::Matrix<double, 9, 9> e = (c * kPeriod).exp();
    const int n = 6 + 3 * (d + 1);
    auto x_block = [](int age) { return age == 0 ? 0 : 3 + 3 * age; };
    Eigen::MatrixXd S = Eigen::MatrixXd::Zero(n, n);
    S.topLeftCorner<6, 6>() = e.topLeftCorner<6, 6>();
    const Eigen::Matrix<double, 6, 3> gamma = e.topRightCorner<6, 3>();
    S.block(0, x_block(d), 6, 3) += gamma * (K + B / kPeriod);
    S.block(0, x_block(d + 1), 6, 3) += gamma * (-B / kPeriod);
    for (int age = 1; age <= d + 1; ++age) S.block(x_block(age), x_block(age - 1), 3, 3) = Eigen::Matrix3d::Identity();
    return Eigen::EigenSolver<Eigen::MatrixXd>(S, false).eigenvalues();
}

// The spectral radius of the contact's modes: the `free` eigenvalues nearest 1 (a double integrator per direction
// the gains leave free: a Jordan block, within ~1e-8 of 1) are checked within 1e-6 of 1 and set aside.
double contact_radius(const Eigen::VectorXcd& ev, int free) {
    std::vector<std::complex<double>> rest(ev.data(), ev.data() + ev.size());
    std::sort(rest.begin(), rest.end(), [](auto a, auto b) { return std::abs(a - 1.0) < std::abs(b - 1.0); });
    for (int f = 0; f < free; ++f) EXPECT_LT(std::abs(rest[static_cast<std::size_t>(f)] - 1.0), 1e-6);
    double radius = 0.0;
    for (std::size_t i = static_cast<std::size_t>(free); i < rest.size(); ++i)
        radius = std::max(radius, std::abs(rest[i]));
    return radius;
}

// The gains the server certifies for a shaded mesh (crease 30 deg; one mass 0.3 kg, the plant set [1/1.1, 1.1] x
// the mass; d = 0, 1, 2; server::shaded_mesh_masses, GainChecker::check_object), at the criterion's optimum and at
// 99 % of the largest K the check accepts at that B, against the independent state matrix of the configurations a
// shaded icosphere (320 triangles) renders on one face: K n_s n_f^T, B n_s n_f^T with (n_f, n_s) at 200 random points
// of its faces, and the worst the crease allows (n_s at 30 deg from n_f), frictionless and with friction
// (K S, B S, S = I + (n_s - n_f) n_f^T), at its ramp weights (s^2 K, s B; s = 1/30 .. 29/30), at the plant set's
// corners c_min m, c_max m and at m. Every one decays. Where the shaded check refuses what the unshaded one accepts
// (a grid of pairs), the worst shaded wall grows; 5 % beyond the accepted K, a face grows at the lightest mass.
TEST(ForceShading, TheCertifiedGainsOfAShadedSphereAreStableInEveryShadedConfigurationOverThePlantSet) {
    const double m = 0.3, crease = 30.0;
    const auto h = mesh::MeshHierarchy::build(mesh::icosphere(0.05, 2), mesh::MeshMode::solid);
    const mesh::ShadingNormals* s = h->shading(crease);
    std::mt19937 rng(1997);
    std::uniform_real_distribution<double> unit(0.0, 1.0);
    std::vector<std::pair<Eigen::Vector3d, Eigen::Vector3d>> normals;  // (n_f, n_s)
    for (int i = 0; i < 200; ++i) {
        const auto f = static_cast<std::uint32_t>(unit(rng) * static_cast<double>(h->mesh().triangles.size()));
        const auto& t = h->mesh().triangles[f];
        double a = unit(rng), b = unit(rng);
        if (a + b > 1.0) a = 1.0 - a, b = 1.0 - b;
        const Eigen::Vector3d& v0 = h->mesh().vertices[t[0]];
        const Eigen::Vector3d x = v0 + a * (h->mesh().vertices[t[1]] - v0) + b * (h->mesh().vertices[t[2]] - v0);
        normals.emplace_back(s->face[f], mesh::shaded_normal(*s, h->mesh(), f, x));
    }
    const double theta = crease * std::numbers::pi / 180.0;
    normals.emplace_back(Eigen::Vector3d::UnitZ(), Eigen::Vector3d(std::sin(theta), 0.0, std::cos(theta)));
    double sphere_tilt = 0.0;
    for (const auto& [nf, ns] : normals)
        sphere_tilt = std::max(sphere_tilt, angle_between(nf, ns) * (nf.z() == 1 ? 0 : 1));
    const Eigen::Matrix3d I = Eigen::Matrix3d::Identity();
    double worst = 0.0;
    int configurations = 0;
    for (int d = 0; d < 3; ++d) {
        GainCheckPlant p;
        p.mass = m;
        p.period = kPeriod;
        p.time_delay = d * kPeriod;
        p.mass_margin = 0.1;
        GainChecker checker(p);
        Matrix3 Id{};
        for (std::size_t i = 0; i < 3; ++i) Id[i][i] = 1.0;
        const auto [c_min, c_max] = checker.mass_scales();
        const std::vector<double> masses = server::shaded_mesh_masses(checker.masses_of(Id), c_min, c_max, crease);
        const std::vector<double> unshaded = server::mesh_masses(checker.masses_of(Id), c_min, c_max);
        ASSERT_GE(masses.size(), 2U);
        EXPECT_NEAR(masses.back(), m / std::cos(theta), 1e-8 * m);
        const CriterionGains optimum = checker.criterion_gains(hapticopt::Criterion::CE2, m);
        ASSERT_TRUE(checker.check_object(optimum.K, optimum.B, masses).stable);
        auto largest_accepted = [&](const std::vector<double>& set) {
            double lo = optimum.K, hi = 100.0 * optimum.K;
            for (int i = 0; i < 40; ++i) {
                const double mid = 0.5 * (lo + hi);
                (checker.check_object(mid, optimum.B, set).stable ? lo : hi) = mid;
            }
            return lo;
        };
        const double shaded_edge = largest_accepted(masses), unshaded_edge = largest_accepted(unshaded);
        std::printf("[ shading d=%d ] CE2 K %.1f B %.3f; largest accepted K at that B: unshaded %.1f, shaded %.1f\n", d,
                    optimum.K, optimum.B, unshaded_edge, shaded_edge);
        for (const double K : {optimum.K, 0.99 * shaded_edge}) {
            for (const auto& [nf, ns] : normals) {
                const Eigen::Matrix3d wall = ns * nf.transpose(), stuck = I + (ns - nf) * nf.transpose();
                for (int j = 1; j <= 30; j += (j < 3 || j > 27) ? 1 : 13) {
                    const double w = j / 30.0;
                    for (const double c : {c_min, 1.0, c_max}) {
                        const double r0 =
                            contact_radius(state_eigenvalues(c * m * I, w * w * K * wall, w * optimum.B * wall, d), 4);
                        const double r1 = contact_radius(
                            state_eigenvalues(c * m * I, w * w * K * stuck, w * optimum.B * stuck, d), 0);
                        EXPECT_LT(r0, 1.0) << "d " << d << " K " << K << " weight " << w << " c " << c;
                        EXPECT_LT(r1, 1.0) << "d " << d << " K " << K << " weight " << w << " c " << c;
                        worst = std::max({worst, r0, r1});
                        configurations += 2;
                    }
                }
            }
        }
        {  // the model sees what the check refuses: 5 % beyond the largest accepted K, a face grows at the lightest
            const Eigen::Matrix3d wall = Eigen::Vector3d::UnitZ() * Eigen::Vector3d::UnitZ().transpose();
            EXPECT_GT(
                contact_radius(state_eigenvalues(c_min * m * I, 1.05 * shaded_edge * wall, optimum.B * wall, d), 4),
                1.0)
                << "d " << d;
        }
        // Where the two checks differ (a grid of K and B, log-spaced): the pairs the unshaded masses accept and the
        // shaded ones refuse; at each, the worst shaded wall (30 deg) grows at one of the set's corners or the heavy
        // end, c_max m / cos 30 deg, itself.
        int differ = 0, grow = 0;
        for (int i = 0; i < 30; ++i) {
            const double B = 0.05 * std::pow(1e4, i / 29.0);
            for (int k = 0; k < 30; ++k) {
                const double K = 10.0 * std::pow(1e5, k / 29.0);
                if (!checker.check_object(K, B, unshaded).stable || checker.check_object(K, B, masses).stable) continue;
                ++differ;
                const Eigen::Matrix3d wall = normals.back().second * normals.back().first.transpose();
                double r = 0.0;
                for (const double c : {c_min, 1.0, c_max})
                    r = std::max(r, contact_radius(state_eigenvalues(c * m * I, K * wall, B * wall, d), 4));
                grow += r > 1.0 ? 1 : 0;
            }
        }
        std::printf("[ shading d=%d ] grid of 900 (K, B): %d accepted unshaded and refused shaded, %d of them grow\n",
                    d, differ, grow);
        EXPECT_EQ(grow, differ) << "d " << d;
    }
    std::printf(
        "[ shading ] %d configurations (sphere: n_s up to %.4f rad from n_f; and the 30 deg worst case), "
        "largest spectral radius %.9f\n",
        configurations, sphere_tilt, worst);
}

}  // namespace shading_test
}  // namespace hapticd
