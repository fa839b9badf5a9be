// SPDX-License-Identifier: Apache-2.0
// The Sect. V experiments on the exact ZOH simulated device against the analysis (hapticopt), for the
// default profile (0.3 kg, no delay) and a plant with physical damping, stiffness and delay (device 1
// period + buffer 1).
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "experiment/experiment_output.hpp"
#include "experiment_fixture.hpp"

namespace hapticd::experiment::test {
namespace {

const Plant kDelayed{0.3, 3.0, 200.0, 1.0, 1, 1e-3};  // delta = 0.01, gamma = 6.7e-4, d = 2

// K where the spectral radius reaches rho (> 1) at damping B, above the exact boundary (bisection).
double stiffness_at_radius(const Theory& theory, double B, double rho) {
    double lo = theory.boundary_stiffness(B), hi = 2.0 * theory.max_stiffness();
    for (int i = 0; i < 200 && hi - lo > 1e-9 * hi; ++i) {
        const double mid = (lo + hi) / 2.0;
        (theory.spectral_radius(mid, B) < rho ? lo : hi) = mid;
    }
    return hi;
}

class BoundaryOnSim : public ::testing::TestWithParam<Plant> {};

TEST_P(BoundaryOnSim, MeasuredBoundaryMatchesAnalysisWithinResolutionAndDetectionWindow) {
    SimBench b(GetParam(), 2000);
    const Theory& theory = b.theory;
    const auto [b_lo, b_hi] = theory.damping_extent();
    std::vector<double> b_values;
    for (int i = 0; i < 5; ++i) b_values.push_back(b_lo + (b_hi - b_lo) * (0.1 + 0.2 * i));
    const BoundarySettings s = k_sweep(theory, b_values, 20.0, 64.0);
    const BoundaryResult r = run_boundary_quietly(b.runner, b.setup, s, theory);
    ASSERT_EQ(r.abort.outcome, TrialOutcome::Stable) << r.abort.detail;
    ASSERT_EQ(r.points.size(), s.b_values.size());
    // Window energy ratio of the dominant mode: rho^(2W); detected when > g: rho_detect = g^(1/(2W)).
    const DetectionSettings& det = b.setup.trial.detection;
    const double rho_detect = std::pow(det.growth, 1.0 / (2.0 * static_cast<double>(det.window)));
    for (const auto& p : r.points) {
        ASSERT_TRUE(std::isfinite(p.K_boundary)) << "B = " << p.B;
        const double k_detect = stiffness_at_radius(theory, p.B, rho_detect);
        std::printf(
            "B = %.6g: K measured %.8g, analysis %.8g, detection bound %.8g, resolution %.6g; (measured - analysis) / "
            "analysis = %.3e\n",
            p.B, p.K_boundary, p.K_theory, k_detect, s.k_resolution, (p.K_boundary - p.K_theory) / p.K_theory);
        EXPECT_GE(p.K_boundary, p.K_theory - s.k_resolution) << "B = " << p.B;
        EXPECT_LE(p.K_boundary, k_detect + s.k_resolution) << "B = " << p.B;
    }
}

INSTANTIATE_TEST_SUITE_P(Plants, BoundaryOnSim, ::testing::Values(kDefault, kDelayed));

class OptimalOnSim : public ::testing::TestWithParam<Plant> {};

TEST_P(OptimalOnSim, MeasuredOptimalDampingMatchesTheOptimalCurveWithinTheGridStep) {
    SimBench b(GetParam(), 3000);
    const Theory& theory = b.theory;
    OptimalSettings s;
    for (double f : {0.2, 0.4, 0.6}) s.k_values.push_back(f * theory.max_stiffness());
    s.b_points = 11;
    std::ostringstream sink;
    Progress progress(sink, false, true);
    const OptimalResult r = run_optimal(b.runner, b.setup, s, theory, progress);
    ASSERT_EQ(r.abort.outcome, TrialOutcome::Stable) << r.abort.detail;
    ASSERT_EQ(r.points.size(), 9U);
    for (const auto& p : r.points) {
        std::printf(
            "K = %.6g CE%d: B grid %.6g, refined %.6g, analysis %.6g, step %.4g, |refined - analysis| / step = %.3f\n",
            p.K, p.criterion, p.B_grid, p.B_refined, p.B_theory, p.b_step,
            std::abs(p.B_refined - p.B_theory) / p.b_step);
        EXPECT_FALSE(p.on_edge);
        EXPECT_LE(std::abs(p.B_grid - p.B_theory), p.b_step);
        EXPECT_LE(std::abs(p.B_refined - p.B_theory), p.b_step);
    }
}

INSTANTIATE_TEST_SUITE_P(Plants, OptimalOnSim, ::testing::Values(kDefault, kDelayed));

class CostsOnSim : public ::testing::TestWithParam<Plant> {};

TEST_P(CostsOnSim, MeasuredCostsMatchTheClosedForms) {
    const Plant plant = GetParam();
    const Theory theory(plant.theory());
    constexpr std::size_t kTicks = 4000;
    const auto [K_opt, B_opt] = theory.ce2_optimum();
    const std::pair<double, double> points[] = {{K_opt, B_opt}, {0.5 * K_opt, 0.6 * B_opt}, {1.3 * K_opt, 1.2 * B_opt}};
    for (const auto& [K, B] : points) {
        // Truncation: E(t) decays like rho^(2t); the tail beyond L periods of \int t^p E is below
        // rho^(2L) L^3 of E(0) (for 1 / (2 ln(1/rho)) < L), required < 1e-6 relative.
        const double rho = theory.spectral_radius(K, B);
        ASSERT_LT(std::pow(rho, 2.0 * kTicks) * std::pow(static_cast<double>(kTicks), 3), 1e-6) << "rho = " << rho;
        auto sim = make_sim(plant);
        TrialRunner runner(*sim, 1'000'000, true);
        ExperimentSetup setup = make_setup(plant, theory, kTicks);
        TrialSettings t = setup.trial;
        t.K = K;
        t.B = B;
        TrialRecord rec;
        runner.run(t, rec);
        ASSERT_EQ(rec.outcome, TrialOutcome::Stable);
        const MeasuredCosts m = measure_costs(rec, t, setup.model);
        const TheoryCosts c = theory.costs(K, B);
        std::printf("K = %.6g, B = %.6g: CE0 %.12g / %.12g, CE1 %.12g / %.12g, CE2 %.12g / %.12g, COV %.6e / %.6e\n", K,
                    B, m.ce0, c.ce0, m.ce1, c.ce1, m.ce2, c.ce2, m.overshoot, c.overshoot);
        EXPECT_NEAR(m.ce0, c.ce0, 1e-9 * c.ce0);
        EXPECT_NEAR(m.ce1, c.ce1, 1e-9 * c.ce1);
        EXPECT_NEAR(m.ce2, c.ce2, 1e-9 * c.ce2);
        EXPECT_NEAR(m.overshoot, c.overshoot, 1e-9);
        EXPECT_LT(m.tail_estimate, 1e-6);
    }
}

INSTANTIATE_TEST_SUITE_P(Plants, CostsOnSim, ::testing::Values(kDefault, kDelayed));

TEST(ParabolaVertex, RecoversTheMinimumOfAQuadratic) {
    auto f = [](double x) { return 3.0 * (x - 1.7) * (x - 1.7) + 2.0; };
    EXPECT_NEAR(parabola_vertex(1.0, f(1.0), 1.5, f(1.5), 2.5, f(2.5)), 1.7, 1e-12);
    EXPECT_EQ(parabola_vertex(0.0, 1.0, 1.0, 1.0, 2.0, 1.0), 1.0);  // flat: the middle point
}

}  // namespace
}  // namespace hapticd::experiment::test
