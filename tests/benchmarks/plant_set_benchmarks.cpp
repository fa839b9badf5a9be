// SPDX-License-Identifier: Apache-2.0
// What certifying every verdict over the profile's plant set costs (tuning/object_checks.hpp, hapticopt's
// mass_scaling_stability.hpp, docs/robust-stability.md), with the nominal plant's verdict as the baseline in the same
// run. Kind 0: backward difference, 1: low-pass 20 Hz at 1 kHz, 2: window of 15 periods (the shipped Falcon's);
// 0.30 kg, delay d = 1 and 6.
//  * BM_PairNominal: pair_is_stable of one (K, B) for the nominal mass alone (mass_margin 0, no mass_range): one
//    Schur-Cohn verdict.
//  * BM_PairOverSet: the same over the Falcon's set (mass_range 0.22 .. 0.30 kg, mass_margin 0.1): the verdict at the
//    lightest mass, the ray's unit-circle crossings (Chebyshev derivative cascade) and the verdict at the heaviest.
//  * BM_PairOverSetWithArm: the same over the set with the arms of the paper's eq. 2 (k_H / m <= 1000 s^-2,
//    b_H / m <= 20 s^-1): the mass verdict at each of the 9 arms of the grid.
//  * BM_PlaneObjectOverSet: check_object of a plane with a criterion's gains (CE2 over the set).
// Gains: CE2 for the nominal mass of each kind and delay, scaled by 0.5 (stable over the set in every case: checked).
#include <benchmark/benchmark.h>

#include <stdexcept>

#include "tuning/object_checks.hpp"

namespace {

using namespace hapticd;

GainCheckPlant set_bench_plant(int d, int kind, bool with_set, bool with_arm = false) {
    GainCheckPlant p;
    p.mass = 0.30;
    p.period = 1e-3;
    p.time_delay = d * 1e-3;
    if (kind == 1) {
        p.velocity.kind = LoopVelocityKind::LowPass;
        p.velocity.cutoff_hz = 20.0;
    } else if (kind == 2) {
        p.velocity.kind = LoopVelocityKind::Window;
        p.velocity.window = 15;
    }
    if (with_set) {
        p.mass_range = std::make_pair(0.22, 0.30);
        p.mass_margin = 0.1;
    }
    if (with_arm) {
        p.arm_stiffness_per_mass = 1000.0;
        p.arm_damping_per_mass = 20.0;
    }
    return p;
}

void run_pair(benchmark::State& state, bool with_set, bool with_arm = false) {
    const int d = static_cast<int>(state.range(0)), kind = static_cast<int>(state.range(1));
    GainChecker checker(set_bench_plant(d, kind, with_set, with_arm));
    const std::optional<CriterionGains> g = checker.criterion_gains("CE2", 0.30);
    const double K = 0.5 * g->K, B = 0.5 * g->B;
    if (!checker.pair_is_stable(K, B, 0.30)) throw std::logic_error("benchmark gains not stable");
    for (auto _ : state) benchmark::DoNotOptimize(checker.pair_is_stable(K, B, 0.30));
}

void BM_PairNominal(benchmark::State& state) { run_pair(state, false); }
void BM_PairOverSet(benchmark::State& state) { run_pair(state, true); }
void BM_PairOverSetWithArm(benchmark::State& state) { run_pair(state, true, true); }

void BM_PlaneObjectOverSet(benchmark::State& state) {
    const int d = static_cast<int>(state.range(0)), kind = static_cast<int>(state.range(1));
    GainChecker checker(set_bench_plant(d, kind, true));
    const std::optional<CriterionGains> g = checker.criterion_gains("CE2", 0.30);
    const std::vector<double> masses{0.30};
    if (!checker.check_object(g->K, g->B, masses).stable) throw std::logic_error("CE2 over the set not stable");
    for (auto _ : state) benchmark::DoNotOptimize(checker.check_object(g->K, g->B, masses));
}

void set_args(benchmark::internal::Benchmark* b) {
    b->ArgNames({"d", "kind"});
    for (const int d : {1, 6}) {
        for (const int kind : {0, 1, 2}) b->Args({d, kind});
    }
    b->Unit(benchmark::kMicrosecond);
}

}  // namespace

BENCHMARK(BM_PairNominal)->Apply(set_args);
BENCHMARK(BM_PairOverSet)->Apply(set_args);
BENCHMARK(BM_PairOverSetWithArm)->Apply(set_args);
BENCHMARK(BM_PlaneObjectOverSet)->Apply(set_args);
