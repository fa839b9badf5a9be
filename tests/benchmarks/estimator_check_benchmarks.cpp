// SPDX-License-Identifier: Apache-2.0
// What the loop's velocity estimator costs the tuning's checks (tuning/object_checks.hpp, docs/velocity-estimation.md,
// "In the checks"), with the backward difference as the baseline in the same run. Kind 0: backward, 1: low-pass
// 20 Hz at 1 kHz (nu = 0.02), 2: window of 5 periods; one mass 0.3 kg, delay d = 1 and 3.
//  * BM_EstimatorCheckerStart: a GainChecker built for the profile (with an estimator: its main stable region's
//    scan for alpha_max).
//  * BM_EstimatorPairVerdict: pair_is_stable of one (K, B): the scalar Schur-Cohn verdict.
//  * BM_EstimatorCoupledCheck: coupled() of three planes on non-commuting directions: the block companion
//    eigenproblem, of size 3 (d + 3) for the backward difference, 3 (d + 4) with the low-pass, 3 (d + 3 + 5)
//    with the window.
//  * BM_EstimatorTuneWall: tune_wall for CE2 (a config wall's or an object criterion's optimum, once per cache).
// Gains: the CE2 optimum of each kind at that delay, each plane at a third of its K and 0.8, 1 or 1.2 thirds of its
// B (stable with every kind, checked).
#include <benchmark/benchmark.h>

#include <array>
#include <cmath>

#include "tuning/object_checks.hpp"

namespace {

using namespace hapticd;

constexpr double kEstBenchPeriod = 1e-3;

GainCheckPlant estimator_bench_plant(int d, int kind) {
    GainCheckPlant p;
    p.mass = 0.3;
    p.period = kEstBenchPeriod;
    p.time_delay = d * kEstBenchPeriod;
    if (kind == 1) {
        p.velocity.kind = hapticopt::VelocityEstimatorKind::lowpass;
        p.velocity.cutoff_hz = 20.0;
    } else if (kind == 2) {
        p.velocity.kind = hapticopt::VelocityEstimatorKind::window;
        p.velocity.window = 5;
    }
    return p;
}

Matrix3 plane_matrix(const std::array<double, 3>& n, double gain) {
    const double norm = std::sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
    Matrix3 m{};
    for (std::size_t i = 0; i < 3; ++i) {
        for (std::size_t j = 0; j < 3; ++j) m[i][j] = gain * n[i] * n[j] / (norm * norm);
    }
    return m;
}

void BM_EstimatorCheckerStart(benchmark::State& state) {
    const GainCheckPlant p = estimator_bench_plant(static_cast<int>(state.range(0)), static_cast<int>(state.range(1)));
    for (auto _ : state) {
        GainChecker checker(p);
        benchmark::DoNotOptimize(&checker);
    }
}

void BM_EstimatorPairVerdict(benchmark::State& state) {
    const GainCheckPlant p = estimator_bench_plant(static_cast<int>(state.range(0)), static_cast<int>(state.range(1)));
    const TuningResult ce2 = tune_wall(hapticopt::Criterion::CE2, p);
    const GainChecker checker(p);
    for (auto _ : state) benchmark::DoNotOptimize(checker.pair_is_stable(ce2.K, ce2.B, p.mass));
}

void BM_EstimatorCoupledCheck(benchmark::State& state) {
    const GainCheckPlant p = estimator_bench_plant(static_cast<int>(state.range(0)), static_cast<int>(state.range(1)));
    const TuningResult ce2 = tune_wall(hapticopt::Criterion::CE2, p);
    const GainChecker checker(p);
    Matrix3 K{}, B{};
    const std::array<std::array<double, 3>, 3> normals{{{1.0, 0.2, 0.0}, {0.3, 1.0, 0.4}, {-0.2, 0.5, 1.0}}};
    const std::array<double, 3> damping_share{0.8, 1.0, 1.2};  // K and B not proportional: they do not commute
    for (std::size_t i = 0; i < 3; ++i) {
        add_to(K, plane_matrix(normals[i], ce2.K / 3.0));
        add_to(B, plane_matrix(normals[i], damping_share[i] * ce2.B / 3.0));
    }
    bool stable = false, commuting = true;
    for (auto _ : state) {
        const hapticopt::MatrixGainStability v = checker.coupled(K, B);
        stable = v.stable;
        commuting = v.commuting;
        benchmark::DoNotOptimize(v.spectral_radius);
    }
    if (!stable || commuting) state.SkipWithError("the benchmark's sum is not the non-commuting stable case");
}

void BM_EstimatorTuneWall(benchmark::State& state) {
    const GainCheckPlant p = estimator_bench_plant(static_cast<int>(state.range(0)), static_cast<int>(state.range(1)));
    for (auto _ : state) benchmark::DoNotOptimize(tune_wall(hapticopt::Criterion::CE2, p).K);
}

void estimator_kinds(benchmark::internal::Benchmark* b) {
    for (int d : {1, 3}) {
        for (int kind : {0, 1, 2}) b->Args({d, kind});
    }
    b->ArgNames({"d", "kind"})->Unit(benchmark::kMicrosecond);
}

BENCHMARK(BM_EstimatorCheckerStart)->Apply(estimator_kinds);
BENCHMARK(BM_EstimatorPairVerdict)->Apply(estimator_kinds);
BENCHMARK(BM_EstimatorCoupledCheck)->Apply(estimator_kinds);
BENCHMARK(BM_EstimatorTuneWall)->Apply(estimator_kinds);

}  // namespace
