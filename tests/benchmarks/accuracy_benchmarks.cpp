// SPDX-License-Identifier: Apache-2.0
// Run time against error: the closed-form energy costs against time-stepping with
// 10, 100, 1000 steps per period (plain composite Simpson, and Richardson-extrapolated from N and 2N
// steps), and the exact continuous overshoot against sample-based maxima, for d = 0, 1, 6
// (tests/data/accuracy_cases.hpp). Errors are measured against tests/data/accuracy_reference.csv
// (long double, tests/data/make_accuracy_reference.cpp) and reported as counters (the optimum search's
// tolerance against time is the last benchmark, BM_OptimumSearch, with its own reference):
//   err_ce = max over C_E0..2 of the relative error, err_ov = |C_OV - reference| (C_OV is already
//   relative to x_inf, so this is the error of the maximum in units of x_inf).
// Time-stepping is tests/core/reference_simulation.hpp (exact ZOH sub-steps, Simpson), run for enough
// periods that the truncated tail (rho^2P P^2) is below 1e-18. Table: tests/benchmarks/accuracy_report.py
// (docs/accuracy.md).
#include <benchmark/benchmark.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include <hapticopt/hapticopt.hpp>

#include "../core/reference_simulation.hpp"
#include "../data/accuracy_cases.hpp"
#include "common/test_paths.hpp"

namespace {

struct Reference {
    std::array<double, 3> ce{};
    double overshoot = 0;
};

const std::vector<Reference>& references() {
    static const std::vector<Reference> refs = [] {
        std::ifstream in(HAPTICOPT_TEST_DATA_DIR + "/accuracy_reference.csv");
        if (!in) throw std::runtime_error("cannot read " + HAPTICOPT_TEST_DATA_DIR + "/accuracy_reference.csv");
        std::vector<Reference> out;
        std::string line;
        while (std::getline(in, line)) {
            if (line.empty() || line[0] == '#' || line[0] == 'd') continue;
            std::replace(line.begin(), line.end(), ',', ' ');
            std::istringstream fields(line);
            double d, g, dl, a, b;
            Reference r;
            fields >> d >> g >> dl >> a >> b >> r.ce[0] >> r.ce[1] >> r.ce[2] >> r.overshoot;
            out.push_back(r);
        }
        if (out.size() != std::size(hapticopt::accuracy::kCases))
            throw std::runtime_error("accuracy_reference.csv: rows");
        return out;
    }();
    return refs;
}

std::size_t case_index(double d) {
    for (std::size_t i = 0; i < std::size(hapticopt::accuracy::kCases); ++i)
        if (hapticopt::accuracy::kCases[i].d == d) return i;
    throw std::runtime_error("no case for this d");
}

double energy_error(const std::array<double, 3>& got, const Reference& ref) {
    double e = 0;
    for (std::size_t p = 0; p < 3; ++p) e = std::max(e, std::fabs(got[p] - ref.ce[p]) / ref.ce[p]);
    return e;
}

int periods_for(const hapticopt::accuracy::Case& c) {
    const double rho = hapticopt::stability({c.gamma, c.delta, c.d}, {c.alpha, c.beta}).spectral_radius;
    int periods = 10;
    while (std::pow(rho, 2.0 * periods) * periods * periods > 1e-18) periods += 10;
    return periods + static_cast<int>(c.d) + 5;
}

void BM_EnergyClosedForm(benchmark::State& state) {
    const std::size_t i = case_index(static_cast<double>(state.range(0)));
    const auto& c = hapticopt::accuracy::kCases[i];
    hapticopt::EnergyCosts e{};
    for (auto _ : state) {
        e = hapticopt::energy_costs({c.gamma, c.delta, c.d}, {c.alpha, c.beta});
        benchmark::DoNotOptimize(e);
    }
    state.counters["err_ce"] = energy_error({e.ce0, e.ce1, e.ce2}, references()[i]);
}
BENCHMARK(BM_EnergyClosedForm)->ArgName("d")->Arg(0)->Arg(1)->Arg(6)->Unit(benchmark::kMicrosecond);

// Time-stepping, N steps per period: energy by composite Simpson, overshoot as the sampled maximum.
void BM_TimeStepping(benchmark::State& state) {
    const std::size_t i = case_index(static_cast<double>(state.range(0)));
    const auto& c = hapticopt::accuracy::kCases[i];
    const int n = static_cast<int>(state.range(1));
    const int periods = periods_for(c);
    hapticopt::testing::SimulatedCosts s;
    for (auto _ : state) {
        s = hapticopt::testing::simulate_step(c.gamma, c.delta, c.d, c.alpha, c.beta, n, periods);
        benchmark::DoNotOptimize(s);
    }
    state.counters["err_ce"] = energy_error(s.ce, references()[i]);
    state.counters["err_ov"] = std::fabs(s.max_sampled_overshoot - references()[i].overshoot);
    state.counters["periods"] = periods;
}
BENCHMARK(BM_TimeStepping)
    ->ArgNames({"d", "steps"})
    ->ArgsProduct({{0, 1, 6}, {10, 100, 1000}})
    ->Unit(benchmark::kMicrosecond);

// Richardson extrapolation of Simpson (order 4): (16 S_2N - S_N) / 15; the time is both runs.
void BM_TimeSteppingRichardson(benchmark::State& state) {
    const std::size_t i = case_index(static_cast<double>(state.range(0)));
    const auto& c = hapticopt::accuracy::kCases[i];
    const int n = static_cast<int>(state.range(1));
    const int periods = periods_for(c);
    std::array<double, 3> ce{};
    for (auto _ : state) {
        const auto coarse = hapticopt::testing::simulate_step(c.gamma, c.delta, c.d, c.alpha, c.beta, n, periods);
        const auto fine = hapticopt::testing::simulate_step(c.gamma, c.delta, c.d, c.alpha, c.beta, 2 * n, periods);
        for (std::size_t p = 0; p < 3; ++p) ce[p] = (16 * fine.ce[p] - coarse.ce[p]) / 15;
        benchmark::DoNotOptimize(ce);
    }
    state.counters["err_ce"] = energy_error(ce, references()[i]);
}
BENCHMARK(BM_TimeSteppingRichardson)
    ->ArgNames({"d", "steps"})
    ->ArgsProduct({{0, 1, 6}, {10, 100, 1000}})
    ->Unit(benchmark::kMicrosecond);

void BM_OvershootExact(benchmark::State& state) {
    const std::size_t i = case_index(static_cast<double>(state.range(0)));
    const auto& c = hapticopt::accuracy::kCases[i];
    hapticopt::OvershootResult r;
    for (auto _ : state) {
        r = hapticopt::overshoot({c.gamma, c.delta, c.d}, {c.alpha, c.beta});
        benchmark::DoNotOptimize(r);
    }
    state.counters["err_ov"] = std::fabs(r.value - references()[i].overshoot);
}
BENCHMARK(BM_OvershootExact)->ArgName("d")->Arg(0)->Arg(1)->Arg(6)->Unit(benchmark::kMicrosecond);

// Optimum search: OptimumOptions::alpha_tolerance (Brent over alpha for CE2 with OptimumMethod::brent,
// bisection for CE2+OV)
// against time, for the paper's first plant rows (gamma = delta = 0) at d = 0, 1, 6. Error: relative
// error of alpha and of the cost C_E2 against the same search run with alpha_tolerance 1e-13 and a 4x
// denser coarse grid (96 x 64). That reference's own accuracy is what the optimum tests check (no
// point of a 120 x 120 grid is better; optimal curves at the long double sign change of dC/dbeta;
// the 64 paper rows to their printed digits), so these errors are self-convergence, not absolute.
const hapticopt::Optimum& optimum_reference(int d, hapticopt::Criterion criterion) {
    static std::array<std::array<hapticopt::Optimum, 2>, 3> cache{};
    static std::array<std::array<bool, 2>, 3> done{};
    const std::size_t i = case_index(static_cast<double>(d));
    const std::size_t k = criterion == hapticopt::Criterion::CE2 ? 0 : 1;
    if (!done[i][k]) {
        hapticopt::OptimumOptions fine;
        fine.alpha_tolerance = 1e-13;
        fine.alpha_grid = 96;
        fine.beta_grid = 64;
        fine.method = hapticopt::OptimumMethod::brent;
        cache[i][k] = hapticopt::WallOptimizer({0.0, 0.0, static_cast<double>(d)}, fine).optimum(criterion);
        done[i][k] = true;
    }
    return cache[i][k];
}

void BM_OptimumSearch(benchmark::State& state) {
    const int d = static_cast<int>(state.range(0));
    const auto criterion = state.range(1) == 0 ? hapticopt::Criterion::CE2 : hapticopt::Criterion::CE2_OV;
    hapticopt::OptimumOptions options;
    options.alpha_tolerance = std::pow(10.0, -static_cast<double>(state.range(2)));
    options.method = hapticopt::OptimumMethod::brent;  // the method with a tolerance over alpha
    const hapticopt::Optimum& ref = optimum_reference(d, criterion);
    hapticopt::Optimum got;
    for (auto _ : state) {
        got = hapticopt::WallOptimizer({0.0, 0.0, static_cast<double>(d)}, options).optimum(criterion);
        benchmark::DoNotOptimize(got);
    }
    state.counters["err_opt_alpha"] = std::fabs(got.alpha - ref.alpha) / ref.alpha;
    state.counters["err_opt_cost"] = std::fabs(*got.cost - *ref.cost) / *ref.cost;
}
BENCHMARK(BM_OptimumSearch)
    ->ArgNames({"d", "ov", "tol_exp"})
    ->ArgsProduct({{0, 1, 6}, {0, 1}, {4, 6, 8, 10, 12}})
    ->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
