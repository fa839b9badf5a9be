// SPDX-License-Identifier: Apache-2.0
// The numerical-range proof for summed gains that do not commute (numerical_range_certificate.hpp), checked against
// what it claims:
//  * the polygon holds the joint numerical range: random complex unit vectors v give points (v^* A v, v^* B v) inside
//    it, and each vertex lies within the stated distance of the range's support points;
//  * the hull holds s P for every s of the interval;
//  * a segment's verdict (MassScalingTest::segment_over, ArmBoxTest::segment_over) against the library's exact verdict
//    on dense points of the segment (and of the arm and delay box);
//  * the implication: every sum the certificate proves (with its anchor) is stable at plants drawn from the set, the
//    ends and the interior of the masses, arms and delays, by the spectral radius of the coupled loop's state matrix
//    built independently (tests/common/coupled_loop_matrix.hpp), and the proof is not vacuous (most random sums of
//    moderate gains are proven).
#include <gtest/gtest.h>

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <complex>
#include <cstdio>
#include <limits>
#include <hapticopt/arm_box_stability.hpp>
#include <hapticopt/estimator_stability.hpp>
#include <hapticopt/mass_scaling_stability.hpp>
#include <hapticopt/matrix_gain_stability.hpp>
#include <hapticopt/numerical_range_certificate.hpp>
#include <random>
#include <string>
#include <vector>

#include "common/coupled_loop_matrix.hpp"
#include "common/random_projector.hpp"

namespace numerical_range_certificate_test {

using hapticopt::GainSegment;
using hapticopt::NormalizedPlant;
using hapticopt::VelocityEstimator;

const double kPi = 3.14159265358979323846;

Eigen::MatrixXd random_symmetric(std::mt19937& rng, int r) {
    std::normal_distribution<double> normal(0.0, 1.0);
    Eigen::MatrixXd m(r, r);
    for (int i = 0; i < r; ++i) {
        for (int j = 0; j < r; ++j) m(i, j) = normal(rng);
    }
    return 0.5 * (m + m.transpose());
}

// Whether w lies in the counter-clockwise convex polygon (within tol of each edge's line).
bool inside(const std::vector<Eigen::Vector2d>& polygon, const Eigen::Vector2d& w, double tol) {
    for (std::size_t i = 0; i < polygon.size(); ++i) {
        const Eigen::Vector2d& a = polygon[i];
        const Eigen::Vector2d& b = polygon[(i + 1) % polygon.size()];
        const Eigen::Vector2d e = b - a;
        const double cross = e.x() * (w.y() - a.y()) - e.y() * (w.x() - a.x());
        if (cross < -tol * e.norm()) return false;
    }
    return true;
}

// A point (v^* A v, v^* B v) of the joint numerical range at a random complex unit vector v.
Eigen::Vector2d random_range_point(std::mt19937& rng, const Eigen::MatrixXd& A, const Eigen::MatrixXd& B) {
    std::normal_distribution<double> normal(0.0, 1.0);
    Eigen::VectorXcd v(A.rows());
    for (Eigen::Index i = 0; i < A.rows(); ++i) v(i) = std::complex<double>(normal(rng), normal(rng));
    v.normalize();
    const Eigen::MatrixXcd Ac = A.cast<std::complex<double>>(), Bc = B.cast<std::complex<double>>();
    return Eigen::Vector2d((v.adjoint() * Ac * v)(0).real(), (v.adjoint() * Bc * v)(0).real());
}

double segment_distance(const Eigen::Vector2d& p, const Eigen::Vector2d& a, const Eigen::Vector2d& b) {
    const Eigen::Vector2d e = b - a;
    const double t = e.squaredNorm() > 0 ? std::clamp((p - a).dot(e) / e.squaredNorm(), 0.0, 1.0) : 0.0;
    return (a + t * e - p).norm();
}

TEST(NumericalRange, ThePolygonHoldsTheRangeAndHugsIt) {
    std::mt19937 rng(20261207);
    for (int trial = 0; trial < 40; ++trial) {
        const int r = 2 + trial % 2;
        const Eigen::MatrixXd A = random_symmetric(rng, r), B = random_symmetric(rng, r);
        const int m = trial % 4 == 0 ? 4 : 32;
        const std::vector<Eigen::Vector2d> polygon = hapticopt::numerical_range_polygon(A, B, m);
        ASSERT_EQ(polygon.size(), static_cast<std::size_t>(m));
        const double tol = 1e-12 * (A.norm() + B.norm());
        for (int k = 0; k < 2000; ++k) {
            const Eigen::Vector2d w = random_range_point(rng, A, B);
            ASSERT_TRUE(inside(polygon, w, tol)) << "trial " << trial << ": (" << w.transpose() << ")";
        }
        // Vertex j lies on the support lines j and j + 1; with t_j, t_{j+1} their support points (points of the
        // range) it forms a triangle of apex angle pi - 2 pi / m, so its distance from the segment [t_j, t_{j+1}]
        // (inside the range) is at most |t_j - t_{j+1}| / 2 tan(pi / m).
        std::vector<Eigen::Vector2d> support;
        for (int j = 0; j < m; ++j) {
            const double phi = 2 * kPi * j / m;
            const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> e(std::cos(phi) * A + std::sin(phi) * B);
            const Eigen::VectorXd u = e.eigenvectors().col(r - 1);
            support.emplace_back(u.dot(A * u), u.dot(B * u));
        }
        for (int j = 0; j < m; ++j) {
            const Eigen::Vector2d& a = support[static_cast<std::size_t>(j)];
            const Eigen::Vector2d& b = support[static_cast<std::size_t>((j + 1) % m)];
            EXPECT_LE(segment_distance(polygon[static_cast<std::size_t>(j)], a, b),
                      0.5 * (a - b).norm() * std::tan(kPi / m) + 1e-9 * (A.norm() + B.norm()))
                << "trial " << trial << ", vertex " << j;
        }
    }
}

TEST(NumericalRange, TheHullHoldsEveryScaledPolygon) {
    std::mt19937 rng(7);
    std::uniform_real_distribution<double> unit(0.0, 1.0);
    for (int trial = 0; trial < 20; ++trial) {
        const Eigen::MatrixXd A = random_symmetric(rng, 3), B = random_symmetric(rng, 3);
        const std::vector<Eigen::Vector2d> polygon = hapticopt::numerical_range_polygon(A, B, 16);
        const double s_lo = 0.5 + unit(rng), s_hi = s_lo * (1.0 + unit(rng));
        const std::vector<Eigen::Vector2d> hull = hapticopt::scaled_polygon_hull(polygon, s_lo, s_hi);
        ASSERT_GE(hull.size(), 3u);
        for (std::size_t i = 0; i < hull.size(); ++i) {  // convex, counter-clockwise
            const Eigen::Vector2d e = hull[(i + 1) % hull.size()] - hull[i];
            const Eigen::Vector2d f = hull[(i + 2) % hull.size()] - hull[(i + 1) % hull.size()];
            EXPECT_GT(e.x() * f.y() - e.y() * f.x(), 0.0);
        }
        for (int k = 0; k < 200; ++k) {
            const double s = s_lo + (s_hi - s_lo) * unit(rng);
            for (const Eigen::Vector2d& v : polygon) {
                EXPECT_TRUE(inside(hull, s * v, 1e-12 * (A.norm() + B.norm()) * s_hi)) << "s = " << s;
            }
        }
    }
}

// An outline at unequally spaced directions (what a refinement makes): random points of W lie inside it, each support
// point lies on its line and is a point of W (v^T A v, v^T B v), and every point of the polygon (random convex
// combinations of its vertices) lies within the largest excess of the support points' hull, measured here.
TEST(NumericalRange, AnUnevenOutlineHoldsTheRangeWithinItsExcess) {
    std::mt19937 rng(20261208);
    std::uniform_real_distribution<double> unit(0.0, 1.0);
    for (int trial = 0; trial < 30; ++trial) {
        const int r = 2 + trial % 2;
        const Eigen::MatrixXd A = random_symmetric(rng, r), B = random_symmetric(rng, r);
        // 4 to 40 directions, gaps below a quarter turn: the quarters, then random turns.
        std::vector<double> turns{0.0, 0.25, 0.5, 0.75};
        for (int k = 0; k < trial; ++k) turns.push_back(unit(rng));
        std::sort(turns.begin(), turns.end());
        const hapticopt::NumericalRangeOutline o = hapticopt::numerical_range_outline(A, B, turns);
        ASSERT_EQ(o.vertices.size(), turns.size());
        const double scale = A.norm() + B.norm(), tol = 1e-12 * scale;
        std::vector<Eigen::Vector2d> support_hull = hapticopt::scaled_polygon_hull(o.support, 1.0, 1.0);
        const double max_excess = *std::max_element(o.excess.begin(), o.excess.end());
        for (std::size_t j = 0; j < turns.size(); ++j) {
            const double phi = 2 * kPi * turns[j];
            const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> e(std::cos(phi) * A + std::sin(phi) * B);
            EXPECT_NEAR(std::cos(phi) * o.support[j].x() + std::sin(phi) * o.support[j].y(), e.eigenvalues()(r - 1),
                        1e-12 * scale)
                << "trial " << trial << ", line " << j;
        }
        for (int k = 0; k < 500; ++k) {
            const Eigen::Vector2d w = random_range_point(rng, A, B);
            ASSERT_TRUE(inside(o.vertices, w, tol)) << "trial " << trial << ": (" << w.transpose() << ")";
            // A point of the polygon: a random convex combination of its vertices.
            Eigen::Vector2d p = Eigen::Vector2d::Zero();
            double total = 0;
            for (const Eigen::Vector2d& x : o.vertices) {
                const double weight = std::pow(unit(rng), 8.0);
                p += weight * x;
                total += weight;
            }
            p /= total;
            double distance = 0.0;
            if (!inside(support_hull, p, 0.0)) {
                distance = std::numeric_limits<double>::infinity();
                for (std::size_t i = 0; i < support_hull.size(); ++i) {
                    distance = std::min(
                        distance, segment_distance(p, support_hull[i], support_hull[(i + 1) % support_hull.size()]));
                }
            }
            EXPECT_LE(distance, max_excess + tol) << "trial " << trial;
            EXPECT_NEAR(hapticopt::distance_to_convex_polygon(support_hull, p), distance, tol) << "trial " << trial;
        }
    }
    const Eigen::MatrixXd I = Eigen::Matrix2d::Identity();
    EXPECT_THROW((void)hapticopt::numerical_range_outline(I, I, {0.0, 0.6}), hapticopt::InvalidParameter);  // gap
    EXPECT_THROW((void)hapticopt::numerical_range_outline(I, I, {0.3, 0.2, 0.6}), hapticopt::InvalidParameter);
    EXPECT_THROW((void)hapticopt::numerical_range_outline(I, I, {0.0}), hapticopt::InvalidParameter);
}

// Merging crowded vertices: the result is convex and counter-clockwise, holds every vertex of the input, has fewer
// vertices where the input crowds (the thin range's tips), and each of its vertices lies within `relative` |v| of an
// input vertex v.
TEST(NumericalRange, MergingCrowdedVerticesHoldsThePolygon) {
    std::mt19937 rng(29);
    std::uniform_real_distribution<double> unit(0.0, 1.0);
    int merged_total = 0;
    for (int trial = 0; trial < 30; ++trial) {
        // A thin ellipse's range (2 x 2, eigenvalues far apart along one direction) at 64 directions, scaled.
        Eigen::Matrix2d A, B;
        const double thin = std::pow(10.0, -1.0 - 4.0 * unit(rng));
        A << 1e-3 * unit(rng) + 1e-6, thin * 1e-3, thin * 1e-3, 1e-3 * unit(rng);
        B << 0.02 * unit(rng), 0.0, 0.0, 0.02 * unit(rng) + 1e-4;
        const std::vector<Eigen::Vector2d> hull =
            hapticopt::scaled_polygon_hull(hapticopt::numerical_range_polygon(A, B, 64), 0.9, 1.5);
        const double relative = 0.01;
        const std::vector<Eigen::Vector2d> merged = hapticopt::merge_crowded_vertices(hull, relative);
        ASSERT_GE(merged.size(), 3u);
        EXPECT_LE(merged.size(), hull.size());
        merged_total += static_cast<int>(hull.size() - merged.size());
        for (std::size_t i = 0; i < merged.size(); ++i) {
            const Eigen::Vector2d e = merged[(i + 1) % merged.size()] - merged[i];
            const Eigen::Vector2d f = merged[(i + 2) % merged.size()] - merged[(i + 1) % merged.size()];
            EXPECT_GE(e.x() * f.y() - e.y() * f.x(), 0.0) << "trial " << trial;
        }
        const double tol = 1e-12 * (A.norm() + B.norm());
        for (const Eigen::Vector2d& v : hull) EXPECT_TRUE(inside(merged, v, tol)) << "trial " << trial;
        for (const Eigen::Vector2d& w : merged) {
            double excess = std::numeric_limits<double>::infinity();
            for (const Eigen::Vector2d& v : hull) excess = std::min(excess, (w - v).norm() - relative * v.norm());
            EXPECT_LE(excess, tol) << "trial " << trial;
        }
    }
    std::printf("[ merged ] %d vertices dropped over 30 thin ranges\n", merged_total);
    EXPECT_GE(merged_total, 30);
}

// The library's exact verdict at u on dense points of the segment.
TEST(GainSegmentVerdict, AgreesWithTheExactVerdictOnDensePoints) {
    std::mt19937 rng(11);
    std::uniform_real_distribution<double> alpha_of(0.0, 0.06), beta_of(0.0, 0.6);
    int stable_segments = 0, unstable_segments = 0;
    for (int trial = 0; trial < 60; ++trial) {
        const NormalizedPlant plant{0.0, 0.0, trial % 3 == 0 ? 1.0 : (trial % 3 == 1 ? 2.5 : 6.0)};
        const VelocityEstimator estimator =
            trial % 2 == 0 ? VelocityEstimator{} : VelocityEstimator::moving_window(1 + trial % 7);
        const hapticopt::MassScalingTest test(plant, estimator);
        const double scale = 1.0 / (1.0 + plant.delay);
        const GainSegment g =
            GainSegment::between(scale * alpha_of(rng), beta_of(rng), scale * alpha_of(rng), beta_of(rng));
        const hapticopt::GainRayStability v = test.segment_over(g);
        bool dense_stable = true;
        for (int k = 0; k <= 2000 && dense_stable; ++k) {
            const double u = k / 2000.0;
            dense_stable = test.stable(g.alpha(u), g.beta(u));
        }
        if (v.stable) {
            ++stable_segments;
            EXPECT_TRUE(dense_stable) << "trial " << trial;
        } else {
            ++unstable_segments;
            // Refused: the failing u is on the boundary or beyond it (the largest root at >= 1 - 1e-7), whether or
            // not a dense point falls there.
            const double u = v.failing_scale;
            const hapticopt::StabilityReport s =
                hapticopt::stability(plant, hapticopt::NormalizedGains{g.alpha(u), g.beta(u)}, estimator);
            EXPECT_GE(s.spectral_radius, 1.0 - 1e-7) << "trial " << trial << ", u = " << u;
        }
    }
    std::printf("[ segments ] %d stable, %d refused\n", stable_segments, unstable_segments);
    EXPECT_GE(stable_segments, 10);
    EXPECT_GE(unstable_segments, 10);
}

// The arm box's segment verdict: a stable verdict holds at random plants of the box along the segment, and a plant it
// names as unstable is unstable by the exact verdict.
TEST(GainSegmentVerdict, TheArmBoxVerdictHoldsAtPlantsInsideTheBox) {
    std::mt19937 rng(13);
    std::uniform_real_distribution<double> unit(0.0, 1.0);
    const NormalizedPlant device{0.0, 0.0, 6.0};
    const VelocityEstimator estimator = VelocityEstimator::moving_window(15);
    const double gamma_max = 1000.0 * 1e-6, delta_max = 20.0 * 1e-3, d_lo = 5.0, d_hi = 8.0;
    const hapticopt::ArmBoxTest box(device, estimator, gamma_max, delta_max, d_lo, d_hi);
    int proven = 0, refuted = 0;
    for (int trial = 0; trial < 12; ++trial) {
        const GainSegment g =
            GainSegment::between(4e-4 * unit(rng), 0.02 * unit(rng), 4e-4 * unit(rng), 0.02 * unit(rng));
        const hapticopt::ArmBoxStability v = box.segment_over(g, 256);
        if (!v.stable) {
            if (!v.proven_unstable) continue;  // neither proven nor refuted within the budget
            ++refuted;
            const NormalizedPlant p{v.failing_gamma, v.failing_delta, v.failing_delay};
            const hapticopt::MassScalingTest exact(p, estimator, hapticopt::ArmAlongRay::per_mass);
            EXPECT_FALSE(exact.stable(g.alpha(v.failing_scale), g.beta(v.failing_scale))) << "trial " << trial;
            continue;
        }
        ++proven;
        for (int k = 0; k < 40; ++k) {
            const NormalizedPlant p{gamma_max * unit(rng), delta_max * unit(rng), d_lo + (d_hi - d_lo) * unit(rng)};
            const double u = unit(rng);
            const hapticopt::MassScalingTest exact(p, estimator, hapticopt::ArmAlongRay::per_mass);
            EXPECT_TRUE(exact.stable(g.alpha(u), g.beta(u)))
                << "trial " << trial << ": gamma " << p.gamma << ", delta " << p.delta << ", d " << p.delay;
        }
    }
    std::printf("[ arm box segments ] %d of 12 proven, %d refuted\n", proven, refuted);
    EXPECT_GE(proven, 1);  // the implication is tested on at least one segment
}

// Summed gains and the normals of the planes that make them.
struct Sum {
    Eigen::MatrixXd A, B;
    std::vector<Eigen::Vector3d> normals;
};

// `planes` planes along random normals, each with its own (alpha, beta) (alpha_top and beta_top times a factor in
// [low, 1]): the sum's A and B do not commute.
Sum random_planes(std::mt19937& rng, double alpha_top, double beta_top, int planes = 3, double low = 0.1) {
    std::uniform_real_distribution<double> unit(-1.0, 1.0), alpha_of(low, 1.0), beta_of(low, 1.0);
    Eigen::Matrix3d A = Eigen::Matrix3d::Zero(), B = Eigen::Matrix3d::Zero();
    std::vector<Eigen::Vector3d> normals;
    for (int object = 0; object < planes; ++object) {
        const Eigen::Vector3d n = Eigen::Vector3d(unit(rng), unit(rng), unit(rng)).normalized();
        A += alpha_top * alpha_of(rng) * n * n.transpose();
        B += beta_top * beta_of(rng) * n * n.transpose();
        normals.push_back(n);
    }
    // On the span of the normals (the rest is the free plant's, decoupled: coupled_loop_matrix::on_span), where the
    // certificate and the state matrix judge the loop, as GainChecker restricts to where the gains act.
    const auto [a, b] = coupled_loop_matrix::on_span(A, B, normals);
    return Sum{a, b, normals};
}

coupled_loop_matrix::Difference difference_of(const VelocityEstimator& e) {
    if (e.kind == hapticopt::VelocityEstimatorKind::window) return coupled_loop_matrix::window(e.window);
    return coupled_loop_matrix::window(1);
}

// An edge's verdict by the arm box (256 sub-boxes), as GainChecker asks it: `certified` when stable or refuted with an
// unstable plant, not when left undecided within the budget.
hapticopt::GainRayStability box_verdict(const hapticopt::ArmBoxTest& box, const GainSegment& g) {
    const hapticopt::ArmBoxStability b = box.segment_over(g, 256);
    hapticopt::GainRayStability v;
    v.stable = b.stable;
    v.certified = b.stable || b.proven_unstable;
    v.failing_scale = b.failing_scale;
    return v;
}

// Whether the coupled loop (independent state matrix) is stable at `count` scales spread over [s_lo, s_hi], ends
// included: the sampled truth the proof is measured against (how many stable sums it proves).
bool stable_at_scales(const NormalizedPlant& plant, const Sum& sum, const coupled_loop_matrix::Difference& e,
                      double s_lo, double s_hi, int count) {
    for (int k = 0; k < count; ++k) {
        const double s = s_lo + (s_hi - s_lo) * k / (count - 1);
        if (!(coupled_loop_matrix::state_radius(plant, s * sum.A, s * sum.B, e) < 1.0)) return false;
    }
    return true;
}

// One plant: no arm, one delay; the segments judged exactly (MassScalingTest::segment_over).
TEST(NumericalRangeCertificate, ProvenSumsAreStableAtEveryMassOfTheSet) {
    std::mt19937 rng(17);
    std::uniform_real_distribution<double> unit(0.0, 1.0);
    int proven = 0, stable = 0;
    const double s_lo = 0.7, s_hi = 1.4;
    for (int trial = 0; trial < 40; ++trial) {
        const NormalizedPlant plant{0.0, 0.0, trial % 2 == 0 ? 1.0 : 2.5};
        const VelocityEstimator estimator = trial % 3 == 0 ? VelocityEstimator::moving_window(4) : VelocityEstimator{};
        const hapticopt::MassScalingTest test(plant, estimator);
        const Sum sum = random_planes(rng, 0.03 / (1 + plant.delay), 0.3);
        ASSERT_GT((sum.A * sum.B - sum.B * sum.A).norm(), 1e-6);  // not commuting
        const coupled_loop_matrix::Difference e = difference_of(estimator);
        const bool sampled = stable_at_scales(plant, sum, e, s_lo, s_hi, 41);
        stable += sampled ? 1 : 0;
        const hapticopt::NumericalRangeCertificate c = hapticopt::certify_by_numerical_range(
            sum.A, sum.B, s_lo, s_hi, 32, [&](const GainSegment& g) { return test.segment_over(g); },
            trial % 2 == 0 ? 256 : 0);  // refined on even trials
        const bool anchor = coupled_loop_matrix::state_radius(plant, sum.A, sum.B, e) < 1.0;
        if (!(c.proven && anchor)) {
            if (sampled) {
                std::printf("[ not proven ] trial %d: stable at 41 scales; edge %d fails at (%.4g, %.4g)\n", trial,
                            c.edges, c.failing_alpha, c.failing_beta);
            }
            continue;
        }
        ++proven;
        std::vector<double> scales{s_lo, s_hi};
        for (int k = 0; k < 20; ++k) scales.push_back(s_lo + (s_hi - s_lo) * unit(rng));
        for (const double s : scales) {
            EXPECT_LT(coupled_loop_matrix::state_radius(plant, s * sum.A, s * sum.B, e), 1.0)
                << "trial " << trial << ", s = " << s;
        }
    }
    std::printf("[ proven ] %d of the %d random non-commuting sums stable at 41 scales (of 40)\n", proven, stable);
    EXPECT_GE(stable, 10);
    EXPECT_GE(2 * proven, stable);
}

// The Falcon's set: window 15, masses x [0.67, 1.5], the paper's arm box (k_H / m <= 1000 s^-2, b_H / m <= 20 s^-1),
// total delays 5 .. 8 periods; segments by the arm box's certified verdict. Proven sums are stable at the set's corners
// and at random interior plants. Two planes at random angles, gains 0.4 .. 1 times (4e-4, 0.03), around half the CE2
// optimum for the 0.30 kg Falcon (alpha 1.26e-3, beta 0.052): a direction much softer than the arm's stiffness
// (gamma up to 1e-3) needs the box subdivided beyond its budget near z = 1, as a single soft plane does.
TEST(NumericalRangeCertificate, ProvenSumsAreStableOverTheArmBoxAndTheDelays) {
    std::mt19937 rng(19);
    std::uniform_real_distribution<double> unit(0.0, 1.0);
    const VelocityEstimator estimator = VelocityEstimator::moving_window(15);
    const double gamma_max = 1000.0 * 1e-6, delta_max = 20.0 * 1e-3, d_lo = 5.0, d_hi = 8.0, s_lo = 0.67, s_hi = 1.5;
    const hapticopt::ArmBoxTest box(NormalizedPlant{0.0, 0.0, d_lo}, estimator, gamma_max, delta_max, d_lo, d_hi);
    const coupled_loop_matrix::Difference e = coupled_loop_matrix::window(15);
    int proven = 0, stable = 0;
    const int cases = 12;
    for (int trial = 0; trial < cases; ++trial) {
        const Sum sum = random_planes(rng, 4e-4, 0.03, 2, 0.4);
        const bool sampled = stable_at_scales(NormalizedPlant{0.0, 0.0, d_lo}, sum, e, s_lo, s_hi, 9) &&
                             stable_at_scales(NormalizedPlant{gamma_max, delta_max, d_hi}, sum, e, s_lo, s_hi, 9);
        stable += sampled ? 1 : 0;
        const hapticopt::NumericalRangeCertificate c = hapticopt::certify_by_numerical_range(
            sum.A, sum.B, s_lo, s_hi, 16, [&](const GainSegment& g) { return box_verdict(box, g); },
            trial % 2 == 0 ? 256 : 0);  // refined: even
        const bool anchor = coupled_loop_matrix::state_radius(NormalizedPlant{0.0, 0.0, 6.0}, sum.A, sum.B, e) < 1.0;
        if (!(c.proven && anchor)) {
            if (sampled) {
                std::printf("[ not proven ] trial %d: stable at the sampled plants; edge %d fails at (%.4g, %.4g)\n",
                            trial, c.edges, c.failing_alpha, c.failing_beta);
            }
            continue;
        }
        ++proven;
        std::vector<NormalizedPlant> plants;
        std::vector<double> scales;
        for (int corner = 0; corner < 16; ++corner) {
            plants.push_back(NormalizedPlant{(corner & 1) ? gamma_max : 0.0, (corner & 2) ? delta_max : 0.0,
                                             (corner & 4) ? d_hi : d_lo});
            scales.push_back((corner & 8) ? s_hi : s_lo);
        }
        for (int k = 0; k < 16; ++k) {
            plants.push_back(
                NormalizedPlant{gamma_max * unit(rng), delta_max * unit(rng), d_lo + (d_hi - d_lo) * unit(rng)});
            scales.push_back(s_lo + (s_hi - s_lo) * unit(rng));
        }
        for (std::size_t i = 0; i < plants.size(); ++i) {
            EXPECT_LT(coupled_loop_matrix::state_radius(plants[i], scales[i] * sum.A, scales[i] * sum.B, e), 1.0)
                << "trial " << trial << ": gamma " << plants[i].gamma << ", delta " << plants[i].delta << ", d "
                << plants[i].delay << ", s " << scales[i];
        }
    }
    std::printf("[ proven over the box ] %d of the %d random non-commuting sums stable at the sampled plants (of %d)\n",
                proven, stable, cases);
    EXPECT_GE(stable, 3);
    EXPECT_GE(2 * proven, stable);
}

// A thin range the equally spaced polygons cannot prove and the refined one does: a half-CE2 wall (Falcon, 0.30 kg,
// 159.4 N/m, 6.53 N s/m) and, 45 degrees to it, a plane at half its ramp (25 N/m, 0.5 N s/m), normalised for 0.30 kg
// at 1 kHz; the Falcon's set: window 15, masses 0.20 .. 0.33 kg (s = 0.909 .. 1.5), the arm of eq. 2, total delays
// 5 .. 8 ms. The 16- and 64-line polygons have a vertex beside the sliver whose loop is unstable (a decided failure);
// the refined certificate proves the sum, and the coupled loop's state matrix, built independently, is stable at the
// set's 16 corners and 16 random plants.
TEST(NumericalRangeCertificate, RefinementProvesAThinRangeTheEvenPolygonsDoNot) {
    const VelocityEstimator estimator = VelocityEstimator::moving_window(15);
    const double gamma_max = 1000.0 * 1e-6, delta_max = 20.0 * 1e-3, d_lo = 5.0, d_hi = 8.0;
    const double s_lo = 0.30 / 0.33, s_hi = 0.30 / 0.20, T = 1e-3, m = 0.30;
    const hapticopt::ArmBoxTest box(NormalizedPlant{0.0, 0.0, d_lo}, estimator, gamma_max, delta_max, d_lo, d_hi);
    const Eigen::Vector3d wall(1.0, 0.0, 0.0), plane = Eigen::Vector3d(1.0, 1.0, 0.0).normalized();
    const Eigen::Matrix3d K = 159.4 * wall * wall.transpose() + 25.0 * plane * plane.transpose();
    const Eigen::Matrix3d Bd = 6.53 * wall * wall.transpose() + 0.5 * plane * plane.transpose();
    const auto [A, B] = coupled_loop_matrix::on_span((T * T / m) * K, (T / m) * Bd, {wall, plane});
    auto verdict = [&](const GainSegment& g) { return box_verdict(box, g); };
    for (const int even : {16, 64}) {
        const hapticopt::NumericalRangeCertificate c =
            hapticopt::certify_by_numerical_range(A, B, s_lo, s_hi, even, verdict);
        EXPECT_FALSE(c.proven) << even << " lines";
        // The failing gains are a loop that is unstable at a plant of the set (the box's decided refusal).
        const hapticopt::ArmBoxStability b = box.segment_over(
            GainSegment::between(c.failing_alpha, c.failing_beta, c.failing_alpha, c.failing_beta), 256);
        EXPECT_TRUE(b.proven_unstable) << even << " lines";
    }
    const hapticopt::NumericalRangeCertificate c =
        hapticopt::certify_by_numerical_range(A, B, s_lo, s_hi, 16, verdict, 256);
    ASSERT_TRUE(c.proven);
    EXPECT_GE(c.refinements, 1);
    EXPECT_LT(c.directions, 64);
    std::printf("[ refined ] proven with %d lines after %d refinements, %d edge verdicts\n", c.directions,
                c.refinements, c.edges);
    ASSERT_LT(coupled_loop_matrix::state_radius(NormalizedPlant{0.0, 0.0, 6.0}, A, B, coupled_loop_matrix::window(15)),
              1.0);  // the anchor
    std::mt19937 rng(31);
    std::uniform_real_distribution<double> unit(0.0, 1.0);
    for (int k = 0; k < 32; ++k) {
        const bool corner = k < 16;
        const NormalizedPlant p{corner ? ((k & 1) ? gamma_max : 0.0) : gamma_max * unit(rng),
                                corner ? ((k & 2) ? delta_max : 0.0) : delta_max * unit(rng),
                                corner ? ((k & 4) ? d_hi : d_lo) : d_lo + (d_hi - d_lo) * unit(rng)};
        const double s = corner ? ((k & 8) ? s_hi : s_lo) : s_lo + (s_hi - s_lo) * unit(rng);
        EXPECT_LT(coupled_loop_matrix::state_radius(p, s * A, s * B, coupled_loop_matrix::window(15)), 1.0)
            << "gamma " << p.gamma << ", delta " << p.delta << ", d " << p.delay << ", s " << s;
    }
}

// A sum with a stiff direction beyond the region: the certificate is not proven, and the failing gains it names are a
// scalar loop that is not stable.
// A mesh's proxy beside other gains (numerical_range_certificate.hpp, "Families"): its configurations are c Mis Q Mis
// (A) and c_B Mis Q Mis (B) for a projector Q of rank 1, 2 or 3, Mis = M^-1/2 of the mass matrix; `at(Q)` gives them
// for any Q. The family's members: the other gains alone and with the proxy at Q = I.
struct ProxyFamily {
    Eigen::MatrixXd A0, B0, Mis;
    double c = 0.0, c_B = 0.0;
    std::pair<Eigen::MatrixXd, Eigen::MatrixXd> at(const Eigen::MatrixXd& Q) const {
        return {A0 + c * Mis * Q * Mis, B0 + c_B * Mis * Q * Mis};
    }
    std::vector<hapticopt::GainMatrixPair> members() const {
        const auto full = at(Eigen::MatrixXd::Identity(3, 3));
        return {hapticopt::GainMatrixPair{A0, B0}, hapticopt::GainMatrixPair{full.first, full.second}};
    }
};

// A random symmetric positive definite M^-1/2 with eigenvalues in [0.8, 1.25] (masses within 1.6 of each other).
Eigen::MatrixXd random_mass_inverse_sqrt(std::mt19937& rng) {
    const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> e(random_symmetric(rng, 3));
    std::uniform_real_distribution<double> lambda(0.8, 1.25);
    const Eigen::Vector3d d(lambda(rng), lambda(rng), lambda(rng));
    return e.eigenvectors() * d.asDiagonal() * e.eigenvectors().transpose();
}

using test_projector::random_projector;

// The family's outline holds the range of every configuration: points of W at random complex vectors for random Q
// with 0 <= Q <= I (projectors among them) lie in the polygon, within its rounding term.
TEST(NumericalRange, AFamilysOutlineHoldsTheRangeOfEveryConfiguration) {
    std::mt19937 rng(29);
    std::uniform_real_distribution<double> unit(0.0, 1.0);
    for (int trial = 0; trial < 20; ++trial) {
        const Sum planes = random_planes(rng, 0.02, 0.2);
        ProxyFamily f{planes.A, planes.B, random_mass_inverse_sqrt(rng), 0.02 * unit(rng), 0.2 * unit(rng)};
        std::vector<double> turns;
        for (int j = 0; j < 24; ++j) turns.push_back(j / 24.0);
        const hapticopt::NumericalRangeOutline o = hapticopt::numerical_range_outline(f.members(), turns);
        const double tol = 1e-12;
        for (int k = 0; k < 200; ++k) {
            Eigen::MatrixXd Q;
            if (k % 2 == 0) {
                Q = random_projector(rng, 1 + k % 3);
            } else {  // 0 <= Q <= I, not a projector
                const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> e(random_symmetric(rng, 3));
                const Eigen::Vector3d d(unit(rng), unit(rng), unit(rng));
                Q = e.eigenvectors() * d.asDiagonal() * e.eigenvectors().transpose();
            }
            const auto [A, B] = f.at(Q);
            const Eigen::Vector2d w = random_range_point(rng, A, B);
            ASSERT_TRUE(inside(o.vertices, w, tol))
                << "trial " << trial << ", point (" << w.x() << ", " << w.y() << ")";
        }
    }
}

// Proven families are stable in every configuration: one plant, the segments judged exactly; the other gains are three
// planes (positive definite on the three directions, so no configuration leaves a direction free), the proxy's at
// around a third of theirs. Where the certificate proves the family and the configuration Q = I (the anchor) is stable,
// the independent state matrix of random projectors of each rank at the set's ends and random masses is stable.
TEST(NumericalRangeCertificate, AProvenProxyFamilyIsStableInEveryConfiguration) {
    std::mt19937 rng(31);
    std::uniform_real_distribution<double> unit(0.0, 1.0);
    const double s_lo = 0.7, s_hi = 1.4;
    int proven = 0, configurations = 0;
    for (int trial = 0; trial < 30; ++trial) {
        const NormalizedPlant plant{0.0, 0.0, trial % 2 == 0 ? 1.0 : 2.0};
        const VelocityEstimator estimator = VelocityEstimator{};
        const hapticopt::MassScalingTest test(plant, estimator);
        const double top = 0.02 / (1 + plant.delay);
        const Sum planes = random_planes(rng, top, 0.25, 3, 0.3);
        const ProxyFamily f{planes.A, planes.B, random_mass_inverse_sqrt(rng), top * (0.2 + 0.3 * unit(rng)),
                            0.25 * (0.2 + 0.3 * unit(rng))};
        const coupled_loop_matrix::Difference e = difference_of(estimator);
        const auto full = f.at(Eigen::MatrixXd::Identity(3, 3));
        const bool anchor = coupled_loop_matrix::state_radius(plant, full.first, full.second, e) < 1.0;
        const hapticopt::NumericalRangeCertificate c = hapticopt::certify_by_numerical_range(
            f.members(), s_lo, s_hi, 16, [&](const GainSegment& g) { return test.segment_over(g); }, 256);
        if (!(c.proven && anchor)) continue;
        ++proven;
        for (int k = 0; k < 30; ++k) {
            const auto [A, B] = f.at(random_projector(rng, 1 + k % 3));
            const double s = k % 10 == 0 ? s_lo : (k % 10 == 1 ? s_hi : s_lo + (s_hi - s_lo) * unit(rng));
            ++configurations;
            EXPECT_LT(coupled_loop_matrix::state_radius(plant, s * A, s * B, e), 1.0)
                << "trial " << trial << ", configuration " << k << ", s = " << s;
        }
    }
    std::printf("[ proven ] %d of 30 proxy families; %d configurations judged by the state matrix\n", proven,
                configurations);
    EXPECT_GE(proven, 10);
}

// Why the family and not its configuration Q = I alone: with the gains near the region's edge, many families have a
// configuration of rank 1 or 2 whose loop grows (state matrix radius > 1 + 1e-6; no direction is left free: the other
// gains are three planes, positive definite) while Q = I is stable. The certificate of Q = I alone proves many of
// them; the family's certificate proves none.
TEST(NumericalRangeCertificate, TheConfigurationIAloneDoesNotCoverAProxyTheFamilyDoes) {
    std::mt19937 rng(5);
    std::uniform_real_distribution<double> unit(0.0, 1.0);
    int unstable_families = 0, proven_by_identity = 0, proven_by_family = 0;
    for (int trial = 0; trial < 400; ++trial) {
        const NormalizedPlant plant{0.0, 0.0, static_cast<double>(trial % 3)};
        const hapticopt::MassScalingTest test(plant, VelocityEstimator{});
        const double top = 0.1 / (1 + plant.delay) * (0.3 + unit(rng));
        const Sum planes = random_planes(rng, top, 0.3 * unit(rng) + 0.02, 3, 0.1);
        const ProxyFamily f{planes.A, planes.B, random_mass_inverse_sqrt(rng), top * unit(rng), 0.3 * unit(rng) + 0.01};
        const coupled_loop_matrix::Difference e = coupled_loop_matrix::window(1);
        const auto full = f.at(Eigen::MatrixXd::Identity(3, 3));
        if (!(coupled_loop_matrix::state_radius(plant, full.first, full.second, e) < 1.0)) continue;
        bool unstable = false;
        for (int k = 0; k < 60 && !unstable; ++k) {
            const auto [A, B] = f.at(random_projector(rng, 1 + k % 2));
            unstable = coupled_loop_matrix::state_radius(plant, A, B, e) > 1.0 + 1e-6;
        }
        if (!unstable) continue;
        ++unstable_families;
        auto verdict = [&](const GainSegment& g) { return test.segment_over(g); };
        proven_by_identity +=
            hapticopt::certify_by_numerical_range(full.first, full.second, 1.0, 1.0, 16, verdict, 256).proven ? 1 : 0;
        proven_by_family +=
            hapticopt::certify_by_numerical_range(f.members(), 1.0, 1.0, 16, verdict, 256).proven ? 1 : 0;
    }
    std::printf("[ families ] %d with an unstable configuration: Q = I alone proves %d, the family %d\n",
                unstable_families, proven_by_identity, proven_by_family);
    EXPECT_GE(unstable_families, 20);
    EXPECT_GE(proven_by_identity, 10);
    EXPECT_EQ(proven_by_family, 0);
}

TEST(NumericalRangeCertificate, AnUnstableEdgeIsNamed) {
    const NormalizedPlant plant{0.0, 0.0, 1.0};
    const hapticopt::MassScalingTest test(plant);
    Eigen::Matrix3d A = Eigen::Matrix3d::Zero(), B = Eigen::Matrix3d::Zero();
    const Eigen::Vector3d n1(1, 0, 0), n2 = Eigen::Vector3d(1, 1, 0).normalized();
    A += 0.3 * n1 * n1.transpose() + 0.01 * n2 * n2.transpose();  // 0.3: beyond alpha_max = 0.1445 at d = 1
    B += 0.2 * n1 * n1.transpose() + 0.3 * n2 * n2.transpose();
    A(2, 2) = 0.01;
    B(2, 2) = 0.2;
    const hapticopt::NumericalRangeCertificate c = hapticopt::certify_by_numerical_range(
        A, B, 1.0, 1.0, 16, [&](const GainSegment& g) { return test.segment_over(g); });
    EXPECT_FALSE(c.proven);
    EXPECT_GE(c.edges, 1);
    EXPECT_FALSE(
        test.stable(c.failing_alpha, c.failing_beta) &&
        hapticopt::stability(plant, hapticopt::NormalizedGains{c.failing_alpha, c.failing_beta}).spectral_radius <
            1.0 - 1e-7);
}

TEST(NumericalRangeCertificate, BadInputIsRefusedNamingTheParameter) {
    const Eigen::MatrixXd A = Eigen::Matrix2d::Identity(), B = Eigen::Matrix2d::Identity();
    auto expect_names = [](auto&& call, const char* name) {
        try {
            call();
            ADD_FAILURE() << "no exception for " << name;
        } catch (const hapticopt::InvalidParameter& e) {
            EXPECT_NE(std::string(e.what()).find(name), std::string::npos) << e.what();
        }
    };
    expect_names([&] { (void)hapticopt::numerical_range_polygon(A, B, 6); }, "directions");
    expect_names([&] { (void)hapticopt::numerical_range_polygon(A, B, 0); }, "directions");
    Eigen::MatrixXd nan = A;
    nan(0, 1) = std::nan("");
    expect_names([&] { (void)hapticopt::numerical_range_polygon(nan, B, 8); }, "A, B");
    expect_names([&] { (void)hapticopt::numerical_range_polygon(A, Eigen::Matrix3d::Identity(), 8); }, "A, B");
    expect_names([&] { (void)hapticopt::scaled_polygon_hull({}, 0.0, 1.0); }, "scale interval");
    const hapticopt::MassScalingTest test(NormalizedPlant{0.0, 0.0, 1.0});
    expect_names([&] { (void)test.segment_over(GainSegment{0.01, 0.1, 0.01, 0.1, -0.5, 1.0}); }, "u interval");
    EXPECT_FALSE(test.segment_over(GainSegment{std::nan(""), 0.1, 0.01, 0.1, 0.0, 1.0}).stable);  // as over()
    const hapticopt::ArmBoxTest box(NormalizedPlant{}, VelocityEstimator{}, 0.0, 0.0, 1.0, 1.0);
    expect_names([&] { (void)box.segment_over(GainSegment{0.01, 0.1, 0.01, 0.1, 2.0, 1.0}); }, "u interval");
}

}  // namespace numerical_range_certificate_test
