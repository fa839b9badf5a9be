// SPDX-License-Identifier: Apache-2.0
// The velocity estimators in the exact model (include/hapticopt/estimator_types.hpp), checked against
// the backward-difference code, and against an independent time-stepping of the same difference equations
// written here from their definitions (Eigen's matrix exponential for the plant, not the library's).
#include <gtest/gtest.h>

#include <Eigen/Core>
#include <Eigen/Eigenvalues>
#include <unsupported/Eigen/MatrixFunctions>
#include <algorithm>
#include <cmath>
#include <complex>
#include <functional>
#include <random>
#include <string>
#include <vector>

#include <hapticopt/hapticopt.hpp>

namespace hapticopt {
namespace {

using Kind = VelocityEstimatorKind;

/// The estimator's difference equation v_j = sum b_i y_{j-i} + sum a_k v_{j-k}, from the definitions.
struct EstimatorEquation {
    std::vector<double> b, a;
};

EstimatorEquation estimator_equation(const VelocityEstimator& e) {
    if (e.kind == Kind::lowpass) {
        const double lambda = std::exp(-2 * 3.14159265358979323846 * e.cutoff);
        return {{1 - lambda, lambda - 1}, {lambda}};
    }
    if (e.kind == Kind::window) {
        std::vector<double> b(static_cast<std::size_t>(e.window) + 1, 0.0);
        b.front() = 1.0 / e.window;
        b.back() = -1.0 / e.window;
        return {b, {}};
    }
    return {{1, -1}, {}};
}

struct EstimatorRun {
    std::array<double, 3> costs{};  ///< (1/E(0)) int_0^P E(t) t^p dt by composite Simpson (step input only)
    std::vector<double> x;          ///< x_j
    std::vector<double> f;          ///< f_j
    double max_x = -HUGE_VAL;       ///< max of x over the sub-step grid
    double max_accel = 0;           ///< max of |x''| over the sub-step grid (for the O(h^2) bound of a sampled max)
};

/// Time-steps the loop of Fig. 2 with the estimator: `substeps` (even) sub-steps per period, each the exact
/// zero-order-hold map of (x, x', wall force, external force); d * substeps must be an integer. y_j =
/// measure(j, x_j); external force external(j) on period j. Everything is at rest (x = y = v = 0) before.
EstimatorRun run_loop(double gamma, double delta, double d, double alpha, double beta, const EstimatorEquation& est,
                      int substeps, int periods, const std::function<double(int, double)>& measure,
                      const std::function<double(int)>& external, bool integrate) {
    const double h = 1.0 / substeps;
    Eigen::Matrix4d aug = Eigen::Matrix4d::Zero();
    aug(0, 1) = 1;
    aug(1, 0) = -gamma;
    aug(1, 1) = -delta;
    aug(1, 2) = -1;
    aug(1, 3) = 1;
    const Eigen::Matrix4d step = (aug * h).exp();
    const long long delay_steps = std::llround(d * substeps);
    const double x_inf = 1 / (alpha + gamma);
    std::vector<double> y, v;
    EstimatorRun out;
    Eigen::Vector4d s(0, 0, 0, 0);
    auto energy = [&](const Eigen::Vector4d& z) {
        const double dx = z(0) - x_inf;
        return 0.5 * (alpha + gamma) * dx * dx + 0.5 * z(1) * z(1);
    };
    const double e0 = 0.5 / (alpha + gamma);
    const long long total = static_cast<long long>(periods) * substeps;
    auto accumulate = [&](long long k, const Eigen::Vector4d& z) {  // composite Simpson weights 1 4 2 4 ... 4 1
        if (!integrate) return;
        const double w = (k == 0 || k == total) ? 1.0 : (k % 2 == 1 ? 4.0 : 2.0);
        const double t = static_cast<double>(k) * h;
        const double e = energy(z) / e0;
        for (int p = 0; p < 3; ++p) out.costs[static_cast<std::size_t>(p)] += w * h / 3 * std::pow(t, p) * e;
    };
    for (long long k = 0; k < total; ++k) {
        if (k % substeps == 0) {
            const int j = static_cast<int>(k / substeps);
            y.push_back(measure(j, s(0)));
            double vj = 0;
            for (std::size_t i = 0; i < est.b.size(); ++i) {
                if (static_cast<std::size_t>(j) >= i) vj += est.b[i] * y[static_cast<std::size_t>(j) - i];
            }
            for (std::size_t q = 1; q <= est.a.size(); ++q) {
                if (static_cast<std::size_t>(j) >= q) vj += est.a[q - 1] * v[static_cast<std::size_t>(j) - q];
            }
            v.push_back(vj);
            out.x.push_back(s(0));
            out.f.push_back(alpha * y.back() + beta * vj);
            s(3) = external(j);
        }
        const long long acting = k - delay_steps;  // the force acting on this sub-step is f_{floor(acting / S)}
        s(2) = acting < 0 ? 0.0 : out.f[static_cast<std::size_t>(acting / substeps)];
        accumulate(k, s);
        out.max_x = std::max(out.max_x, s(0));
        out.max_accel = std::max(out.max_accel, std::abs(-gamma * s(0) - delta * s(1) - s(2) + s(3)));
        s = step * s;
    }
    accumulate(total, s);
    return out;
}

double step_input(int) { return 1.0; }
double exact_measurement(int, double x) { return x; }

/// Std of f_j over [burn, burn + count) estimated by `batches` batch means of f^2 (zero-mean signal), and
/// the standard error of that std (delta method: se(s) = se(s^2) / (2 s)).
std::pair<double, double> batch_std(const std::vector<double>& f, int burn, int count, int batches) {
    std::vector<double> means(static_cast<std::size_t>(batches), 0.0);
    const int size = count / batches;
    for (int k = 0; k < size * batches; ++k) {
        const double v = f[static_cast<std::size_t>(burn + k)];
        means[static_cast<std::size_t>(k / size)] += v * v / size;
    }
    double mean = 0, sq = 0;
    for (double m : means) mean += m / batches;
    for (double m : means) sq += (m - mean) * (m - mean) / (batches - 1);
    const double s = std::sqrt(mean);
    return {s, std::sqrt(sq / batches) / (2 * s)};
}

// The generic loop (every estimator, the dense path) reproduces the backward-difference code for the
// estimators that are the backward difference: window 1 exactly, the low-pass with lambda = exp(-2 pi nu)
// below rounding (nu = 1000: lambda = 0 in double; nu = 6: lambda = 4e-17). Both paths are exact, so they
// agree to the rounding of the costs (relative 1e-10 for rho <= 0.999, energy_costs.hpp).
TEST(VelocityEstimator, WindowOneAndFastLowPassEqualBackward) {
    for (double d : {0.0, 1.0, 1.5, 6.0}) {
        const NormalizedPlant plant{0.001, 0.02, d};
        const SampledPlant<double> sampled(plant);
        for (auto [a, b] : {std::pair{0.05, 0.3}, std::pair{0.005, 0.1}}) {
            if (!is_stable(plant, {a, b})) continue;
            const EnergyCosts ref = energy_costs(sampled, a, b);
            const double rho = stability(plant, {a, b}).spectral_radius;
            for (const VelocityEstimator& e : {VelocityEstimator::moving_window(1), VelocityEstimator::low_pass(1000),
                                               VelocityEstimator::low_pass(6)}) {
                for (bool dense : {false, true}) {  // the window's shift-structured path and the complex-Schur path
                    const EnergyCosts c = estimator_energy_costs(sampled, e, a, b, dense);
                    EXPECT_NEAR(c.ce0, ref.ce0, 1e-10 * ref.ce0) << d << " " << a;
                    EXPECT_NEAR(c.ce1, ref.ce1, 1e-10 * ref.ce1);
                    EXPECT_NEAR(c.ce2, ref.ce2, 1e-10 * ref.ce2);
                }
                const StabilityReport r = stability(plant, {a, b}, e);
                EXPECT_TRUE(r.stable);
                EXPECT_NEAR(r.spectral_radius, rho, 1e-12);
                const OvershootResult ov_ref = overshoot(plant, {a, b});
                const OvershootResult ov = estimator_overshoot(sampled, e, a, b);
                EXPECT_NEAR(ov.value, ov_ref.value, 1e-10 * std::max(ov_ref.value, 1e-12));
                EXPECT_EQ(ov.within_tolerance, ov_ref.within_tolerance);
            }
        }
    }
    // The main region of window 1 is the backward region: alpha_max = 12 - 8 sqrt(2) at beta = 2 sqrt(2) - 2
    // (d = 0, gamma = delta = 0). alpha to 1e-11 (bisection to 1e-14, Brent over a flat maximum); beta is
    // ill-conditioned at a flat maximum (|d alpha| ~ |d beta|^2): 1e-5.
    const EstimatorStabilityRegion region({0, 0, 0}, VelocityEstimator::moving_window(1));
    EXPECT_NEAR(region.alpha_max(), 12 - 8 * std::sqrt(2.0), 1e-11);
    EXPECT_NEAR(region.beta_at_alpha_max(), 2 * std::sqrt(2.0) - 2, 1e-5);
    EXPECT_TRUE(region.islands().empty());
    // Every plant of the paper's box, fractional and long delays (the d = 13 region is smaller than one cell of
    // the first scan): against the D-decomposition of the backward loop (stability_region.hpp, ~1e-12). 1e-10
    // relative: both sides are bisection / root-finding results good to ~1e-12.
    for (double d : {0.5, 1.0, 2.5, 6.0, 13.0}) {
        for (double gamma : {0.0, 0.001}) {
            for (double delta : {0.0, 0.02}) {
                const NormalizedPlant plant{gamma, delta, d};
                const double exact = StabilityRegion(plant).alpha_max();
                const EstimatorStabilityRegion r(plant, VelocityEstimator::moving_window(1));
                EXPECT_NEAR(r.alpha_max(), exact, 1e-10 * exact) << d << " " << gamma << " " << delta;
                EXPECT_TRUE(r.islands().empty());
            }
        }
    }
}

// The window's two methods agree (shift-structured LU and complex Schur form, both exact up to rounding:
// 1e-10 relative as for the backward loop at rho <= 0.999), and both are +inf outside the region.
TEST(VelocityEstimator, WindowMethodsAgree) {
    for (double d : {0.0, 1.0, 2.5}) {
        const SampledPlant<double> sampled(NormalizedPlant{0.001, 0.02, d});
        for (int n : {2, 4, 15}) {
            const VelocityEstimator e = VelocityEstimator::moving_window(n);
            const EstimatorStabilityRegion region(sampled.parameters(), e);
            for (double f : {0.2, 0.6, 0.95}) {
                const double a = f * region.alpha_max();
                const auto [lo, hi] = region.beta_interval(a);
                const double b = (lo + hi) / 2;
                const EnergyCosts fast = estimator_energy_costs(sampled, e, a, b);
                const EnergyCosts dense = estimator_energy_costs(sampled, e, a, b, true);
                ASSERT_TRUE(std::isfinite(fast.ce2)) << d << " " << n << " " << f;
                EXPECT_NEAR(fast.ce0, dense.ce0, 1e-10 * dense.ce0);
                EXPECT_NEAR(fast.ce1, dense.ce1, 1e-10 * dense.ce1);
                EXPECT_NEAR(fast.ce2, dense.ce2, 1e-10 * dense.ce2);
            }
            EXPECT_TRUE(std::isinf(
                estimator_energy_costs(sampled, e, 1.05 * region.alpha_max(), region.beta_at_alpha_max()).ce0));
        }
    }
}

// The paper's C_E2 optima (d = 0, d = 1) are unstable with a 20 Hz low-pass at 1 kHz (nu = 0.02) and with a
// 15-sample window. The spectral radius is the largest eigenvalue modulus of the loop matrix (Eigen's
// complex Schur form); the expected figures are given to 3 decimals, so +-5e-4.
TEST(VelocityEstimator, PaperCE2OptimaAreUnstableWithFilters) {
    struct Row {
        double d, alpha, beta, lowpass_radius, window_radius;
    };
    for (const Row& r : {Row{0, 0.2474, 0.7445, 1.065, 1.053}, Row{1, 0.0582, 0.3796, 1.046, 1.071}}) {
        const NormalizedPlant plant{0, 0, r.d};
        EXPECT_TRUE(is_stable(plant, {r.alpha, r.beta}));
        const StabilityReport lp = stability(plant, {r.alpha, r.beta}, VelocityEstimator::low_pass(0.02));
        const StabilityReport w = stability(plant, {r.alpha, r.beta}, VelocityEstimator::moving_window(15));
        EXPECT_FALSE(lp.stable);
        EXPECT_FALSE(w.stable);
        EXPECT_NEAR(lp.spectral_radius, r.lowpass_radius, 5e-4);
        EXPECT_NEAR(w.spectral_radius, r.window_radius, 5e-4);
    }
}

// Closed form against time-stepping with composite Simpson (32 sub-steps per period, 6000 periods).
// Simpson's error is h^4/180 times the fourth derivative of t^p E / E(0) per unit time, h = 1/32: 5e-9 times
// a derivative whose scale is set by the plant (||A|| <= 1) and the slow decay of these loops; the
// truncated tail is below rho^12000 (rho < 0.99 here). Tolerance 1e-7 relative: 20x the Simpson scale, far
// below any modelling error (a wrong delay or estimator state moves the costs by percents).
TEST(VelocityEstimator, CostsMatchTimeStepping) {
    struct Case {
        VelocityEstimator e;
        double d, alpha, beta;
    };
    const std::vector<Case> cases = {
        {VelocityEstimator::low_pass(0.02), 1.0, 0.0046, 0.107},
        {VelocityEstimator::low_pass(0.1), 1.5, 0.02, 0.25},
        {VelocityEstimator::moving_window(15), 0.0, 0.0047, 0.09},
        {VelocityEstimator::moving_window(4), 1.5, 0.01, 0.2},
    };
    for (const Case& c : cases) {
        const NormalizedPlant plant{0.001, 0.02, c.d};
        const StabilityReport r = stability(plant, {c.alpha, c.beta}, c.e);
        ASSERT_TRUE(r.stable) << c.d;
        ASSERT_LT(r.spectral_radius, 0.99);
        const EnergyCosts closed = energy_costs(plant, {c.alpha, c.beta}, c.e);
        const EstimatorRun run = run_loop(plant.gamma, plant.delta, c.d, c.alpha, c.beta, estimator_equation(c.e), 32,
                                          6000, exact_measurement, step_input, true);
        EXPECT_NEAR(run.costs[0], closed.ce0, 1e-7 * closed.ce0) << c.d;
        EXPECT_NEAR(run.costs[1], closed.ce1, 1e-7 * closed.ce1) << c.d;
        EXPECT_NEAR(run.costs[2], closed.ce2, 1e-7 * closed.ce2) << c.d;
    }
}

// C_OV with the estimator against the maximum of the time-stepped x over its sub-step grid (64 per period):
// the sampled maximum approaches the continuous one from below, within max|x''| h^2 / 8 (the true maximum is
// within h/2 of a grid point, where x' = 0), plus 1e-12 x_inf for rounding.
TEST(VelocityEstimator, OvershootMatchesTimeStepping) {
    struct Case {
        VelocityEstimator e;
        double d, alpha, beta;
    };
    for (const Case& c :
         {Case{VelocityEstimator::low_pass(0.1), 1.0, 0.05, 0.3}, Case{VelocityEstimator::low_pass(0.1), 0.0, 0.2, 0.5},
          Case{VelocityEstimator::moving_window(4), 1.5, 0.01, 0.2},
          Case{VelocityEstimator::low_pass(0.02), 1.0, 0.0046, 0.107}}) {
        const NormalizedPlant plant{0.001, 0.02, c.d};
        const OvershootResult ov = overshoot(plant, {c.alpha, c.beta}, c.e);
        ASSERT_TRUE(ov.converged);
        const EstimatorRun run = run_loop(plant.gamma, plant.delta, c.d, c.alpha, c.beta, estimator_equation(c.e), 64,
                                          3000, exact_measurement, step_input, false);
        const double x_inf = 1 / (c.alpha + plant.gamma);
        const double closed = x_inf * (1 + ov.value);
        const double h = 1.0 / 64;
        EXPECT_LE(run.max_x, closed + 1e-12 * x_inf) << c.d;
        EXPECT_GE(run.max_x, closed - run.max_accel * h * h / 8 - 1e-12 * x_inf) << c.d;
    }
}

// The main region's tip against long simulation: 1 % inside alpha_max the step response decays, 1 % outside
// it grows (the envelope of |x_j - x_inf| over the last 2000 of 60000 periods against periods 2000..4000).
// Includes regions smaller than one cell of the first scan (low-pass nu = 0.002, window 60 at d = 3).
TEST(VelocityEstimator, MainRegionTipAgainstSimulation) {
    struct Case {
        VelocityEstimator e;
        double d;
    };
    for (const Case& c : {Case{VelocityEstimator::low_pass(0.02), 1.0}, Case{VelocityEstimator::moving_window(15), 0.0},
                          Case{VelocityEstimator::moving_window(3), 2.0}, Case{VelocityEstimator::low_pass(0.002), 1.0},
                          Case{VelocityEstimator::moving_window(60), 3.0}}) {
        const NormalizedPlant plant{0, 0, c.d};
        const EstimatorStabilityRegion region(plant, c.e);
        ASSERT_GT(region.alpha_max(), 0);
        for (double factor : {0.99, 1.01}) {
            const double a = region.alpha_max() * factor, b = region.beta_at_alpha_max();
            const EstimatorRun run =
                run_loop(0, 0, c.d, a, b, estimator_equation(c.e), 2, 60000, exact_measurement, step_input, false);
            auto envelope = [&](std::size_t from, std::size_t to) {
                double m = 0;
                for (std::size_t j = from; j < to; ++j) m = std::max(m, std::abs(run.x[j] - 1 / a));
                return m;
            };
            const double early = envelope(2000, 4000), late = envelope(58000, 60000);
            if (factor < 1) {
                EXPECT_LT(late, early) << c.d;
                EXPECT_TRUE(region.stable(a, b));
            } else {
                EXPECT_GT(late, early) << c.d;
                EXPECT_FALSE(region.stable(a, b));
            }
        }
    }
}

// The tip (the D-decomposition curve's maximum, confirmed by the edge) against the loop matrix's spectral radius
// (complex Schur form: independent of the Schur-Cohn verdict and of the curve): at beta_at_alpha_max the radius is
// below 1 at alpha_max (1 - 1e-7) and above 1 at alpha_max (1 + 1e-7), and at 21 betas across a band of +-10 % of
// the main region's beta interval at alpha_max / 2 around it, alpha_max (1 + 1e-7) is unstable (no point above the
// tip nearby). 1e-7 is far above the ~1e-12 accuracy claimed for alpha_max and below any cell of the scan.
TEST(VelocityEstimator, MainRegionTipAgainstTheLoopsSpectralRadius) {
    struct Case {
        VelocityEstimator e;
        double d;
    };
    for (const Case& c :
         {Case{VelocityEstimator::low_pass(0.02), 1.0}, Case{VelocityEstimator::moving_window(15), 0.0},
          Case{VelocityEstimator::moving_window(15), 1.0}, Case{VelocityEstimator::moving_window(3), 2.0},
          Case{VelocityEstimator::low_pass(0.002), 1.0}, Case{VelocityEstimator::low_pass(0.02), 6.0},
          Case{VelocityEstimator::moving_window(15), 6.0}}) {
        const NormalizedPlant plant{0, 0, c.d};
        for (const EstimatorRegionOptions& grid : {EstimatorRegionOptions{}, kFastOptimumRegionGrid}) {
            const EstimatorStabilityRegion region(plant, c.e, grid);
            const double a = region.alpha_max(), b = region.beta_at_alpha_max();
            ASSERT_GT(a, 0);
            auto radius = [&](double alpha, double beta) {
                return stability(plant, NormalizedGains{alpha, beta}, c.e).spectral_radius;
            };
            EXPECT_LT(radius(a * (1 - 1e-7), b), 1) << c.d;
            EXPECT_GT(radius(a * (1 + 1e-7), b), 1) << c.d;
            const auto [lo, hi] = region.beta_interval(a / 2);
            const double band = 0.1 * (hi - lo);
            for (int k = -10; k <= 10; ++k) {
                const double beta = b + band * k / 10;
                EXPECT_GE(radius(a * (1 + 1e-7), beta), 1) << c.d << " beta " << beta;
            }
        }
    }
}

// Window 30, d = 0, delta = 0.05: the main region narrows to a waist (beta interval 0.06 wide at alpha 0.105, its
// centre moving down as alpha grows) and widens again up to its tip at 0.16907. A 16 x 16 or 40 x 40 scan's flood
// fill stopped at the waist and reported a point on its upper edge (0.11398, 0.11486) as the tip;
// continues_beyond_tip sends the region to a finer grid. Every grid gives the default grid's tip, and it is the
// region's: a path of points marched up in alpha through the waist (200 steps of the beta interval's midpoint, each
// interval overlapping the next) is stable by the loop's spectral radius (an eigenvalue solve, independent of the
// Schur-Cohn verdicts the region uses), stable points lie within 1e-8 alpha_max of the tip on the segment towards
// the midpoint of the interval at 0.99 alpha_max (the tip is a corner, the crossing of the two edges: the point
// straight below it is outside),
// and above the tip the radius is >= 1 over a band of betas.
TEST(VelocityEstimator, AWaistNarrowerThanTheScanCellsDoesNotEndTheRegion) {
    const NormalizedPlant plant{0, 0.05, 0};
    const VelocityEstimator e = VelocityEstimator::moving_window(30);
    const EstimatorStabilityRegion reference(plant, e);
    const double a = reference.alpha_max(), b = reference.beta_at_alpha_max();
    EXPECT_GT(a, 0.16);
    auto radius = [&](double alpha, double beta) {
        return stability(plant, NormalizedGains{alpha, beta}, e).spectral_radius;
    };
    for (const EstimatorRegionOptions& grid : {kFastOptimumRegionGrid, EstimatorRegionOptions{40, 40, false}}) {
        const EstimatorStabilityRegion region(plant, e, grid);
        EXPECT_NEAR(region.alpha_max() / a, 1.0, 1e-10) << grid.alpha_grid;
    }
    double previous_lo = -HUGE_VAL, previous_hi = HUGE_VAL;
    for (int k = 1; k < 200; ++k) {
        const double alpha = a * k / 200;
        const auto [lo, hi] = reference.beta_interval(alpha, 1e-10);
        ASSERT_GT(hi, lo) << alpha;
        EXPECT_TRUE(lo < previous_hi && hi > previous_lo) << "the interval at " << alpha << " joins the one below";
        EXPECT_LT(radius(alpha, (lo + hi) / 2), 1) << alpha;
        previous_lo = lo;
        previous_hi = hi;
    }
    const auto [below_lo, below_hi] = reference.beta_interval(0.99 * a, 1e-12);
    ASSERT_GT(below_hi, below_lo);
    const double inner_beta = (below_lo + below_hi) / 2;
    for (const double s : {1e-4, 1e-6}) {
        EXPECT_LT(radius(a + s * (0.99 * a - a), b + s * (inner_beta - b)), 1) << s;
    }
    const auto [lo, hi] = reference.beta_interval(a / 2);
    for (int k = -10; k <= 10; ++k) EXPECT_GE(radius(a * (1 + 1e-7), b + 0.1 * (hi - lo) * k / 10), 1) << k;
}

// The 15-sample window at d = 0 has a stable island above the main region (negative beta): reported as an
// island, with alpha_max the main region's, far below it.
TEST(VelocityEstimator, LongWindowIslandIsSeparate) {
    const EstimatorStabilityRegion region({0, 0, 0}, VelocityEstimator::moving_window(15));
    ASSERT_FALSE(region.islands().empty());
    const StableIsland& island = region.islands().front();
    EXPECT_GT(island.alpha_min, 2 * region.alpha_max());
    const double a = (island.alpha_min + island.alpha_max) / 2;
    bool found = false;
    for (int k = 0; k < 400 && !found; ++k) {
        found = region.stable(a, island.beta_min + (k + 0.5) / 400 * (island.beta_max - island.beta_min));
    }
    EXPECT_TRUE(found);
    EXPECT_FALSE(region.stable(region.alpha_max() * 1.01, region.beta_at_alpha_max()));
}

// The C_E2 optimum with a filter: no point of a 60 x 40 grid over the main region has a lower cost.
TEST(VelocityEstimator, OptimumBeatsGrid) {
    const NormalizedPlant plant{0, 0, 1};
    const VelocityEstimator e = VelocityEstimator::low_pass(0.02);
    const EstimatorOptimum o = optimal_point(Criterion::CE2, plant, e);
    ASSERT_TRUE(o.cost.has_value());
    EXPECT_LT(o.alpha, o.alpha_max);
    const EstimatorStabilityRegion region(plant, e);
    const SampledPlant<double> sampled(plant);
    for (int i = 0; i < 60; ++i) {
        const double a = (i + 0.5) / 60 * region.alpha_max();
        const auto [lo, hi] = region.beta_interval(a);
        for (int k = 0; k < 40; ++k) {
            const double b = lo + (k + 0.5) / 40 * (hi - lo);
            EXPECT_GE(estimator_energy_costs(sampled, e, a, b).ce2, *o.cost * (1 - 1e-12)) << a << " " << b;
        }
    }
}

// The no-overshoot limit at fixed beta: the largest alpha in (lo, hi) with C_OV <= 1e-12 (overshoot.hpp, the
// backward loop), bisected to 1e-13 relative; lo must be without overshoot and hi with.
double no_overshoot_limit(const NormalizedPlant& plant, double beta, double lo, double hi) {
    for (int k = 0; k < 200 && hi - lo > 1e-13 * hi; ++k) {
        const double mid = (lo + hi) / 2;
        (overshoot(plant, NormalizedGains{mid, beta}).within_tolerance ? lo : hi) = mid;
    }
    return lo;
}

// CEx+OV with the estimator. Window 1 against the paper's optimiser (optimum.hpp): beta to 1e-6 relative (this
// search's beta_opt is Brent's on a flat minimum, where the cost's rounding leaves its location uncertain to about
// sqrt(eps) relative and more; the backward optimiser polishes by Newton). Alpha is the no-overshoot limit on the
// curve beta_opt(alpha), so a beta error moves it along the boundary C_OV = 1e-12: alpha to |d alpha* / d beta|
// times that 1e-6 beta, plus both bisections' 1e-10 alpha_max; the slope by bisecting the boundary at beta +- 1e-4
// beta (no_overshoot_limit). The low-pass point against the definition: no overshoot (C_OV <= 1e-12) on the optimal
// curve at alpha, overshoot just beyond.
TEST(VelocityEstimator, NoOvershootPoints) {
    for (double d : {0.0, 1.0}) {
        const NormalizedPlant plant{0, 0, d};
        for (Criterion c : {Criterion::CE0_OV, Criterion::CE2_OV}) {
            const Optimum ref = optimal_point(c, plant);
            const EstimatorOptimum w = optimal_point(c, plant, VelocityEstimator::moving_window(1));
            const double h = 1e-4 * ref.beta;
            const double slope = (no_overshoot_limit(plant, ref.beta + h, ref.alpha / 2, ref.alpha_max) -
                                  no_overshoot_limit(plant, ref.beta - h, ref.alpha / 2, ref.alpha_max)) /
                                 (2 * h);
            EXPECT_NEAR(w.alpha, ref.alpha, std::abs(slope) * 1e-6 * ref.beta + 2e-10 * ref.alpha_max)
                << d << " slope " << slope;
            EXPECT_NEAR(w.beta, ref.beta, 1e-6 * ref.beta) << d;
            EXPECT_NEAR(*w.cost, *ref.cost, 1e-5 * *ref.cost) << d;
        }
    }
    const NormalizedPlant plant{0, 0, 1};
    const VelocityEstimator e = VelocityEstimator::low_pass(0.1);
    const SampledPlant<double> sampled(plant);
    const EstimatorOptimum o = optimal_point(Criterion::CE2_OV, plant, e);
    EXPECT_TRUE(estimator_overshoot(sampled, e, o.alpha, o.beta).within_tolerance);
    const EstimatorStabilityRegion region(plant, e);
    auto curve_beta = [&](double a) {  // beta_opt(a) by a fine scan of the main region's interval
        const auto [lo, hi] = region.beta_interval(a);
        double best = lo, value = HUGE_VAL;
        for (int k = 0; k < 2000; ++k) {
            const double b = lo + (k + 0.5) / 2000 * (hi - lo);
            const double v = estimator_energy_costs(sampled, e, a, b).ce2;
            if (v < value) {
                value = v;
                best = b;
            }
        }
        return best;
    };
    const double beyond = o.alpha + 1e-3 * o.alpha_max;
    EXPECT_FALSE(estimator_overshoot(sampled, e, beyond, curve_beta(beyond)).within_tolerance);
    EXPECT_LT(o.alpha, o.alpha_max);
}

// g_F against Monte-Carlo: y = x + e with e uniform on (-1/2, 1/2) (variance 1/12, q = 1), 400000 periods
// after 4000 of burn-in; the std of f_j by 40 batch means. Tolerance 4 standard errors of that estimate.
TEST(VelocityEstimator, NoiseMatchesMonteCarlo) {
    struct Case {
        VelocityEstimator e;
        double d, alpha, beta;
    };
    for (const Case& c : {Case{VelocityEstimator::backward_difference(), 1.0, 0.0582, 0.3796},
                          Case{VelocityEstimator::low_pass(0.02), 1.0, 0.0046, 0.107},
                          Case{VelocityEstimator::moving_window(15), 0.0, 0.0047, 0.09}}) {
        const NormalizedPlant plant{0, 0, c.d};
        const double g = force_noise_gain(plant, {c.alpha, c.beta}, c.e);
        ASSERT_TRUE(std::isfinite(g));
        std::mt19937_64 rng(12345);
        std::uniform_real_distribution<double> u(-0.5, 0.5);
        const int burn = 4000, count = 400000;
        const EstimatorRun run = run_loop(
            0, 0, c.d, c.alpha, c.beta, estimator_equation(c.e), 2, burn + count,
            [&](int, double x) { return x + u(rng); }, [](int) { return 0.0; }, false);
        const auto [s, se] = batch_std(run.f, burn, count, 40);
        EXPECT_NEAR(s, g, 4 * se) << c.d;
    }
}

// Real rounding: y = round(x) (q = 1) while a slow sinusoidal force moves x over ~10^4 counts, hundreds of
// counts per period, where the rounding error is close to white and uniform. The force error is the
// difference to the same run without rounding (the loop is linear); its std against g_F with the same
// batch-means tolerance (4 standard errors). At rest (motion within a count) the rounding error is not
// white and the model does not apply (docs/velocity-estimation.md).
TEST(VelocityEstimator, NoiseMatchesRoundingWhenMotionSpansManyCounts) {
    struct Case {
        VelocityEstimator e;
        double d, alpha, beta;
    };
    for (const Case& c : {Case{VelocityEstimator::backward_difference(), 1.0, 0.0582, 0.3796},
                          Case{VelocityEstimator::low_pass(0.02), 1.0, 0.0046, 0.107}}) {
        const NormalizedPlant plant{0, 0, c.d};
        const double g = force_noise_gain(plant, {c.alpha, c.beta}, c.e);
        const double omega = 2 * 3.14159265358979323846 * 0.01234567;
        const double amplitude = 1e4 * std::abs(c.alpha - omega * omega);
        auto force = [&](int j) { return amplitude * std::sin(omega * j); };
        const int burn = 4000, count = 400000;
        const EstimatorEquation eq = estimator_equation(c.e);
        const EstimatorRun rounded = run_loop(
            0, 0, c.d, c.alpha, c.beta, eq, 2, burn + count, [](int, double x) { return std::round(x); }, force, false);
        const EstimatorRun exact =
            run_loop(0, 0, c.d, c.alpha, c.beta, eq, 2, burn + count, exact_measurement, force, false);
        std::vector<double> diff(rounded.f.size());
        double span = 0;
        for (std::size_t j = 0; j < diff.size(); ++j) {
            diff[j] = rounded.f[j] - exact.f[j];
            span = std::max(span, std::abs(exact.x[j]));
        }
        EXPECT_GT(span, 1000);
        const auto [s, se] = batch_std(diff, burn, count, 40);
        EXPECT_NEAR(s, g, 4 * se) << c.d;
    }
}

TEST(VelocityEstimator, InvalidParametersNameTheFunctionAndRange) {
    auto message = [](auto&& f) {
        try {
            f();
        } catch (const InvalidParameter& e) {
            return std::string(e.what());
        }
        return std::string();
    };
    for (double nu : {0.0, -1.0, std::nan(""), HUGE_VAL}) {
        const std::string m = message([&] { VelocityEstimator::low_pass(nu); });
        EXPECT_EQ(m.rfind("hapticopt::VelocityEstimator::low_pass: cutoff", 0), 0u) << m;
        EXPECT_NE(m.find("finite and > 0"), std::string::npos);
    }
    for (int n : {0, -3, 1001}) {
        const std::string m = message([&] { VelocityEstimator::moving_window(n); });
        EXPECT_EQ(m.rfind("hapticopt::VelocityEstimator::moving_window: window", 0), 0u) << m;
        EXPECT_NE(m.find("1 <= N <= 1000"), std::string::npos);
    }
    VelocityEstimator bad;
    bad.kind = Kind::window;
    bad.window = 0;
    const std::string m = message([&] { force_noise_gain({0, 0, 0}, {0.1, 0.5}, bad); });
    EXPECT_EQ(m.rfind("hapticopt::force_noise_gain: window", 0), 0u) << m;
    EXPECT_EQ(message([&] {
                  force_noise_std({0.3, 0, 0, 1e-3, 0}, {1000, 10}, 0);
              }).rfind("hapticopt::force_noise_std: position_resolution", 0),
              0u);
    // sigma_F = (m q / T^2) g_F with alpha = K T^2 / m, beta = B T / m.
    EXPECT_NEAR(force_noise_std({0.3, 0, 0, 1e-3, 0}, {1000, 10}, 2e-5),
                0.3 * 2e-5 / 1e-6 * force_noise_gain({0, 0, 0}, {1000 * 1e-6 / 0.3, 10 * 1e-3 / 0.3}), 1e-12);
}

// A cusp-shaped (corner) tip: window 20 at d = 0, gamma = 0.001, delta = 0.02, where two branches of the
// D-decomposition curve cross (region_tip.hpp). Checked by an independent method: the crossing solved as
// C(theta_1) = C(theta_2) by Newton in long double (the curve by complex Horner and Cramer's rule, the Jacobian by
// central differences), started from the angles of the loop matrix's eigenvalues nearest the unit circle at the
// region's tip (complex Eigen solver: independent of Schur-Cohn, of the deflation and of the arc bisection). The
// vertex agrees to 1e-10 relative whatever the scan's grid (the grid's edge maximum was 0.0917216, 7.9e-4 below), and
// the tip is confirmed by the loop matrix's spectral radius: below 1 at alpha_max (1 - 1e-9) just inside the wedge,
// four eigenvalues within 1e-6 of the unit circle at the tip (two crossing pairs), and above 1 at alpha_max (1 + 1e-9)
// at 201 betas across +-1e-3 around it.
TEST(VelocityEstimator, CornerTipIsTheBranchCrossing) {
    const NormalizedPlant plant{0.001, 0.02, 0};
    const VelocityEstimator e = VelocityEstimator::moving_window(20);
    using LD = long double;
    const SampledPlant<double> sampled(plant);
    auto loop_eigenvalues = [&](double alpha, double beta) {
        const Eigen::MatrixXd m = make_estimator_loop(sampled, e, alpha, beta, false).loop.transition;
        return Eigen::ComplexEigenSolver<Eigen::MatrixXd>(m).eigenvalues();
    };
    auto radius = [&](double alpha, double beta) { return loop_eigenvalues(alpha, beta).cwiseAbs().maxCoeff(); };
    const AffineCharacteristicPolynomial<LD> p =
        estimator_characteristic_polynomial(characteristic_polynomial(plant_transitions<LD>(plant)), e);
    auto curve = [&](LD t) {
        const std::complex<LD> z = std::polar(LD(1), t);
        std::complex<LD> c0 = 0, ca = 0, cb = 0;
        for (int k = p.degree(); k >= 0; --k) {
            c0 = c0 * z + p.base(k);
            ca = ca * z + p.alpha(k);
            cb = cb * z + p.beta(k);
        }
        const LD det = ca.real() * cb.imag() - ca.imag() * cb.real();
        return Eigen::Matrix<LD, 2, 1>((c0.imag() * cb.real() - c0.real() * cb.imag()) / det,
                                       (c0.real() * ca.imag() - c0.imag() * ca.real()) / det);
    };
    for (const EstimatorRegionOptions& grid :
         {EstimatorRegionOptions{}, kFastOptimumRegionGrid, EstimatorRegionOptions{40, 40, false}}) {
        const EstimatorStabilityRegion region(plant, e, grid);
        const double a = region.alpha_max(), b = region.beta_at_alpha_max();
        EXPECT_GT(a, 0.0917216);  // above the grid edge's maximum
        // The start: the two distinct angles in (0, pi) of the eigenvalues nearest the unit circle.
        const Eigen::VectorXcd ev = loop_eigenvalues(a, b);
        std::vector<std::pair<double, double>> near;  // (| |lambda| - 1 |, angle)
        for (Eigen::Index k = 0; k < ev.size(); ++k) {
            if (ev(k).imag() > 0) near.emplace_back(std::abs(std::abs(ev(k)) - 1), std::arg(ev(k)));
        }
        std::sort(near.begin(), near.end());
        ASSERT_GE(near.size(), 2u);
        EXPECT_LT(near[1].first, 1e-6);  // two pairs on the circle: a crossing of two branches
        Eigen::Matrix<LD, 2, 1> t(near[0].second, near[1].second);
        for (int it = 0; it < 40; ++it) {
            const Eigen::Matrix<LD, 2, 1> f = curve(t(0)) - curve(t(1));
            const LD h = 1e-9L;
            Eigen::Matrix<LD, 2, 2> jac;
            jac.col(0) = (curve(t(0) + h) - curve(t(0) - h)) / (2 * h);
            jac.col(1) = -(curve(t(1) + h) - curve(t(1) - h)) / (2 * h);
            t -= jac.inverse() * f;
        }
        const Eigen::Matrix<LD, 2, 1> vertex = curve(t(0));
        EXPECT_LT((curve(t(0)) - curve(t(1))).norm(), 1e-14L);
        EXPECT_NEAR(a, static_cast<double>(vertex(0)), 1e-10 * a) << grid.alpha_grid;
        EXPECT_NEAR(b, static_cast<double>(vertex(1)), 1e-8) << grid.alpha_grid;
        // Just inside: from the tip along the sum of the two branches' unit tangents that point to smaller alpha.
        Eigen::Matrix<LD, 2, 1> inward = Eigen::Matrix<LD, 2, 1>::Zero();
        for (int k = 0; k < 2; ++k) {
            Eigen::Matrix<LD, 2, 1> tangent = curve(t(k) + 1e-7L) - curve(t(k) - 1e-7L);
            tangent /= tangent.norm();
            inward += tangent(0) < 0 ? tangent : Eigen::Matrix<LD, 2, 1>(-tangent);
        }
        inward *= static_cast<LD>(1e-9 * a) / inward.norm();
        EXPECT_LT(radius(static_cast<double>(vertex(0) + inward(0)), static_cast<double>(vertex(1) + inward(1))), 1);
        EXPECT_GT(radius(static_cast<double>(vertex(0) - inward(0)), static_cast<double>(vertex(1) - inward(1))), 1);
        for (int k = -100; k <= 100; ++k) EXPECT_GT(radius(a * (1 + 1e-9), b + 1e-5 * k), 1) << k;
    }
}

}  // namespace
}  // namespace hapticopt
