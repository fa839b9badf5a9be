// SPDX-License-Identifier: Apache-2.0
// Beyond the paper: collision criteria (closed form vs independent time-stepping, optimum vs
// grid), passivity (formula, the paper's optima are not passive, best passive gains), robust optimum
// (certified mass-segment check vs dense sweep, stability over the box, worst case vs nominal).
#include <gtest/gtest.h>

#include <Eigen/Core>
#include <array>
#include <cmath>
#include <cstdio>
#include <random>
#include <vector>

#include <hapticopt/hapticopt.hpp>

#include "../core/reference_simulation.hpp"
#include "paper_table.hpp"

namespace hapticopt {
namespace {

// ---------------------------------------------------------------------------------------------
// Independent method: the time-stepping of tests/core/reference_simulation.hpp (exact ZOH sub-steps with
// Eigen's matrix exponential, Simpson quadrature of E(t) t^p) from the collision initial conditions of
// impulse_costs.hpp: x(0) = 0, x'(0) = 1, x_{-1} = -1, zero forces before contact, no external force.
struct SimulatedImpulse {
    std::array<double, 3> ci{};
    double max_sampled_x = 0;  ///< max over the sub-step grid of x
    double max_accel = 0;      ///< max over the grid of |x''| (for the O(h^2) bound of the sampled max)
};

SimulatedImpulse simulate_impulse(double gamma, double delta, double d, double alpha, double beta, int substeps,
                                  int periods) {
    const testing::SimulatedLoop loop =
        testing::simulate_loop(gamma, delta, d, alpha, beta, substeps, periods, {0, 1, -1, 0, 0});
    return {loop.costs, loop.max_sampled_deviation, loop.max_accel};
}

struct Case {
    NormalizedPlant plant;
    NormalizedGains gains;
};

const std::vector<Case>& cases() {
    static const std::vector<Case> all = {
        {{0.0, 0.0, 0.0}, {0.30, 0.95}},  {{0.0, 0.0, 1.0}, {0.06, 0.38}},
        {{0.0, 0.02, 1.0}, {0.05, 0.30}}, {{0.001, 0.01, 0.5}, {0.10, 0.50}},
        {{0.0, 0.0, 2.0}, {0.02, 0.20}},  {{0.0005, 0.02, 0.0}, {0.01, 0.0}},  // beta = 0
    };
    return all;
}

// Tolerance. The integrand E(t) t^p is smooth on every sub-step (the force switches lie on the grid,
// at even sub-step indices, so every Simpson panel is smooth), hence composite Simpson converges at
// order 4: the error must fall by >= 8 (ideal 16) per halving of h until it reaches rounding (1e-11,
// the rounding floor of summing ~4e5 steps), and at h = 1/64 it must be below 1e-8 (measured: at most
// ~1.5e-9; the worst case is 2.4e-8 at h = 1/32, so an order-4 error constant of about 2e-2). The horizon of 6000
// periods leaves a relative tail below 1e-20 even for the slowest case (beta = 0, spectral radius about 0.993:
// 0.993^12000 t^2).
TEST(ImpulseCosts, ClosedFormMatchesTimeSteppingAtOrderFour) {
    for (const Case& c : cases()) {
        const ImpulseCosts exact = impulse_costs(c.plant, c.gains);
        ASSERT_TRUE(std::isfinite(exact.ci2)) << "case d=" << c.plant.delay;
        std::array<double, 3> previous{1, 1, 1};
        for (int substeps : {8, 16, 32, 64}) {
            const SimulatedImpulse sim = simulate_impulse(c.plant.gamma, c.plant.delta, c.plant.delay, c.gains.alpha,
                                                          c.gains.beta, substeps, 6000);
            for (int p = 0; p < 3; ++p) {
                const double error = std::abs(sim.ci[static_cast<std::size_t>(p)] / exact[p] - 1);
                if (previous[static_cast<std::size_t>(p)] > 1e-11) {
                    EXPECT_LT(error, previous[static_cast<std::size_t>(p)] / 8)
                        << "p=" << p << " substeps=" << substeps << " d=" << c.plant.delay
                        << " alpha=" << c.gains.alpha;
                }
                previous[static_cast<std::size_t>(p)] = error;
                std::printf("d=%g alpha=%g substeps=%d p=%d rel.error=%.3g\n", c.plant.delay, c.gains.alpha, substeps,
                            p, error);
            }
        }
        for (int p = 0; p < 3; ++p) EXPECT_LT(previous[static_cast<std::size_t>(p)], 1e-8) << "p=" << p;
    }
}

// The sampled maximum cannot exceed the continuous one, and misses it by at most 1/2 max|x''| h^2
// (Taylor at the maximum, where x' = 0, over a distance <= h to the nearest grid point).
TEST(ImpulseCosts, PenetrationBoundsTheSampledMaximum) {
    for (const Case& c : cases()) {
        const PenetrationResult exact = penetration(c.plant, c.gains);
        ASSERT_TRUE(exact.converged);
        const int substeps = 64;
        const SimulatedImpulse sim =
            simulate_impulse(c.plant.gamma, c.plant.delta, c.plant.delay, c.gains.alpha, c.gains.beta, substeps, 400);
        const double h = 1.0 / substeps;
        EXPECT_GE(exact.depth, sim.max_sampled_x - 1e-13) << "d=" << c.plant.delay;
        EXPECT_LE(exact.depth - sim.max_sampled_x, 0.5 * sim.max_accel * h * h + 1e-13) << "d=" << c.plant.delay;
    }
}

TEST(ImpulseCosts, UnstableIsInfiniteAndInputsAreValidated) {
    const ImpulseCosts c = impulse_costs(NormalizedPlant{0, 0, 1}, NormalizedGains{0.5, 0.4});
    EXPECT_TRUE(std::isinf(c.ci0));
    EXPECT_TRUE(std::isinf(penetration(NormalizedPlant{0, 0, 1}, NormalizedGains{0.5, 0.4}).depth));
    EXPECT_THROW(impulse_costs(NormalizedPlant{0, 0, 1}, NormalizedGains{NAN, 0.4}), InvalidParameter);
    EXPECT_THROW(impulse_costs(NormalizedPlant{-1, 0, 1}, NormalizedGains{0.1, 0.4}), InvalidParameter);
}

TEST(ImpulseCriterionNames, RoundTrip) {
    for (const ImpulseCriterion c : kAllImpulseCriteria) EXPECT_EQ(parse_impulse_criterion(to_string(c)), c);
    EXPECT_FALSE(parse_impulse_criterion("CE2").has_value());
    EXPECT_FALSE(parse_criterion("CI2").has_value());  // the step criteria are unchanged
}

// No point of a 60 x 60 grid over the exact stable region is better than the optimum.
TEST(ImpulseOptimum, NoGridPointIsBetter) {
    for (double d : {0.0, 1.0}) {
        const NormalizedPlant plant{0, 0, d};
        const ImpulseOptimizer opt(plant);
        for (const ImpulseCriterion c : kAllImpulseCriteria) {
            const ImpulseOptimum o = opt.optimum(c);
            ASSERT_TRUE(std::isfinite(o.cost));
            EXPECT_GT(o.penetration, 0);
            // C_I0's infimum is the pure damper on the edge alpha -> -gamma; C_I1, C_I2 have interior minima.
            EXPECT_EQ(o.on_region_edge, c == ImpulseCriterion::CI0) << to_string(c) << " d=" << d;
            if (c != ImpulseCriterion::CI0) {
                EXPECT_TRUE(o.penetration_converged);
            }
            const int k = energy_index(c);
            const auto& region = opt.region();
            const int n = 60;
            for (int i = 0; i < n; ++i) {
                const double a = region.alpha_min() + (region.alpha_max() - region.alpha_min()) * (i + 0.5) / n;
                const auto [lo, hi] = region.beta_range(a);
                for (int j = 0; j < n; ++j) {
                    const double b = lo + (hi - lo) * (j + 0.5) / n;
                    EXPECT_GE(opt.cost(k, a, b), o.cost * (1 - 1e-12))
                        << to_string(c) << " d=" << d << " a=" << a << " b=" << b;
                }
            }
        }
    }
}

// ---------------------------------------------------------------------------------------------
TEST(Passivity, MarginIsTheColgateSchenkelFormula) {
    const NormalizedPlant plant{0, 0.02, 0};
    EXPECT_DOUBLE_EQ(passivity_margin(plant, {0.01, 0.005}), 0.02 - 0.005 - 0.005);
    EXPECT_DOUBLE_EQ(passivity_margin(plant, {0.01, -0.005}), 0.02 - 0.005 - 0.005);
    // The boundary delta = alpha/2 + |beta|: just inside passive, just outside not.
    for (double beta : {-0.01, 0.0, 0.012}) {
        const double alpha = 2 * (0.02 - std::abs(beta));
        EXPECT_TRUE(is_passive(plant, {alpha * (1 - 1e-9), beta}));
        EXPECT_FALSE(is_passive(plant, {alpha * (1 + 1e-9), beta}));
    }
    // Physical form b - K T / 2 - |B| = margin m / T.
    const PhysicalPlant p{0.3, 6.0, 0.0, 0.001, 0.0};
    const WallGains g{1000.0, 2.0};
    const NormalizedGains n = normalize(g, p.mass, p.period);
    EXPECT_NEAR(passivity_margin(p, g), passivity_margin(normalize(p), n) * p.mass / p.period, 1e-12);
    EXPECT_FALSE(is_passive(NormalizedPlant{0, 0, 0}, {1e-6, 0.0}));  // delta = 0: nothing is passive
}

// The paper's remark: its optima violate passivity. Every printed optimum of Tables III and IV.
TEST(Passivity, PaperOptimaAreNotPassive) {
    int rows = 0;
    double closest = -HUGE_VAL, farthest = HUGE_VAL;
    for (const cli::PaperRow& r : cli::paper_rows()) {
        const NormalizedPlant plant{r.gamma, r.delta, r.delay};
        const double margin = passivity_margin(plant, {r.alpha.value, r.beta.value});
        closest = std::max(closest, margin);
        farthest = std::min(farthest, margin);
        EXPECT_LT(margin, 0) << r.table << " " << r.criterion << " gamma=" << r.gamma << " delta=" << r.delta;
        EXPECT_FALSE(is_passive(plant, {r.alpha.value, r.beta.value}));
        ++rows;
    }
    EXPECT_EQ(rows, 64);
    std::printf("passivity margins of the 64 printed optima: from %.4f to %.4f\n", farthest, closest);
}

// Colgate-Schenkel passive gains (d = 0) are stable, and the best passive gains are passive,
// stable and no better than the unconstrained optimum.
TEST(Passivity, BestPassiveGains) {
    std::mt19937 rng(8);
    std::uniform_real_distribution<double> u(0.0, 1.0);
    const NormalizedPlant plant{0, 0.02, 0};
    for (int i = 0; i < 500; ++i) {
        const double a = 2 * plant.delta * u(rng);
        const double half = plant.delta - a / 2;
        const double b = half * (2 * u(rng) - 1);
        if (a <= 0) continue;
        EXPECT_TRUE(is_stable(plant, {a, b})) << a << " " << b;
    }
    EXPECT_FALSE(passive_optimum(2, NormalizedPlant{0, 0, 0}).has_value());
    for (double d : {0.0, 1.0}) {
        const NormalizedPlant p{0, 0.02, d};
        for (int k = 0; k < 3; ++k) {
            const auto po = passive_optimum(k, p);
            ASSERT_TRUE(po.has_value());
            EXPECT_GE(po->margin, -1e-12);
            EXPECT_TRUE(is_stable(p, {po->alpha, po->beta}));
            const Optimum o = optimal_point(k == 0 ? Criterion::CE0 : k == 1 ? Criterion::CE1 : Criterion::CE2, p);
            EXPECT_GT(po->cost, *o.cost);
            const auto pi = passive_impulse_optimum(k, p);
            ASSERT_TRUE(pi.has_value());
            EXPECT_GE(pi->margin, -1e-12);
        }
    }
}

// ---------------------------------------------------------------------------------------------
// The exact crossing test agrees with a dense Schur-Cohn sweep (2001 masses) on random gains that
// straddle the robust boundary.
TEST(RobustOptimum, CrossingTestAgreesWithDenseSweep) {
    std::mt19937 rng(42);
    std::uniform_real_distribution<double> u(0.0, 1.0);
    for (double td : {0.0, 0.001, 0.0015}) {
        UncertainPlant box;
        box.mass = {0.22, 0.30};
        box.period = 0.001;
        box.time_delay = {td, td};
        const StabilityRegion region(NormalizedPlant{0, 0, td / box.period});
        int agree = 0, unstable = 0;
        for (int i = 0; i < 60; ++i) {
            const double alpha = region.alpha_max() * (0.05 + 1.0 * u(rng));  // at m = 0.26
            const double beta = region.beta_at_alpha_max() * 2.2 * u(rng);
            const WallGains g = to_physical(NormalizedGains{alpha, beta}, 0.26, box.period);
            const bool certified = detail::mass_segment_certified_stable(box, td, g.stiffness, g.damping);
            bool dense = true;
            const SampledPlant<double> sp(NormalizedPlant{0, 0, td / box.period});
            for (int k = 0; k <= 2000; ++k) {
                const double m = 0.22 + 0.08 * k / 2000;
                const NormalizedGains n = normalize(g, m, box.period);
                dense = dense && loop_is_stable(sp, n.alpha, n.beta);
            }
            EXPECT_EQ(certified, dense) << "td=" << td << " K=" << g.stiffness << " B=" << g.damping;
            agree += certified == dense;
            unstable += !dense;
        }
        EXPECT_GT(unstable, 5);  // the sample really straddles the boundary
        EXPECT_LT(unstable, 55);
    }
}

void expect_robust(const RobustOptimum& r, const UncertainPlant& box) {
    EXPECT_TRUE(r.stability.stable);
    EXPECT_TRUE(std::isfinite(r.worst.cost));
    // Stable at every corner and at random interior points of the box.
    std::mt19937 rng(7);
    std::uniform_real_distribution<double> u(0.0, 1.0);
    auto pick = [&](const ParameterRange& range, int corner, int bit) {
        return corner < 0 ? range.min + (range.max - range.min) * u(rng)
                          : ((corner >> bit) & 1 ? range.max : range.min);
    };
    for (int i = -200; i < 16; ++i) {
        const PhysicalPlant p{pick(box.mass, i, 0), pick(box.damping, i, 1), pick(box.stiffness, i, 2), box.period,
                              pick(box.time_delay, i, 3)};
        const NormalizedGains g = normalize(r.gains, p.mass, p.period);
        EXPECT_TRUE(is_stable(normalize(p), g)) << "m=" << p.mass << " b=" << p.damping << " td=" << p.time_delay;
        // The worst case over the box is not exceeded at sampled points (up to the refinement's tolerance).
        const double c = detail::physical_cost(r.criterion, p, SampledPlant<double>(normalize(p)), r.gains.stiffness,
                                               r.gains.damping);
        EXPECT_LE(c, r.worst.cost * (1 + 1e-6));
    }
    // No worse than the nominal optimum's worst case.
    EXPECT_LE(r.worst.cost, r.nominal_worst.cost);
}

TEST(RobustOptimum, FalconMassRangeCE2) {
    UncertainPlant box;
    box.mass = {0.22, 0.30};
    box.period = 0.001;
    box.time_delay = {0.001, 0.001};
    const RobustOptimum r = robust_optimum(Criterion::CE2, box);
    expect_robust(r, box);
    EXPECT_TRUE(r.stability.mass_segments_certified);
    EXPECT_THROW(robust_optimum(Criterion::CE2_OV, box), InvalidParameter);
    UncertainPlant bad = box;
    bad.mass = {0.3, 0.2};
    EXPECT_THROW(robust_optimum(Criterion::CE2, bad), InvalidParameter);
}

TEST(RobustOptimum, MassDampingDelayBoxCI2) {
    UncertainPlant box;
    box.mass = {0.22, 0.30};
    box.damping = {0.0, 2.0};
    box.period = 0.001;
    box.time_delay = {0.0005, 0.0015};
    RobustOptions options;
    options.verify_mass_points = 17;
    const RobustOptimum r = robust_optimum(ImpulseCriterion::CI2, box, options);
    expect_robust(r, box);
    EXPECT_FALSE(r.stability.mass_segments_certified);  // b > 0 somewhere: dense check only
}

}  // namespace
}  // namespace hapticopt
