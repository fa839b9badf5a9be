// SPDX-License-Identifier: Apache-2.0
// The fast energy optima (OptimumMethod::newton: start grid + damped Newton on the analytic gradient) against
// the nested Brent search (OptimumMethod::brent), the independent slower method, on every row of Tables III
// and IV that an energy search decides (CE0..2 and CE0+OV..CE2+OV; amax and OV do not depend on the method)
// and at d = 0, 1, 6 (also through optimal_point with the backward-difference velocity estimator).
//
// Tolerances, from the methods (not from the output):
//  - Brent over alpha stops where C(alpha) is flat to its rounding: |delta alpha| ~ sqrt(2 e C / C'') with
//    e ~ 1e-13 the cost's relative rounding (tests/core/test_energy_costs.cpp) and C'' ~ C / alpha^2, i.e.
//    ~5e-7 alpha; beta_opt moves with alpha by about as much relatively. Newton stops where the analytic
//    gradient vanishes to rounding (~1e-13 relative). Point tolerance: 1e-5 relative (20x the Brent bound).
//  - Cost: at a minimum the cost's error is quadratic in the point's, (1/2) C'' delta^2 ~ 1e-13 C, plus the
//    evaluation's rounding 1e-13: tolerance 1e-11 relative; and the fast cost must not exceed Brent's by more
//    than rounding (1e-12 relative): it is the more accurate of the two.
//  - CEx+OV: the same bisection over alpha (to alpha_tolerance = 1e-10) on beta_opt(alpha) from either
//    method. Its end is where C_OV(alpha, beta_opt(alpha)) crosses the 1e-12 tolerance, and there C_OV
//    varies with beta as steeply as with alpha (a complex pole pair overtaking a slower real pole), so the
//    two curves' difference (delta beta / beta <= 1e-8, OptimalCurveEqualsTheBrentCurve
//    below) moves the crossing by that times (d ln C_OV / d ln beta) / (d ln C_OV / d ln alpha), a ratio of
//    order 1 to 100: alpha and beta within 1e-6 relative, the cost (which changes along the curve by
//    d ln C / d ln alpha ~ 1) likewise 1e-6.
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <map>
#include <memory>
#include <sstream>

#include <hapticopt/estimator_optimum.hpp>
#include <hapticopt/optimum.hpp>
#include <hapticopt/estimator_types.hpp>

#include "common/test_paths.hpp"
#include "paper_table.hpp"

namespace hapticopt {
namespace fast_optimum_test {

OptimumOptions with_method(OptimumMethod m) {
    OptimumOptions o;
    o.method = m;
    return o;
}

void expect_same_optimum(const Optimum& fast, const Optimum& brent, const std::string& where) {
    ASSERT_TRUE(fast.cost.has_value()) << where;
    ASSERT_TRUE(brent.cost.has_value()) << where;
    const bool ov = requires_no_overshoot(fast.criterion);
    const double point_tol = ov ? 1e-6 : 1e-5, cost_tol = ov ? 1e-6 : 1e-11;
    EXPECT_NEAR(fast.alpha / brent.alpha, 1.0, point_tol) << where;
    EXPECT_NEAR(fast.beta / brent.beta, 1.0, point_tol) << where;
    EXPECT_NEAR(*fast.cost / *brent.cost, 1.0, cost_tol) << where;
    if (!ov) {
        EXPECT_LE(*fast.cost, *brent.cost * (1 + 1e-12)) << where;
    }
}

TEST(FastOptimum, EqualsTheBrentSearchOnEveryEnergyRowOfTheTables) {
    std::ifstream in(HAPTICOPT_TEST_DATA_DIR + "/paper_tables.csv");
    std::stringstream text;
    text << in.rdbuf();
    const auto rows = cli::parse_paper_table(text.str());
    ASSERT_EQ(rows.size(), 64u);
    std::map<std::tuple<double, double, double>,
             std::pair<std::unique_ptr<WallOptimizer>, std::unique_ptr<WallOptimizer>>>
        optimizers;
    int compared = 0;
    for (const auto& r : rows) {
        const Criterion c = *parse_criterion(r.criterion);
        if (!energy_index(c)) continue;
        auto& pair = optimizers[{r.gamma, r.delta, r.delay}];
        const NormalizedPlant plant{r.gamma, r.delta, r.delay};
        if (!pair.first) {
            pair.first = std::make_unique<WallOptimizer>(plant, with_method(OptimumMethod::newton));
            pair.second = std::make_unique<WallOptimizer>(plant, with_method(OptimumMethod::brent));
        }
        const std::string where = "Table " + r.table + " " + r.criterion + " gamma=" + std::to_string(r.gamma) +
                                  " delta=" + std::to_string(r.delta);
        expect_same_optimum(pair.first->optimum(c), pair.second->optimum(c), where);
        ++compared;
    }
    EXPECT_EQ(compared, 48);  // 6 energy criteria x 8 plants
}

TEST(FastOptimum, EqualsTheBrentSearchAtDelaysZeroOneSixAndFractional) {
    for (const NormalizedPlant p : {NormalizedPlant{0, 0, 0}, NormalizedPlant{0, 0, 1}, NormalizedPlant{0, 0, 6},
                                    NormalizedPlant{0.001, 0.02, 6}, NormalizedPlant{0.0005, 0.01, 2.5}}) {
        for (const Criterion c : {Criterion::CE0, Criterion::CE1, Criterion::CE2, Criterion::CE2_OV}) {
            const std::string where =
                std::string(to_string(c)) + " d=" + std::to_string(p.delay) + " gamma=" + std::to_string(p.gamma);
            expect_same_optimum(optimal_point(c, p, with_method(OptimumMethod::newton)),
                                optimal_point(c, p, with_method(OptimumMethod::brent)), where);
        }
    }
}

TEST(FastOptimum, TheEstimatorEntryPointUsesTheFastPathForTheBackwardDifference) {
    // optimal_point with VelocityEstimator::backward_difference() is the backward optimiser with its default
    // (newton) method: the same point as the Brent search at d = 0, 1, 6.
    for (double d : {0.0, 1.0, 6.0}) {
        const NormalizedPlant p{0, 0, d};
        const EstimatorOptimum e = optimal_point(Criterion::CE2, p, VelocityEstimator::backward_difference());
        const Optimum brent = optimal_point(Criterion::CE2, p, with_method(OptimumMethod::brent));
        Optimum fast;
        fast.criterion = Criterion::CE2;
        fast.alpha = e.alpha;
        fast.beta = e.beta;
        fast.cost = e.cost;
        expect_same_optimum(fast, brent, "estimator backward d=" + std::to_string(d));
    }
}

TEST(FastOptimum, OptimalCurveEqualsTheBrentCurve) {
    // beta_opt(alpha) of each C_Ex by both methods: Brent's polished curve is good to ~1e-10
    // (tests/core/test_optimum.cpp checks it to 1e-8 against dC/dbeta in long double); tolerance 1e-8 relative.
    for (const NormalizedPlant p : {NormalizedPlant{0, 0, 0}, NormalizedPlant{0.001, 0.02, 1}}) {
        const WallOptimizer fast(p, with_method(OptimumMethod::newton));
        const WallOptimizer brent(p, with_method(OptimumMethod::brent));
        for (int k = 0; k < 3; ++k) {
            for (double frac : {0.1, 0.3, 0.5, 0.7, 0.9, 0.99}) {
                const double a = fast.region().alpha_max() * frac;
                EXPECT_NEAR(fast.optimal_beta(k, a) / brent.optimal_beta(k, a), 1.0, 1e-8)
                    << "k=" << k << " alpha=" << a << " d=" << p.delay;
            }
        }
    }
}

}  // namespace fast_optimum_test
}  // namespace hapticopt
