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
//  * BM_PairOverSetWithDelays: BM_PairOverSet with the total delays [d - 1, d + 2] periods in the set (the shipped
//    Falcon's 5 .. 8 ms at d = 6; delay_range_stability.hpp), arm 0: without, 1: with the arms of the paper's eq. 2.
//  * BM_PlaneCommitOverSet: what the server checks when a client commits one plane on the Falcon's loop (window 15,
//    d = 6): the plane's ramp over 30 ticks (ramp_is_stable: 29 scenes) and the final scene (sum_is_stable), gains
//    half the CE2 optimum; arm 0/1 as above, delays 0: the nominal delay alone, 1: 5 .. 8 ms.
//  * BM_ObliqueSumOverSet: sum_is_stable of two planes 45 degrees apart, one with half the CE2 gains and one with a
//    quarter of its stiffness and half its damping (their gain matrices do not commute), on the Falcon's loop (window
//    15, d = 6), arm and delays as above: the sampled coupled verdict, then the numerical-range proof over the set
//    (numerical_range_certificate.hpp); counter `proven` 1 when coupled_over_set reports it certified. Baseline in
//    the same run: BM_ObliqueSumNominal, the same sum for the nominal plant alone (one block companion eigenproblem).
//  * BM_ObliqueRampSceneOverSet: coupled_over_set of scene j / 30 of a plane's ramp (100 N/m, 1 N s/m at its end,
//    45 degrees to the wall) beside a wall of half the CE2 gains on the Falcon's loop with the arm and the delays
//    5 .. 8 ms: a thin numerical range (the refined polygon; numerical_range_certificate.hpp); counter `proven`.
// Gains: CE2 for the nominal mass of each kind and delay, scaled by 0.5 (stable over the set in every case: checked).
#include <benchmark/benchmark.h>

#include <cmath>
#include <stdexcept>
#include <string>
#include <utility>

#include "tuning/object_checks.hpp"

namespace {

using namespace hapticd;

GainCheckPlant set_bench_plant(int d, int kind, bool with_set, bool with_arm = false, bool with_delays = false) {
    GainCheckPlant p;
    p.mass = 0.30;
    p.period = 1e-3;
    p.time_delay = d * 1e-3;
    if (kind == 1) {
        p.velocity.kind = hapticopt::VelocityEstimatorKind::lowpass;
        p.velocity.cutoff_hz = 20.0;
    } else if (kind == 2) {
        p.velocity.kind = hapticopt::VelocityEstimatorKind::window;
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
    if (with_delays) p.delay_range = std::make_pair((d - 1) * 1e-3, (d + 2) * 1e-3);
    return p;
}

void run_pair(benchmark::State& state, bool with_set, bool with_arm = false, bool with_delays = false) {
    const int d = static_cast<int>(state.range(0)), kind = static_cast<int>(state.range(1));
    GainChecker checker(set_bench_plant(d, kind, with_set, with_arm, with_delays));
    const CriterionGains g = checker.criterion_gains(hapticopt::Criterion::CE2, 0.30);
    const double K = 0.5 * g.K, B = 0.5 * g.B;
    if (!checker.pair_is_stable(K, B, 0.30)) throw std::logic_error("benchmark gains not stable");
    for (auto _ : state) benchmark::DoNotOptimize(checker.pair_is_stable(K, B, 0.30));
}

void BM_PairNominal(benchmark::State& state) { run_pair(state, false); }
void BM_PairOverSet(benchmark::State& state) { run_pair(state, true); }
void BM_PairOverSetWithArm(benchmark::State& state) { run_pair(state, true, true); }

void BM_PairOverSetWithDelays(benchmark::State& state) { run_pair(state, true, state.range(2) != 0, true); }

void BM_PlaneCommitOverSet(benchmark::State& state) {
    const bool with_arm = state.range(0) != 0, with_delays = state.range(1) != 0;
    GainChecker checker(set_bench_plant(6, 2, true, with_arm, with_delays));
    const CriterionGains g = checker.criterion_gains(hapticopt::Criterion::CE2, 0.30);
    Matrix3 K{}, B{}, zero{};
    K[2][2] = 0.5 * g.K;
    B[2][2] = 0.5 * g.B;
    std::string why;
    for (auto _ : state) {
        const bool ok =
            checker.ramp_is_stable(zero, zero, K, B, zero, zero, 1.0 / 30.0, why) && checker.sum_is_stable(K, B, why);
        if (!ok) throw std::logic_error("benchmark plane not stable: " + why);
        benchmark::DoNotOptimize(ok);
    }
}

// The two oblique planes of BM_ObliqueSumOverSet, (K, B) summed.
std::pair<Matrix3, Matrix3> oblique_sum(const CriterionGains& g) {
    Matrix3 K{}, B{};
    const double c = std::sqrt(0.5);
    const double n[2][3] = {{0.0, 0.0, 1.0}, {0.0, c, c}};
    const double k[2] = {0.5 * g.K, 0.25 * g.K}, b[2] = {0.5 * g.B, 0.5 * g.B};
    for (int p = 0; p < 2; ++p) {
        for (std::size_t i = 0; i < 3; ++i) {
            for (std::size_t j = 0; j < 3; ++j) {
                K[i][j] += k[p] * n[p][i] * n[p][j];
                B[i][j] += b[p] * n[p][i] * n[p][j];
            }
        }
    }
    return {K, B};
}

void run_oblique_sum(benchmark::State& state, bool with_set) {
    const bool with_arm = with_set && state.range(0) != 0, with_delays = with_set && state.range(1) != 0;
    GainChecker checker(set_bench_plant(6, 2, with_set, with_arm, with_delays));
    const auto [K, B] = oblique_sum(checker.criterion_gains(hapticopt::Criterion::CE2, 0.30));
    std::string why;
    if (!checker.sum_is_stable(K, B, why)) throw std::logic_error("benchmark sum not stable: " + why);
    for (auto _ : state) benchmark::DoNotOptimize(checker.sum_is_stable(K, B, why));
    state.counters["proven"] = with_set && checker.coupled_over_set(K, B).certified ? 1.0 : 0.0;
}

void BM_ObliqueSumNominal(benchmark::State& state) { run_oblique_sum(state, false); }
void BM_ObliqueSumOverSet(benchmark::State& state) { run_oblique_sum(state, true); }

void BM_ObliqueRampSceneOverSet(benchmark::State& state) {
    GainChecker checker(set_bench_plant(6, 2, true, true, true));
    const CriterionGains g = checker.criterion_gains(hapticopt::Criterion::CE2, 0.30);
    const double s = static_cast<double>(state.range(0)) / 30.0, c = std::sqrt(0.5);
    Matrix3 K{}, B{};
    K[0][0] = 0.5 * g.K;
    B[0][0] = 0.5 * g.B;
    const double n[3] = {c, c, 0.0};
    for (std::size_t i = 0; i < 3; ++i) {
        for (std::size_t j = 0; j < 3; ++j) {
            K[i][j] += s * s * 100.0 * n[i] * n[j];
            B[i][j] += s * 1.0 * n[i] * n[j];
        }
    }
    hapticopt::MatrixGainScaleStability v;
    for (auto _ : state) {
        v = checker.coupled_over_set(K, B);
        benchmark::DoNotOptimize(v);
    }
    if (!v.stable) throw std::logic_error("benchmark ramp scene not stable");
    state.counters["proven"] = v.certified ? 1.0 : 0.0;
}

void BM_PlaneObjectOverSet(benchmark::State& state) {
    const int d = static_cast<int>(state.range(0)), kind = static_cast<int>(state.range(1));
    GainChecker checker(set_bench_plant(d, kind, true));
    const CriterionGains g = checker.criterion_gains(hapticopt::Criterion::CE2, 0.30);
    const std::vector<double> masses{0.30};
    if (!checker.check_object(g.K, g.B, masses).stable) throw std::logic_error("CE2 over the set not stable");
    for (auto _ : state) benchmark::DoNotOptimize(checker.check_object(g.K, g.B, masses));
}

void set_args(benchmark::internal::Benchmark* b) {
    b->ArgNames({"d", "kind"});
    for (const int d : {1, 6}) {
        for (const int kind : {0, 1, 2}) b->Args({d, kind});
    }
    b->Unit(benchmark::kMicrosecond);
}

// Without and with the arm, without and with the delays' range, in milliseconds.
void arm_and_delay_args(benchmark::internal::Benchmark* b) {
    b->ArgNames({"arm", "delays"});
    for (const int arm : {0, 1}) {
        for (const int delays : {0, 1}) b->Args({arm, delays});
    }
    b->Unit(benchmark::kMillisecond);
}

}  // namespace

BENCHMARK(BM_PairNominal)->Apply(set_args);
BENCHMARK(BM_PairOverSet)->Apply(set_args);
BENCHMARK(BM_PairOverSetWithArm)->Apply(set_args);
BENCHMARK(BM_PlaneObjectOverSet)->Apply(set_args);
BENCHMARK(BM_PairOverSetWithDelays)
    ->ArgNames({"d", "kind", "arm"})
    ->Args({1, 0, 0})
    ->Args({6, 0, 0})
    ->Args({6, 2, 0})
    ->Args({6, 0, 1})
    ->Args({6, 2, 1})
    ->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_PlaneCommitOverSet)->Apply(arm_and_delay_args);
BENCHMARK(BM_ObliqueSumNominal)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_ObliqueSumOverSet)->Apply(arm_and_delay_args);
BENCHMARK(BM_ObliqueRampSceneOverSet)
    ->ArgName("j")
    ->Arg(1)
    ->Arg(2)
    ->Arg(15)
    ->Arg(29)
    ->Arg(30)
    ->Unit(benchmark::kMillisecond);
