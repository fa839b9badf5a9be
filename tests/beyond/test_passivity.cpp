// SPDX-License-Identifier: Apache-2.0
// Passivity of the wall with an integer delay (passivity.hpp). The exact maximum over frequency
// is checked against an independent direct evaluation of Colgate and Schenkel's complex expression on a
// fine grid (with the grid's error bound), against closed forms worked out by hand (d = 0, beta = 0, d = 1),
// passive => stable on a dense sample, the passive polygon, the best passive gains and the CLI's answer.
#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <complex>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include <hapticopt/hapticopt.hpp>

#include "common/test_paths.hpp"

namespace hapticopt {
namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kU = 1.1102230246251565e-16;  // unit roundoff of double

/// The frequency-domain expression of Colgate and Schenkel, evaluated directly with complex arithmetic
/// (independent of the Chebyshev closed form): Re{(1 - e^{-j th}) e^{-j d th} (alpha + beta (1 - e^{-j th}))}
/// / (2 (1 - cos th)), 0 < th <= pi. 1 - e^{-j th} is formed as 2 sin^2(th/2) + j sin th (no cancellation).
double direct_condition(double alpha, double beta, int d, double theta) {
    const double s = std::sin(theta / 2);
    const std::complex<double> u(2 * s * s, std::sin(theta));
    const std::complex<double> delay = std::polar(1.0, -d * theta);
    return std::real(u * delay * (alpha + beta * u)) / (4 * s * s);
}

// The exact maximiser against the direct complex form on a grid of N = 20000 frequencies.
// Grid bound: R(theta) is even and smooth, so between the grid points (spacing h = pi/N, the first one at h)
// the maximum exceeds the best grid value by at most L h^2 / 2, L = max |R''| <= |alpha| sum_{k<=d} k^2 +
// |beta| (d+1)^2 (differentiate R = alpha/2 + alpha sum cos k th - beta cos (d+1) th twice). Rounding of the
// direct form: the product has absolute error <= 8 u |u||w|, divided by |u|^2 = 4 sin^2(th/2) >= 4 sin^2(h/2):
// <= 8 u (|alpha| + 2|beta|) / (2 sin(h/2)) per point.
TEST(PassivityMaximum, AgreesWithDirectComplexEvaluationOnAFineGrid) {
    std::mt19937 rng(15);
    std::uniform_real_distribution<double> u(-1.0, 1.0);
    const int N = 20000;
    const double h = kPi / N;
    double worst_gap = 0, worst_bound = 0;
    for (int d = 0; d <= 8; ++d) {
        for (int i = 0; i < 40; ++i) {
            const double alpha = i % 5 == 0 ? -0.2 * std::abs(u(rng)) : 0.5 * std::abs(u(rng));
            const double beta = i % 7 == 0 ? 0.0 : u(rng);
            const PassivityConditionMaximum m = passivity_condition_maximum({alpha, beta}, d);
            double grid = -HUGE_VAL;
            for (int k = 1; k <= N; ++k) grid = std::max(grid, direct_condition(alpha, beta, d, k * h));
            double sum_k2 = 0;
            for (int k = 1; k <= d; ++k) sum_k2 += double(k) * k;
            const double L = std::abs(alpha) * sum_k2 + std::abs(beta) * (d + 1.0) * (d + 1.0);
            const double rounding = 8 * kU * (std::abs(alpha) + 2 * std::abs(beta)) / (2 * std::sin(h / 2));
            // The grid never exceeds the exact maximum (+ the method's stated bound + grid rounding) ...
            EXPECT_LE(grid, m.value + m.error_bound + rounding) << "d=" << d << " alpha=" << alpha << " beta=" << beta;
            // ... and comes within the grid bound of it.
            EXPECT_GE(grid, m.value - m.error_bound - L * h * h / 2 - rounding)
                << "d=" << d << " alpha=" << alpha << " beta=" << beta;
            // The reported maximiser attains the value (direct form there, theta = 0 as the limit R(0)).
            const double at = m.theta > 0 ? direct_condition(alpha, beta, d, m.theta) : alpha * (d + 0.5) - beta;
            EXPECT_NEAR(at, m.value, m.error_bound + 1e-12 * (std::abs(alpha) + std::abs(beta)) * (d + 1));
            worst_gap = std::max(worst_gap, std::abs(grid - m.value));
            worst_bound = std::max(worst_bound, m.error_bound);
        }
    }
    std::printf("exact max vs 20000-point grid: largest |difference| %.3g, largest stated error bound %.3g\n",
                worst_gap, worst_bound);
}

/// The direct complex form of direct_condition in long double (u_ld = 2^-64), 0 < theta <= pi.
long double direct_condition_ld(double alpha, double beta, int d, long double theta) {
    const long double s = std::sin(theta / 2);
    const std::complex<long double> u(2 * s * s, std::sin(theta));
    const std::complex<long double> delay = std::polar(1.0L, -static_cast<long double>(d) * theta);
    return std::real(u * delay * (static_cast<long double>(alpha) + static_cast<long double>(beta) * u)) / (4 * s * s);
}

/// The maximum of R over [0, pi] in long double by the direct complex form, and the allowance for its rounding
/// (test below): theta = 0 as the limit R(0) = alpha (d + 1/2) - beta, theta = pi, and golden section (60 steps)
/// within [theta_{k-1}, theta_{k+1}] of every local maximum k of a grid of N frequencies (N must put R's local maxima
/// more than 2 pi / N apart). Allowance: 4 u_ld (d + 2)(|alpha| + |beta|) at theta = 0, else
/// (8 + 2 d pi) u_ld (|alpha| + 2|beta|) / (2 sin(theta/2)) at the maximiser (the product's rounding, as in the grid
/// test, plus that of the phase d theta, <= d pi u_ld), u_ld = 2^-64.
struct LongDoubleMaximum {
    long double value;
    long double allowance;
};
LongDoubleMaximum long_double_maximum(double alpha, double beta, int d, int N) {
    const long double h = static_cast<long double>(kPi) / N, u_ld = std::ldexp(1.0L, -64);
    LongDoubleMaximum best{static_cast<long double>(alpha) * (d + 0.5L) - beta,
                           4 * u_ld * (d + 2) * (std::abs(alpha) + std::abs(beta))};
    auto take = [&](long double theta) {
        const long double v = direct_condition_ld(alpha, beta, d, theta);
        if (v > best.value) {
            best.value = v;
            best.allowance = (8 + 2 * d * static_cast<long double>(kPi)) * u_ld *
                             (std::abs(alpha) + 2 * std::abs(beta)) / (2 * std::sin(theta / 2));
        }
    };
    take(static_cast<long double>(kPi));
    std::vector<long double> grid(static_cast<std::size_t>(N) + 1);
    for (int k = 1; k <= N; ++k) grid[static_cast<std::size_t>(k)] = direct_condition_ld(alpha, beta, d, k * h);
    grid[0] = best.value - 1;  // theta = 0 is handled exactly above; never an interior maximum of the grid
    for (int k = 1; k < N; ++k) {
        const auto i = static_cast<std::size_t>(k);
        if (!(grid[i] >= grid[i - 1] && grid[i] >= grid[i + 1])) continue;
        long double a = k == 1 ? h * 1e-3L : (k - 1) * h, b = (k + 1) * h;
        const long double g = 0.6180339887498948482L;
        for (int it = 0; it < 60; ++it) {
            const long double x1 = b - g * (b - a), x2 = a + g * (b - a);
            if (direct_condition_ld(alpha, beta, d, x1) < direct_condition_ld(alpha, beta, d, x2)) {
                a = x1;  // the maximum is in [x1, b]
            } else {
                b = x2;
            }
        }
        take((a + b) / 2);
    }
    return best;
}

// The stated error_bound at its own scale (the grid test above cannot see it: its grid error is ~1e-6). The exact
// maximum is at theta = 0, theta = pi (R is even about both) or at an interior local maximum; R is a trigonometric
// polynomial of degree d + 1 <= 9, so its local maxima are far more than 2 h apart on a grid of N = 1000 and each
// lies within [theta_{k-1}, theta_{k+1}] of a local maximum k of the grid, where golden section (60 steps: width
// 2 h 0.618^60 < 1e-15, so R there is within L 1e-30 of the peak) finds it. All in long double by the direct complex
// form; its rounding, as in the grid test with u_ld = 2^-64: 8 u_ld (|alpha| + 2|beta|) / (2 sin(theta/2)) at the
// maximiser (plus the phase's, long_double_maximum), and 4 u_ld (d + 2)(|alpha| + |beta|) for the limit
// R(0) = alpha (d + 1/2) - beta. Check, both ways: |exact maximum - value| <= error_bound + that rounding.
TEST(PassivityMaximum, ErrorBoundHoldsAgainstALongDoubleMaximum) {
    std::mt19937 rng(16);
    std::uniform_real_distribution<double> u(-1.0, 1.0);
    const int N = 1000;
    double worst_ratio = 0, worst_gap = 0, worst_rounding = 0;
    for (int d = 0; d <= 8; ++d) {
        for (int i = 0; i < 40; ++i) {
            const double alpha = i % 5 == 0 ? -0.2 * std::abs(u(rng)) : 0.5 * std::abs(u(rng));
            const double beta = i % 7 == 0 ? 0.0 : u(rng);
            const PassivityConditionMaximum m = passivity_condition_maximum({alpha, beta}, d);
            const LongDoubleMaximum reference = long_double_maximum(alpha, beta, d, N);
            const long double best = reference.value, allowance = reference.allowance;
            const double gap = static_cast<double>(std::abs(best - static_cast<long double>(m.value)));
            const double stated = m.error_bound + static_cast<double>(allowance);
            EXPECT_LE(gap, stated) << "d=" << d << " alpha=" << alpha << " beta=" << beta << " value " << m.value;
            worst_ratio = std::max(worst_ratio, gap / stated);
            worst_gap = std::max(worst_gap, gap);
            worst_rounding = std::max(worst_rounding, static_cast<double>(allowance));
        }
    }
    std::printf(
        "exact max vs long-double maximum: largest |difference| %.3g, largest long-double rounding allowance "
        "%.3g, largest |difference| / (error_bound + rounding) %.3g\n",
        worst_gap, worst_rounding, worst_ratio);
}

// The closed form of the header, R = alpha D_d / 2 - beta cos((d+1) theta) with the Dirichlet kernel
// D_d = 1 + 2 sum cos k theta, against the direct complex form (rounding allowance as above at theta >= 0.01).
TEST(PassivityMaximum, ChebyshevFormIsTheColgateSchenkelExpression) {
    for (int d : {0, 1, 2, 5, 12}) {
        for (double theta : {0.01, 0.3, 1.0, 2.0, 3.0, kPi}) {
            for (auto [alpha, beta] : {std::pair{0.3, 0.1}, std::pair{0.05, -0.4}, std::pair{-0.1, 0.7}}) {
                double dirichlet = 1;
                for (int k = 1; k <= d; ++k) dirichlet += 2 * std::cos(k * theta);
                const double closed = alpha * dirichlet / 2 - beta * std::cos((d + 1) * theta);
                EXPECT_NEAR(passivity_condition({alpha, beta}, d, theta), closed, 1e-13 * (d + 1));
                EXPECT_NEAR(direct_condition(alpha, beta, d, theta), closed, 1e-12 * (d + 1));
            }
        }
    }
}

// d = 0: max R = alpha/2 + |beta| (Colgate-Schenkel's b > K T/2 + |B|), to rounding.
TEST(PassivityMaximum, DelayFreeCaseIsTheClassicalCondition) {
    std::mt19937 rng(3);
    std::uniform_real_distribution<double> u(-1.0, 1.0);
    for (int i = 0; i < 200; ++i) {
        const double alpha = std::abs(u(rng)), beta = u(rng), delta = std::abs(u(rng));
        EXPECT_NEAR(passivity_margin(NormalizedPlant{0, delta, 0}, {alpha, beta}), delta - alpha / 2 - std::abs(beta),
                    4 * kU * (delta + alpha + std::abs(beta)));
    }
}

// beta = 0: R = alpha D_d(theta)/2 is largest at theta = 0 (D_d(0) = 2d + 1 >= |D_d|), so the largest
// passive alpha is delta / (d + 1/2); the issue's case is d = 1, delta = 0.02. Bisection on is_passive to 1e-15.
TEST(PassivityMaximum, LargestPassiveStiffnessWithoutDampingIsDeltaOverDPlusHalf) {
    for (int d = 0; d <= 6; ++d) {
        for (double delta : {0.02, 0.1}) {
            const NormalizedPlant plant{0, delta, double(d)};
            double lo = 0, hi = 1;
            while (hi - lo > 1e-15) {
                const double mid = (lo + hi) / 2;
                (is_passive(plant, {mid, 0.0}) ? lo : hi) = mid;
            }
            EXPECT_NEAR(lo, delta / (d + 0.5), 4e-15) << "d=" << d << " delta=" << delta;
        }
    }
}

// d = 1 over all beta: R(c) = alpha/2 + alpha c - beta (2c^2 - 1). For beta >= alpha/4 the parabola peaks at
// c = alpha/(4 beta) with value alpha/2 + beta + alpha^2/(8 beta), least at beta = alpha/(2 sqrt 2):
// alpha (1 + sqrt 2)/2; for beta < alpha/4 the maximum 3 alpha/2 - beta is larger. Hence the largest passive
// alpha is 2 delta (sqrt 2 - 1) at beta = delta (sqrt 2 - 1)/sqrt 2. Accuracy of largest_passive_alpha: its
// inner Brent minimum over beta is accurate to ~1.5e-8 |beta| (sqrt(eps) relative), and g is 1-Lipschitz
// in beta, so h(alpha) and alpha_top to ~1e-9 delta; beta at the smooth tip to ~1e-7 relative.
TEST(PassivityMaximum, UnitDelayTipIsTheClosedForm) {
    for (double delta : {0.02, 0.1}) {
        const PassiveAlphaLimit top = largest_passive_alpha(NormalizedPlant{0, delta, 1});
        EXPECT_NEAR(top.alpha, 2 * delta * (std::sqrt(2.0) - 1), 1e-9 * delta);
        EXPECT_NEAR(top.beta, delta * (std::sqrt(2.0) - 1) / std::sqrt(2.0), 1e-6 * delta);
    }
}

// The issue's example: alpha 0.03, beta 0, delta 0.02, d = 1 was reported passive (margin 0.005) while
// unstable. Now: margin = delta - 3 alpha / 2 = -0.025 and not passive; through the CLI too.
TEST(PassivityMaximum, IssueExampleIsNotPassive) {
    const NormalizedPlant plant{0, 0.02, 1};
    EXPECT_NEAR(passivity_margin(plant, {0.03, 0.0}), 0.02 - 1.5 * 0.03, 1e-15);
    EXPECT_FALSE(is_passive(plant, {0.03, 0.0}));
    EXPECT_FALSE(is_stable(plant, {0.03, 0.0}));
    const std::string out = "passivity_cli_example.json";
    ASSERT_EQ(
        std::system((std::string(HAPTICOPT_CLI) + " cost --alpha 0.03 --beta 0 --delta 0.02 --delay 1 --json > " + out)
                        .c_str()),
        0);
    std::ifstream in(out);
    std::stringstream text;
    text << in.rdbuf();
    EXPECT_NE(text.str().find("\"passive\":false"), std::string::npos) << text.str();
    EXPECT_NE(text.str().find("\"stable\":false"), std::string::npos) << text.str();
}

// The longest delay accepted, kMaxPassivityDelay = 1000 (degree 1001 of the Chebyshev series, whose derivative
// cascade loses digits as the degree grows), and d = 200, against long_double_maximum on a grid of N = 32 (d + 2)
// frequencies (R has degree d + 1, so its local maxima are about 32 grid steps apart), with its allowance. Gains:
// alpha in [0, 0.05] (small alphas put the maximum inside (0, pi)), |beta| <= 0.5. One more period is refused by
// name.
TEST(PassivityMaximum, LongestDelayAgreesWithALongDoubleMaximum) {
    std::mt19937 rng(17);
    std::uniform_real_distribution<double> ua(0.0, 0.05), ub(-0.5, 0.5);
    for (int d : {200, kMaxPassivityDelay}) {
        for (int trial = 0; trial < 3; ++trial) {
            const double alpha = trial == 0 ? 0.01 * ua(rng) : ua(rng), beta = ub(rng);
            const PassivityConditionMaximum m = passivity_condition_maximum({alpha, beta}, d);
            const LongDoubleMaximum reference = long_double_maximum(alpha, beta, d, 32 * (d + 2));
            const long double best = reference.value, allowance = reference.allowance;
            const double gap = static_cast<double>(std::abs(best - static_cast<long double>(m.value)));
            EXPECT_LE(gap, m.error_bound + static_cast<double>(allowance))
                << "d=" << d << " alpha=" << alpha << " beta=" << beta << " value " << m.value;
        }
    }
    EXPECT_TRUE(passivity_is_covered(NormalizedPlant{0, 0.02, 1000}));
    EXPECT_FALSE(passivity_is_covered(NormalizedPlant{0, 0.02, 1001}));
    try {
        passivity_margin(NormalizedPlant{0, 0.02, 1001}, {0.01, 0.0});
        ADD_FAILURE() << "no error for d = 1001";
    } catch (const InvalidParameter& e) {
        EXPECT_EQ(e.parameter(), "delay");
        EXPECT_NE(std::string(e.what()).find("0..1000"), std::string::npos) << e.what();
    }
}

// A fractional delay is refused by name, never answered with the integer result; the rounding of t_d / T
// (within 1e-9 of an integer) is accepted.
TEST(PassivityMaximum, FractionalDelayIsRefused) {
    for (double d : {0.5, 1.25, 2.999}) {
        try {
            passivity_margin(NormalizedPlant{0, 0.02, d}, {0.01, 0.0});
            ADD_FAILURE() << "no error for d = " << d;
        } catch (const InvalidParameter& e) {
            EXPECT_EQ(e.parameter(), "delay");
            EXPECT_NE(std::string(e.what()).find("not covered"), std::string::npos) << e.what();
        }
        EXPECT_FALSE(passivity_is_covered(NormalizedPlant{0, 0.02, d}));
        EXPECT_THROW(passive_optimum(2, NormalizedPlant{0, 0.02, d}), InvalidParameter);
    }
    const NormalizedPlant rounded = normalize(PhysicalPlant{0.3, 6.0, 0.0, 0.001, 0.003});
    EXPECT_TRUE(passivity_is_covered(rounded)) << rounded.delay;
    EXPECT_NO_THROW(passivity_margin(rounded, {0.001, 0.0}));
    // Negative stiffness stores unbounded negative energy: never passive.
    EXPECT_FALSE(is_passive(NormalizedPlant{0, 0.5, 0}, {-1e-6, 0.0}));
    EXPECT_TRUE(is_passive(NormalizedPlant{0, 0.5, 0}, {0.0, 0.1}));  // a pure damper on a damped device
}

// Passive => stable on a dense sample: d = 0..6, gamma in [0, 0.05], delta in (0, 0.5]; 12 alphas across
// (0, alpha_top) and 12 betas across each passive interval including points 1e-6 of its width from the edges.
// alpha = gamma = 0 is excluded: a free damped mass is passive but only marginally stable (pole at z = 1).
TEST(PassivityImplication, PassiveGainsAreStable) {
    int checked = 0;
    for (int d = 0; d <= 6; ++d) {
        for (double gamma : {0.0, 0.001, 0.05}) {
            for (double delta : {0.001, 0.02, 0.1, 0.5}) {
                const NormalizedPlant plant{gamma, delta, double(d)};
                const SampledPlant<double> sampled(plant);
                const double top = largest_passive_alpha(plant).alpha;
                for (int i = 0; i < 12; ++i) {
                    const double alpha = top * (i == 11 ? 1 - 1e-7 : (i + 0.5) / 11.5);
                    const auto [lo, hi] = passive_beta_interval(plant, alpha);
                    if (!(hi > lo)) continue;
                    for (int j = 0; j < 12; ++j) {
                        const double s = j == 0 ? 1e-6 : j == 11 ? 1 - 1e-6 : j / 11.0;
                        const double beta = lo + s * (hi - lo);
                        if (!is_passive(plant, {alpha, beta})) continue;  // the very edge, rounded outside
                        EXPECT_TRUE(loop_is_stable(sampled, alpha, beta))
                            << "d=" << d << " gamma=" << gamma << " delta=" << delta << " alpha=" << alpha
                            << " beta=" << beta;
                        ++checked;
                    }
                }
            }
        }
    }
    EXPECT_GT(checked, 7 * 3 * 4 * 100);
    std::printf("passive => stable: %d passive gain sets checked\n", checked);
}

// The polygon: its vertices lie on the passive boundary (margin ~ 0, to the bisection's resolution), points
// pulled 1e-6 towards its centre are passive and pushed 1e-6 away are not; d = 0 gives the triangle.
TEST(PassivePolygon, VerticesOnTheBoundary) {
    for (int d : {0, 1, 3, 6}) {
        const NormalizedPlant plant{0, 0.02, double(d)};
        const auto polygon = passive_polygon(plant, 40);
        ASSERT_GT(polygon.size(), 40u);
        double ca = 0, cb = 0;
        for (const auto& p : polygon) {
            ca += p.alpha;
            cb += p.beta;
        }
        ca /= polygon.size();
        cb /= polygon.size();
        EXPECT_TRUE(is_passive(plant, {ca, cb}));
        for (const auto& p : polygon) {
            EXPECT_NEAR(passivity_margin(plant, {p.alpha, p.beta}), 0.0, 1e-9) << "d=" << d;
            if (p.alpha == 0) continue;  // the alpha = 0 edge: outside is alpha < 0, tested in FractionalDelayIsRefused
            const double in_a = p.alpha + 1e-6 * (ca - p.alpha), in_b = p.beta + 1e-6 * (cb - p.beta);
            const double out_a = p.alpha - 1e-6 * (ca - p.alpha), out_b = p.beta - 1e-6 * (cb - p.beta);
            EXPECT_TRUE(is_passive(plant, {in_a, in_b})) << "d=" << d << " " << p.alpha << " " << p.beta;
            EXPECT_FALSE(is_passive(plant, {out_a, out_b})) << "d=" << d << " " << p.alpha << " " << p.beta;
            if (d == 0) {
                EXPECT_NEAR(p.alpha / 2 + std::abs(p.beta), 0.02, 1e-12);
            }
        }
    }
    EXPECT_TRUE(passive_polygon(NormalizedPlant{0, 0, 1}).empty());
}

// Best passive gains: passive, stable, dearer than the unconstrained optimum, and no point of a 30 x 30
// grid over the passive set is cheaper (the grid's cells are inside the set, so it cannot beat a true minimum).
TEST(PassiveOptimum, IsTheMinimumOverThePassiveSet) {
    for (int d : {0, 1, 3}) {
        const NormalizedPlant plant{0, 0.02, double(d)};
        const SampledPlant<double> sampled(plant);
        const auto po = passive_optimum(2, plant);
        ASSERT_TRUE(po.has_value());
        EXPECT_GE(po->margin, -1e-12);
        EXPECT_TRUE(is_stable(plant, {po->alpha, po->beta}));
        const Optimum o = optimal_point(Criterion::CE2, plant);
        EXPECT_GT(po->cost, *o.cost);
        const double top = largest_passive_alpha(plant).alpha;
        for (int i = 0; i < 30; ++i) {
            const double a = top * (i + 0.5) / 30;
            const auto [lo, hi] = passive_beta_interval(plant, a);
            for (int j = 0; j < 30; ++j) {
                const double b = lo + (hi - lo) * (j + 0.5) / 30;
                EXPECT_GE(energy_costs(sampled, a, b).ce2, po->cost * (1 - 1e-9)) << "d=" << d << " " << a << " " << b;
            }
        }
        const auto pi = passive_impulse_optimum(2, plant);
        ASSERT_TRUE(pi.has_value());
        EXPECT_GE(pi->margin, -1e-12);
    }
}

}  // namespace
}  // namespace hapticopt
