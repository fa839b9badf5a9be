// SPDX-License-Identifier: Apache-2.0
// The mean-value form of the arm box's zero exclusion (arm_box_stability.hpp, interval_exponential.hpp,
// zonotope_distance.hpp), checked by methods that share none of its code:
//  * the zonotope's distance from the origin against its support function sampled in 20 000 directions (every
//    direction gives a lower bound; the sampled maximum is within the direction step of the exact one), against the
//    brute-force least distance over all its m 2^(m-1) candidate boundary edges, and against points drawn inside it;
//  * the coefficients' gradient enclosures against central differences of the coefficients computed with the library's
//    double exponential (exponential_integrals.hpp) at points drawn from each box;
//  * the mean-value margin at a point of the circle against |p| there at plants drawn from its box, and its slope bound
//    against the margin a step away;
//  * every verdict "stable" against the coupled loop's state matrix (tests/common/coupled_loop_matrix.hpp, built with
//    Eigen's matrix exponential, not with hapticopt's polynomials), at the box's corners and at random plants, for
//    near-free gain segments (the first step of a plane's ramp: roots near z = 1) and random segments near the
//    stability boundary.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <complex>
#include <hapticopt/arm_box_stability.hpp>
#include <hapticopt/zonotope_distance.hpp>
#include <random>
#include <vector>

#include "common/coupled_loop_matrix.hpp"

namespace arm_box_mean_value_test {

using hapticopt::ArmBoxStability;
using hapticopt::ArmBoxTest;
using hapticopt::GainSegment;
using hapticopt::NormalizedPlant;
using hapticopt::VelocityEstimator;
using hapticopt::VelocityEstimatorKind;

TEST(ZonotopeDistance, AgreesWithItsSupportFunctionAndHoldsItsPoints) {
    std::mt19937 rng(7);
    std::uniform_real_distribution<double> u(-1.0, 1.0);
    const double pi = 3.14159265358979323846;
    constexpr int kDirections = 20000;
    for (int trial = 0; trial < 300; ++trial) {
        const std::size_t m = static_cast<std::size_t>(trial % 10);
        std::vector<std::complex<double>> g(m);
        for (auto& v : g) {
            const double scale = std::pow(10.0, -3.0 * (u(rng) + 1.0));
            v = {scale * u(rng), scale * u(rng)};
        }
        if (trial % 7 == 0 && m > 1) g[1] = -2.5 * g[0];  // parallel generators
        double size = 0;
        for (const auto& v : g) size += std::abs(v);
        const std::complex<double> c(2.0 * size * u(rng) + u(rng) * 1e-3, 2.0 * size * u(rng));
        const double d = hapticopt::zonotope_origin_distance(c, g.data(), m);
        // The support function: for a unit w, w.c - sum |w.g_k| <= distance (the zonotope lies beyond that line); its
        // maximum over w equals the distance when the origin is outside (else it is <= 0), and it moves by at most
        // |c| + sum |g_k| per radian, so the sampled maximum is within that times pi / kDirections.
        double best = -1e300;
        for (int j = 0; j < kDirections; ++j) {
            const std::complex<double> w = std::polar(1.0, 2.0 * pi * j / kDirections);
            double f = w.real() * c.real() + w.imag() * c.imag();
            for (const auto& v : g) f -= std::abs(w.real() * v.real() + w.imag() * v.imag());
            best = std::max(best, f);
        }
        const double rounding = 1e-14 * (std::abs(c) + size);
        EXPECT_LE(best, d + rounding) << "trial " << trial;
        EXPECT_GE(std::max(best, 0.0), d - (std::abs(c) + size) * pi / kDirections - rounding) << "trial " << trial;
        EXPECT_GE(d, 0.0);
        // Brute force: every boundary edge of Z is c + sum_{j != k} (+-1) g_j + [-1, 1] g_k for some k and signs, so
        // when the origin is outside, the least distance over all m 2^(m-1) such segments is the distance.
        if (best > (std::abs(c) + size) * pi / kDirections + rounding) {
            double brute = std::abs(c);
            for (std::size_t k = 0; k < m; ++k) {
                for (unsigned signs = 0; signs < (1u << m); ++signs) {
                    std::complex<double> a = c;
                    for (std::size_t j = 0; j < m; ++j) {
                        if (j != k) a += ((signs >> j) & 1u ? 1.0 : -1.0) * g[j];
                    }
                    const std::complex<double> from = a - g[k], e = 2.0 * g[k];
                    const double along =
                        std::norm(e) > 0 ? std::clamp(-(from * std::conj(e)).real() / std::norm(e), 0.0, 1.0) : 0.0;
                    brute = std::min(brute, std::abs(from + along * e));
                }
            }
            EXPECT_NEAR(d, brute, rounding) << "trial " << trial;
        } else if (d > 0) {
            EXPECT_LE(best, (std::abs(c) + size) * pi / kDirections + rounding) << "trial " << trial;
        }
        // Points of the zonotope are no nearer than the distance; with c moved onto one, the origin is inside.
        std::complex<double> point = c;
        for (const auto& v : g) point += u(rng) * v;
        EXPECT_GE(std::abs(point), d - rounding);
        EXPECT_LE(hapticopt::zonotope_origin_distance(c - point, g.data(), m), rounding) << "trial " << trial;
    }
}

TEST(ArmBoxMeanValue, TheGradientEnclosureHoldsCentralDifferences) {
    std::mt19937 rng(19);
    std::uniform_real_distribution<double> u(0.0, 1.0);
    // gamma_H <= 0.1, delta_H <= 1: |A t|_inf <= 2.1, so the coefficients' third derivatives are below ~50 and the
    // central difference with step 1e-5 is within 50 h^2 / 6 ~ 1e-9 of the derivative, plus its rounding
    // 2 eps max|c| / (2 h) ~ 1e-10: the tolerance 1e-8 holds both.
    const ArmBoxTest test(NormalizedPlant{0, 0, 0}, VelocityEstimator{}, 0.1, 1.0, 0.0, 1.0);
    constexpr double kStep = 1e-5, kTolerance = 1e-8;
    for (int trial = 0; trial < 100; ++trial) {
        const double scale = std::pow(10.0, -5.0 * u(rng));
        const double g0 = 0.09 * u(rng), d0 = 0.9 * u(rng), f0 = 0.9 * u(rng);
        const double g1 = g0 + 0.01 * scale * u(rng), d1 = d0 + 0.1 * scale * u(rng), f1 = f0 + 0.1 * scale * u(rng);
        const auto e = test.coefficient_gradient_enclosure({g0, g1}, {d0, d1}, {f0, f1});
        for (int k = 0; k < 10; ++k) {
            const double x[3] = {g0 + (g1 - g0) * u(rng), d0 + (d1 - d0) * u(rng), f0 + (f1 - f0) * u(rng)};
            const auto c = test.coefficients(x[0], x[1], x[2]);
            for (std::size_t i = 0; i < 5; ++i) {
                EXPECT_LE(e[i].v.lo, c[i]);
                EXPECT_GE(e[i].v.hi, c[i]);
            }
            for (std::size_t j = 0; j < 3; ++j) {
                double up[3] = {x[0], x[1], x[2]}, down[3] = {x[0], x[1], x[2]};
                up[j] += kStep;
                down[j] -= kStep;
                const auto cu = test.coefficients(up[0], up[1], up[2]),
                           cd = test.coefficients(down[0], down[1], down[2]);
                for (std::size_t i = 0; i < 5; ++i) {
                    const double fd = (cu[i] - cd[i]) / (2.0 * kStep);
                    EXPECT_LE(e[i].d[j].lo, fd + kTolerance) << "coefficient " << i << ", axis " << j;
                    EXPECT_GE(e[i].d[j].hi, fd - kTolerance) << "coefficient " << i << ", axis " << j;
                }
            }
        }
    }
}

// |p(z)| of an ascending polynomial, by Horner in long double.
double modulus(const Eigen::VectorXd& p, std::complex<long double> z) {
    std::complex<long double> v = 0;
    for (Eigen::Index k = p.size() - 1; k >= 0; --k) v = v * z + static_cast<long double>(p(k));
    return static_cast<double>(std::abs(v));
}

// The margin is a lower bound of |p| at every plant and gain of its box (by the polynomial at sampled points: corners,
// random, and the two nearest the box's centre plant's minimum), and it moves by no more than its slope bound.
TEST(ArmBoxMeanValue, TheMarginBoundsThePolynomialAtThePlantsOfItsBox) {
    std::mt19937 rng(41);
    std::uniform_real_distribution<double> u(0.0, 1.0);
    const double pi = 3.14159265358979323846;
    int positive = 0;
    for (int trial = 0; trial < 300; ++trial) {
        const VelocityEstimator e = trial % 3 == 0   ? VelocityEstimator{}
                                    : trial % 3 == 1 ? VelocityEstimator::low_pass(0.05)
                                                     : VelocityEstimator::moving_window(4);
        const ArmBoxTest test(NormalizedPlant{0, 0, 0}, e, 1e-2, 0.1, 0.0, 4.0);
        const double width = std::pow(10.0, -4.0 * u(rng));
        const double g0 = 1e-3 * u(rng), d0 = 0.05 * u(rng), f0 = 0.9 * u(rng);
        const double g1 = g0 + 1e-3 * width * u(rng), d1 = d0 + 0.02 * width * u(rng), f1 = f0 + 0.1 * width * u(rng);
        const int n = static_cast<int>(3 * u(rng));
        const hapticopt::GainSegment g =
            u(rng) < 0.5 ? GainSegment::between(1e-4 * u(rng), 1e-2 * u(rng), 0.1 * u(rng), 0.3 * u(rng))
                         : GainSegment::ray(0.05 * u(rng) * u(rng), 0.2 * u(rng), 0.9, 1.1);
        // theta near 0 (where near-free roots are) or anywhere.
        const double theta = u(rng) < 0.5 ? 0.05 * u(rng) * u(rng) : pi * u(rng);
        const ArmBoxTest::CircleMargin m = test.mean_value_margin({g0, g1}, {d0, d1}, {f0, f1}, n, g, theta);
        const std::complex<long double> z = std::polar(1.0L, static_cast<long double>(theta));
        double smallest = 1e300;
        for (int k = 0; k < 80; ++k) {
            auto side = [&](double lo, double hi, int bit) {
                return k < 16 ? ((k >> bit) & 1 ? hi : lo) : lo + (hi - lo) * u(rng);
            };
            const double gh = side(g0, g1, 0), dh = side(d0, d1, 1), f = side(f0, f1, 2), s = side(g.u_lo, g.u_hi, 3);
            smallest = std::min(smallest, modulus(test.polynomial(gh, dh, n, f, 1.0, g.alpha(s), g.beta(s)), z));
        }
        if (m.margin > 0) ++positive;
        EXPECT_LE(m.margin, smallest) << "trial " << trial;
        // The slope bound over [theta, theta + h]: the margin at theta + t differs by at most (slope + h growth) t
        // (both computed, so up to their rounding allowances, ~1e-13 of the polynomials' size).
        const double h = std::pow(10.0, -3.0 * u(rng));
        for (int j = 1; j <= 8; ++j) {
            const double t = h * j / 8;
            const ArmBoxTest::CircleMargin next = test.mean_value_margin({g0, g1}, {d0, d1}, {f0, f1}, n, g, theta + t);
            EXPECT_LE(std::abs(next.margin - m.margin), (m.slope + h * m.growth) * t + 1e-12) << "trial " << trial;
        }
    }
    EXPECT_GT(positive, 100);  // the bound is informative, not vacuous
}

coupled_loop_matrix::Difference difference_of(const VelocityEstimator& e) {
    if (e.kind == VelocityEstimatorKind::lowpass) return coupled_loop_matrix::low_pass(e.cutoff);
    return coupled_loop_matrix::window(e.kind == VelocityEstimatorKind::window ? e.window : 1);
}

struct Box {
    VelocityEstimator e;
    double gamma_max, delta_max, d_lo, d_hi;
};

// The largest state-matrix radius of the loop with the segment's gains over the box: its 16 corners of (gamma_H,
// delta_H, delay, u) and `random` plants drawn inside.
double largest_radius(const Box& box, const GainSegment& g, int random, std::mt19937& rng) {
    std::uniform_real_distribution<double> u(0.0, 1.0);
    const coupled_loop_matrix::Difference diff = difference_of(box.e);
    double largest = 0;
    for (int k = 0; k < 16 + random; ++k) {
        auto side = [&](double lo, double hi, int bit) {
            return k < 16 ? ((k >> bit) & 1 ? hi : lo) : lo + (hi - lo) * u(rng);
        };
        const NormalizedPlant plant{side(0.0, box.gamma_max, 0), side(0.0, box.delta_max, 1),
                                    side(box.d_lo, box.d_hi, 2)};
        const double s = side(g.u_lo, g.u_hi, 3);
        const Eigen::MatrixXd A = Eigen::MatrixXd::Constant(1, 1, g.alpha(s)),
                              B = Eigen::MatrixXd::Constant(1, 1, g.beta(s));
        largest = std::max(largest, coupled_loop_matrix::state_radius(plant, A, B, diff));
    }
    return largest;
}

// The first ramp step of a 100 N/m, 1 N s/m plane at 45 degrees to a CE2 wall on a 0.30 kg axis (the sum's soft
// direction: (alpha, beta) ~ (1.8e-7, 5.1e-5)): the longest edge of its numerical range's hull, from the soft corner to
// the stiff one, over the masses 0.2727 .. 0.33 kg (s in [0.909, 1.1]).
TEST(ArmBoxMeanValue, ANearFreeSegmentIsProvenOnEveryBoxAndItsPlantsAreStable) {
    const GainSegment edge = GainSegment::between(1.77654e-07, 5.05087e-05, 0.224927, 0.543072);
    std::mt19937 rng(3);
    for (const Box& box :
         {Box{VelocityEstimator{}, 0.0, 0.0, 0.0, 0.0}, Box{VelocityEstimator{}, 1e-4, 0.0, 0.0, 0.0},
          Box{VelocityEstimator{}, 0.0, 2e-3, 0.0, 0.0}, Box{VelocityEstimator{}, 1e-3, 0.02, 0.0, 0.3}}) {
        const ArmBoxTest test(NormalizedPlant{0, 0, 0}, box.e, box.gamma_max, box.delta_max, box.d_lo, box.d_hi);
        for (const GainSegment& g : {edge, GainSegment::ray(1.77654e-07, 5.05087e-05, 0.909, 1.1)}) {
            const ArmBoxStability v = test.segment_over(g);  // the library's budget, kArmBoxMaxBoxes
            EXPECT_TRUE(v.stable) << "box gamma " << box.gamma_max << ", delta " << box.delta_max << ", delay "
                                  << box.d_hi << ": refused at gamma " << v.failing_gamma << ", delta "
                                  << v.failing_delta << ", delay " << v.failing_delay << " after " << v.boxes;
            // Roots near z = 1 (1 - |z| ~ beta / 2 ~ 2.5e-5 at the soft end): the radius stays below 1 by far more
            // than the eigenvalues' error (~1e-12 for simple roots).
            EXPECT_LT(largest_radius(box, g, 48, rng), 1.0);
        }
    }
}

// Random boxes and segments (near-free ends, or gains scaled to lie near the boundary), three estimators: every stable
// verdict holds at the corners and 48 random plants of its box by the state matrix; nearly all are decided.
TEST(ArmBoxMeanValue, RandomSegmentsVerdictsHoldAtTheirPlants) {
    std::mt19937 rng(29), sampler(31);
    std::uniform_real_distribution<double> u(0.0, 1.0);
    int stable = 0, unstable = 0, refused = 0;
    for (int trial = 0; trial < 120; ++trial) {
        const VelocityEstimator e = trial % 3 == 0   ? VelocityEstimator{}
                                    : trial % 3 == 1 ? VelocityEstimator::low_pass(0.05)
                                                     : VelocityEstimator::moving_window(4);
        Box box{e, u(rng) < 0.3 ? 0.0 : 2e-3 * u(rng), u(rng) < 0.3 ? 0.0 : 0.05 * u(rng), 0.0, 0.0};
        box.d_lo = std::floor(3 * u(rng)) + (u(rng) < 0.5 ? 0.0 : u(rng));
        box.d_hi = box.d_lo + (u(rng) < 0.3 ? 0.0 : 0.7 * u(rng));
        const double scale = 0.3 / (1 + box.d_hi) * (trial % 3 == 2 ? 0.5 : 1.0);
        auto pick = [&]() {
            const double a = u(rng) < 0.3 ? 1e-5 * u(rng) : scale * u(rng);
            const double b = u(rng) < 0.3 ? 1e-3 * u(rng) : 3 * scale * u(rng);
            return std::array<double, 2>{a, b};
        };
        const auto [a0, b0] = pick();
        const auto [a1, b1] = pick();
        const GainSegment g = u(rng) < 0.5 ? GainSegment::between(a0, b0, a1, b1) : GainSegment::ray(a0, b0, 0.9, 1.1);
        const ArmBoxTest test(NormalizedPlant{0, 0, 0}, e, box.gamma_max, box.delta_max, box.d_lo, box.d_hi);
        const ArmBoxStability v = test.segment_over(g, 256);
        if (!v.stable) {
            ++(v.proven_unstable ? unstable : refused);
            continue;
        }
        ++stable;
        // Simple roots: the eigenvalues' error ~1e-12; a root pair near z = 1 of a near-free segment: ~sqrt(eps).
        EXPECT_LT(largest_radius(box, g, 48, sampler), 1.0 + 1e-7)
            << "trial " << trial << ": (" << a0 << ", " << b0 << ") -> (" << a1 << ", " << b1 << ")";
    }
    // Both outcomes occur (the draw straddles the boundary), and nearly every segment is decided (near-free ends are
    // where the radii's bound alone gives up: BM_NearFreeEdge, docs/benchmarks.md).
    EXPECT_GT(stable, 20);
    EXPECT_GT(unstable, 20);
    EXPECT_LE(refused, 3);
}

}  // namespace arm_box_mean_value_test
