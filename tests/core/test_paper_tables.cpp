// SPDX-License-Identifier: Apache-2.0
// Every row of Tables III and IV (tests/data/paper_tables.csv, transcribed as printed).
//
// Tolerances (the facts checked against the tables: docs/methods.md):
//  - alpha, beta, cost: one unit in the last printed digit. The paper's own optimiser is good to
//    about one unit (an exact computation lands within one unit, sometimes across a rounding
//    boundary), so half a unit would test the paper's optimiser, not ours.
//  - amax betas: two units (the maximum is flat in beta; printed betas are ~1e-4 low in every row).
//  - OV betas: 0.01 absolute (blunt tip of the no-overshoot region; ill-conditioned to ~0.01).
//  - Errata (below): two Table IV costs that no stable point attains; checked two ways.
#include <gtest/gtest.h>

#include <cmath>
#include <map>
#include <fstream>
#include <memory>
#include <sstream>

#include <hapticopt/optimum.hpp>

#include "common/test_paths.hpp"
#include "paper_table.hpp"
#include "reference_simulation.hpp"

namespace hapticopt {
namespace {

struct Erratum {
    std::string criterion;
    double gamma, delta, delay;
    double exact_beta;  ///< our values, also in the README's errata list
    double exact_cost;
};
// Table IV, gamma = 0, delta = 0.02: the printed cost 79.40 (CE2) is below the exact minimum
// 79.469 (our beta 0.37841 vs printed 0.3786, alpha agrees), and the printed 102.5 (CE2+OV) is
// below the exact C_E2 at that point, 103.347 (alpha and beta agree). No stable point attains
// either printed cost (global search + dense grid, and the independent method below).
const Erratum kErrata[] = {{"CE2", 0.0, 0.02, 1, 0.37841, 79.4690}, {"CE2+OV", 0.0, 0.02, 1, 0.31497, 103.347}};

const Erratum* erratum_for(const cli::PaperRow& r) {
    for (const Erratum& e : kErrata) {
        if (e.criterion == r.criterion && e.gamma == r.gamma && e.delta == r.delta && e.delay == r.delay) return &e;
    }
    return nullptr;
}

std::vector<cli::PaperRow> load_rows() {
    std::ifstream in(HAPTICOPT_TEST_DATA_DIR + "/paper_tables.csv");
    std::stringstream text;
    text << in.rdbuf();
    return cli::parse_paper_table(text.str());
}

TEST(PaperTables, AllSixtyFourRowsWithinThePrintedPrecision) {
    const auto rows = load_rows();
    ASSERT_EQ(rows.size(), 64u);
    std::map<std::tuple<double, double, double>, std::unique_ptr<WallOptimizer>> optimizers;
    for (const auto& r : rows) {
        auto& opt = optimizers[{r.gamma, r.delta, r.delay}];
        if (!opt) opt = std::make_unique<WallOptimizer>(NormalizedPlant{r.gamma, r.delta, r.delay});
        const Optimum o = opt->optimum(*parse_criterion(r.criterion));
        const std::string where = "Table " + r.table + " " + r.criterion + " gamma=" + std::to_string(r.gamma) +
                                  " delta=" + std::to_string(r.delta);
        EXPECT_NEAR(o.alpha, r.alpha.value, r.alpha.unit * (1 + 1e-9)) << where;
        if (const Erratum* e = erratum_for(r)) {
            EXPECT_NEAR(o.beta, e->exact_beta, 1e-5) << where;
            EXPECT_NEAR(*o.cost, e->exact_cost, 1e-3) << where;
            EXPECT_GT(*o.cost, r.cost->value + 5 * r.cost->unit) << where << ": no longer an erratum?";
            continue;
        }
        const double beta_tol = r.criterion == "amax" ? 2 * r.beta.unit : r.criterion == "OV" ? 0.01 : r.beta.unit;
        EXPECT_NEAR(o.beta, r.beta.value, beta_tol * (1 + 1e-9)) << where;
        EXPECT_EQ(o.cost.has_value(), r.criterion != "amax" && r.criterion != "OV") << where;
        if (!r.cost || !o.cost) continue;
        EXPECT_NEAR(*o.cost, r.cost->value, r.cost->unit * (1 + 1e-9)) << where;
    }
}

TEST(PaperTables, ErrataConfirmedByTheIndependentMethod) {
    // Second way: time-stepping with quadrature (64 sub-steps, error ~1e-9) at the printed optimal
    // point gives the exact cost there, well above the printed cost; and the printed point is
    // within the printed precision of ours, so the printed cost is not attained nearby either.
    const NormalizedPlant p{0, 0.02, 1};
    const auto ce2 = testing::simulate_step(p.gamma, p.delta, p.delay, 0.0625, 0.3786, 64, 2000).ce[2];
    EXPECT_NEAR(ce2, energy_costs(p, {0.0625, 0.3786}).ce2, 1e-6 * ce2);
    EXPECT_GT(ce2, 79.40 + 0.05);
    const WallOptimizer opt(p);
    const Optimum o = opt.optimum(Criterion::CE2_OV);
    const auto at_point = testing::simulate_step(p.gamma, p.delta, p.delay, o.alpha, o.beta, 64, 2000).ce[2];
    EXPECT_NEAR(at_point, *o.cost, 1e-6 * at_point);
    const auto printed_point = testing::simulate_step(p.gamma, p.delta, p.delay, 0.046, 0.315, 64, 2000).ce[2];
    EXPECT_GT(printed_point, 102.5 + 0.5);
}

}  // namespace
}  // namespace hapticopt
