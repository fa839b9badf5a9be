// SPDX-License-Identifier: Apache-2.0
// Speed of the closed forms and the optimisers (issues 2 and 3). Run:
//   build/release/tests/benchmarks/hapticopt_benchmarks --benchmark_min_time=0.2
// Figures go in the README with the machine they were measured on.
#include <benchmark/benchmark.h>

#include <cstdint>

#include <hapticopt/hapticopt.hpp>

namespace {

using namespace hapticopt;

// Gains near the CE2 optimum of each delay (Table III/IV; 0.6x alpha_max for larger d).
NormalizedGains gains_for(double d) {
    if (d == 0) return {0.2474, 0.7445};
    if (d == 1) return {0.0582, 0.3796};
    return {0.006, 0.09};  // d = 6: inside the region, alpha_max = 0.01126
}

void BM_EnergyCosts(benchmark::State& state) {
    const double d = static_cast<double>(state.range(0));
    const SampledPlant<double> plant(NormalizedPlant{0.001, 0.02, d});
    const NormalizedGains g = gains_for(d);
    for (auto _ : state) benchmark::DoNotOptimize(energy_costs(plant, g.alpha, g.beta));
}
BENCHMARK(BM_EnergyCosts)->Arg(0)->Arg(1)->Arg(6)->Unit(benchmark::kMicrosecond);

// C_E<k> alone (what the CEk optimiser evaluates): C_E0 needs one Stein solve, C_E2 all three.
void BM_EnergyCostSingleIndex(benchmark::State& state) {
    const double d = static_cast<double>(state.range(0));
    const int k = static_cast<int>(state.range(1));
    const SampledPlant<double> plant(NormalizedPlant{0.001, 0.02, d});
    const NormalizedGains g = gains_for(d);
    for (auto _ : state) benchmark::DoNotOptimize(energy_cost(plant, g.alpha, g.beta, k));
}
BENCHMARK(BM_EnergyCostSingleIndex)
    ->Args({1, 0})
    ->Args({1, 2})
    ->Args({6, 0})
    ->Args({6, 2})
    ->Unit(benchmark::kMicrosecond);

// The complex Schur form + triangular Stein solves: the tests' independent method, the baseline here.
void BM_EnergyCostsComplexSchur(benchmark::State& state) {
    const double d = static_cast<double>(state.range(0));
    const SampledPlant<double> plant(NormalizedPlant{0.001, 0.02, d});
    const NormalizedGains g = gains_for(d);
    for (auto _ : state)
        benchmark::DoNotOptimize(hapticopt::detail::energy_costs_complex_schur(plant, g.alpha, g.beta));
}
BENCHMARK(BM_EnergyCostsComplexSchur)->Arg(1)->Arg(6)->Unit(benchmark::kMicrosecond);

// C_E<k> with its gradient (energy_gradient.hpp, adjoint Stein equation); compare BM_EnergyCostSingleIndex.
void BM_EnergyCostGradient(benchmark::State& state) {
    const double d = static_cast<double>(state.range(0));
    const int k = static_cast<int>(state.range(1));
    const SampledPlant<double> plant(NormalizedPlant{0.001, 0.02, d});
    const NormalizedGains g = gains_for(d);
    for (auto _ : state) benchmark::DoNotOptimize(energy_cost_gradient(plant, g.alpha, g.beta, k));
}
BENCHMARK(BM_EnergyCostGradient)->Args({1, 0})->Args({1, 2})->Args({6, 0})->Args({6, 2})->Unit(benchmark::kMicrosecond);

void BM_EnergyCostsIncludingPlantSetup(benchmark::State& state) {
    const double d = static_cast<double>(state.range(0));
    const NormalizedGains g = gains_for(d);
    for (auto _ : state) benchmark::DoNotOptimize(energy_costs(NormalizedPlant{0.001, 0.02, d}, g));
}
BENCHMARK(BM_EnergyCostsIncludingPlantSetup)->Arg(1)->Unit(benchmark::kMicrosecond);

void BM_Overshoot(benchmark::State& state) {
    const double d = static_cast<double>(state.range(0));
    const SampledPlant<double> plant(NormalizedPlant{0.001, 0.02, d});
    const NormalizedGains g = gains_for(d);
    for (auto _ : state) benchmark::DoNotOptimize(overshoot(plant, g.alpha, g.beta));
}
BENCHMARK(BM_Overshoot)->Arg(0)->Arg(1)->Arg(6)->Unit(benchmark::kMicrosecond);

void BM_StabilityTest(benchmark::State& state) {
    const SampledPlant<double> plant(NormalizedPlant{0.001, 0.02, 1});
    for (auto _ : state) benchmark::DoNotOptimize(loop_is_stable(plant, 0.0582, 0.3796));
}
BENCHMARK(BM_StabilityTest)->Unit(benchmark::kMicrosecond);

void BM_Optimum(benchmark::State& state) {
    const auto c = static_cast<Criterion>(state.range(0));
    const double d = static_cast<double>(state.range(1));
    for (auto _ : state) benchmark::DoNotOptimize(optimal_point(c, NormalizedPlant{0, 0, d}));
}
BENCHMARK(BM_Optimum)
    ->Args({static_cast<int>(Criterion::CE2), 1})
    ->Args({static_cast<int>(Criterion::CE2), 6})
    ->Args({static_cast<int>(Criterion::CE2_OV), 1})
    ->Args({static_cast<int>(Criterion::Overshoot), 1})
    ->Unit(benchmark::kMillisecond);

// The CE2 optimum (optimal_point, plant gamma = delta = 0) by both methods in the same run: method 0 the
// fast path (OptimumMethod::newton, the default), 1 the nested Brent search (OptimumMethod::brent).
void BM_OptimumMethod(benchmark::State& state) {
    const double d = static_cast<double>(state.range(0));
    OptimumOptions o;
    o.method = state.range(1) == 0 ? OptimumMethod::newton : OptimumMethod::brent;
    for (auto _ : state) benchmark::DoNotOptimize(optimal_point(Criterion::CE2, NormalizedPlant{0, 0, d}, o));
}
BENCHMARK(BM_OptimumMethod)->ArgNames({"d", "brent"})->ArgsProduct({{0, 1, 6}, {0, 1}})->Unit(benchmark::kMicrosecond);

// What the optimum's set-up costs: the exact stable region (StabilityRegion) and the sampled plant.
void BM_OptimizerSetup(benchmark::State& state) {
    const double d = static_cast<double>(state.range(0));
    for (auto _ : state) benchmark::DoNotOptimize(WallOptimizer(NormalizedPlant{0, 0, d}));
}
BENCHMARK(BM_OptimizerSetup)->Arg(0)->Arg(1)->Arg(6)->Unit(benchmark::kMicrosecond);

// Velocity estimators (velocity_estimator.hpp). Kind 0: the backward difference through the estimator's
// dense loop (complex Schur; compare BM_EnergyCosts, the shift-structured backward path, in the same run);
// 1: low-pass nu = 0.02 (20 Hz at 1 kHz); 2: window N = 15. Gains: BM_EstimatorOptimum's CE2 optima of
// these estimators are about (0.0047, 0.09..0.11) at d = 0, 1 and (0.0013, 0.05) at d = 6: use points inside
// every main region.
VelocityEstimator estimator_for(std::int64_t kind) {
    if (kind == 1) return VelocityEstimator::low_pass(0.02);
    if (kind == 2) return VelocityEstimator::moving_window(15);
    return VelocityEstimator::backward_difference();
}
NormalizedGains estimator_gains_for(double d) {
    return d >= 6 ? NormalizedGains{0.0013, 0.05} : NormalizedGains{0.0046, 0.09};
}

void BM_EstimatorEnergyCosts(benchmark::State& state) {
    const double d = static_cast<double>(state.range(1));
    const SampledPlant<double> plant(NormalizedPlant{0.001, 0.02, d});
    const VelocityEstimator e = estimator_for(state.range(0));
    const NormalizedGains g = estimator_gains_for(d);
    for (auto _ : state) benchmark::DoNotOptimize(estimator_energy_costs(plant, e, g.alpha, g.beta));
}
BENCHMARK(BM_EstimatorEnergyCosts)
    ->Args({0, 1})
    ->Args({1, 1})
    ->Args({2, 1})
    ->Args({0, 6})
    ->Args({1, 6})
    ->Args({2, 6})
    ->Unit(benchmark::kMicrosecond);

// The backward baseline of BM_EstimatorEnergyCosts at the same gains (shift-structured path).
void BM_EstimatorBaselineEnergyCosts(benchmark::State& state) {
    const double d = static_cast<double>(state.range(0));
    const SampledPlant<double> plant(NormalizedPlant{0.001, 0.02, d});
    const NormalizedGains g = estimator_gains_for(d);
    for (auto _ : state) benchmark::DoNotOptimize(energy_costs(plant, g.alpha, g.beta));
}
BENCHMARK(BM_EstimatorBaselineEnergyCosts)->Arg(1)->Arg(6)->Unit(benchmark::kMicrosecond);

void BM_ForceNoiseGain(benchmark::State& state) {
    const double d = static_cast<double>(state.range(1));
    const SampledPlant<double> plant(NormalizedPlant{0.001, 0.02, d});
    const VelocityEstimator e = estimator_for(state.range(0));
    const NormalizedGains g = estimator_gains_for(d);
    for (auto _ : state) benchmark::DoNotOptimize(estimator_force_noise_gain(plant, e, g.alpha, g.beta));
}
BENCHMARK(BM_ForceNoiseGain)->Args({0, 1})->Args({1, 1})->Args({2, 1})->Unit(benchmark::kMicrosecond);

// CE2 optimum with the estimator; kind 0 is the existing backward optimiser (optimal_point, optimum.hpp).
// range(2): the CEx search, 0 = OptimumMethod::newton (the default: start grid, then Newton on the analytic
// gradient), 1 = OptimumMethod::brent (the derivative-free nested search; the baseline of the same run).
void BM_EstimatorOptimum(benchmark::State& state) {
    const double d = static_cast<double>(state.range(1));
    const VelocityEstimator e = estimator_for(state.range(0));
    EstimatorOptimumOptions o;
    o.method = state.range(2) == 0 ? OptimumMethod::newton : OptimumMethod::brent;
    for (auto _ : state) benchmark::DoNotOptimize(optimal_point(Criterion::CE2, NormalizedPlant{0, 0, d}, e, o));
}
BENCHMARK(BM_EstimatorOptimum)->ArgsProduct({{0, 1, 2}, {1, 6}, {0, 1}})->Unit(benchmark::kMillisecond);

// The estimator optimum at the Falcon's d = 6 (issue 39: the goal is at most 1 ms) for each energy criterion:
// range(0) the estimator (estimator_for: 0 backward through the estimator's optimiser, 1 low-pass nu = 0.02,
// 2 window 15), range(1) the criterion (0 CE0, 1 CE1, 2 CE2); OptimumMethod::newton (the default).
void BM_EstimatorOptimumD6(benchmark::State& state) {
    const VelocityEstimator e = estimator_for(state.range(0));
    const Criterion c = state.range(1) == 0 ? Criterion::CE0 : state.range(1) == 1 ? Criterion::CE1 : Criterion::CE2;
    for (auto _ : state) benchmark::DoNotOptimize(optimal_point(c, NormalizedPlant{0, 0, 6}, e));
}
BENCHMARK(BM_EstimatorOptimumD6)
    ->ArgNames({"estimator", "CE"})
    ->ArgsProduct({{0, 1, 2}, {0, 1, 2}})
    ->Unit(benchmark::kMillisecond);

// The main region at a corner tip (issue 39's case: window 20, d = 0, gamma = 0.001, delta = 0.02; the tip is the
// crossing of two branches, region_tip.hpp): range(0) 0 = the default 160 x 160 scan, 1 = the fast optimum's
// 16 x 16 (kFastOptimumRegionGrid); range(1) 1 = the region and its exact tip, 0 = region_tip_candidates alone.
void BM_RegionCornerTip(benchmark::State& state) {
    const NormalizedPlant plant{0.001, 0.02, 0};
    const VelocityEstimator e = VelocityEstimator::moving_window(20);
    const EstimatorRegionOptions grid = state.range(0) == 0 ? EstimatorRegionOptions{} : kFastOptimumRegionGrid;
    const EstimatorStabilityTest test(plant, e);
    for (auto _ : state) {
        if (state.range(1) == 1) benchmark::DoNotOptimize(EstimatorStabilityRegion(plant, e, grid).alpha_max());
        if (state.range(1) == 0) {
            benchmark::DoNotOptimize(region_tip_candidates(test.polynomial(), 16 * test.polynomial().degree()));
        }
    }
}
BENCHMARK(BM_RegionCornerTip)->Args({0, 1})->Args({1, 1})->Args({1, 0})->Unit(benchmark::kMicrosecond);

// The parts of the fast CE2 optimum with the estimator (d = range(1)): 0 = the main region on the fast
// method's 16 x 16 scan (EstimatorStabilityRegion with kFastOptimumRegionGrid), 1 = one gradient
// (estimator_energy_cost_gradient) at the optimum's neighbourhood, 2 = one cost (estimator_energy_costs) there,
// 3 = one exact Hessian (estimator_energy_cost_hessian, estimator_hessian.hpp) there.
void BM_EstimatorOptimumParts(benchmark::State& state) {
    const double d = static_cast<double>(state.range(1));
    const NormalizedPlant np{0, 0, d};
    const SampledPlant<double> plant(np);
    const VelocityEstimator e = estimator_for(state.range(0));
    const NormalizedGains g = estimator_gains_for(d);
    const auto part = state.range(2);
    for (auto _ : state) {
        if (part == 0) benchmark::DoNotOptimize(EstimatorStabilityRegion(np, e, kFastOptimumRegionGrid).alpha_max());
        if (part == 1) benchmark::DoNotOptimize(estimator_energy_cost_gradient(plant, e, g.alpha, g.beta, 2));
        if (part == 2) benchmark::DoNotOptimize(estimator_energy_costs(plant, e, g.alpha, g.beta));
        if (part == 3) benchmark::DoNotOptimize(estimator_energy_cost_hessian(plant, e, g.alpha, g.beta, 2));
    }
}
BENCHMARK(BM_EstimatorOptimumParts)->ArgsProduct({{1, 2}, {1, 6}, {0, 1, 2, 3}})->Unit(benchmark::kMicrosecond);

// CE2 under a force-noise budget (noise_budget.hpp), d = 1: half the g_F of the unconstrained optimum (the budget
// binds); the unconstrained optimum is part of the call (compare BM_EstimatorOptimum in the same run).
void BM_NoiseBudgetOptimum(benchmark::State& state) {
    const NormalizedPlant plant{0, 0, static_cast<double>(state.range(1))};
    const VelocityEstimator e = estimator_for(state.range(0));
    const EstimatorOptimum free = optimal_point(Criterion::CE2, plant, e);
    const double budget = 0.5 * force_noise_gain(plant, {free.alpha, free.beta}, e);
    for (auto _ : state) benchmark::DoNotOptimize(optimal_point_under_noise_budget(Criterion::CE2, plant, e, budget));
}
BENCHMARK(BM_NoiseBudgetOptimum)->Args({0, 1})->Args({1, 1})->Args({2, 1})->Unit(benchmark::kMillisecond);

// Every criterion under the shipped Falcon profile's budget (config/devices/falcon.toml: window 15, d = 6, 0.30 kg,
// T = 1 ms, q = 4.85e-5 m, 0.05 N: g_max = 3.436e-3; it binds for amax only), range(0): 0 CE2, 1 amax, 2 CE2+OV,
// 3 OV; CE2's point is the baseline in the same run.
void BM_NoiseBudgetFalconCriteria(benchmark::State& state) {
    const NormalizedPlant plant{0, 0, 6};
    const VelocityEstimator e = VelocityEstimator::moving_window(15);
    const double g_max = 0.05 * 1e-6 / (0.30 * 4.85e-5);
    const Criterion c[] = {Criterion::CE2, Criterion::AlphaMax, Criterion::CE2_OV, Criterion::Overshoot};
    for (auto _ : state) benchmark::DoNotOptimize(optimal_point_under_noise_budget(c[state.range(0)], plant, e, g_max));
}
BENCHMARK(BM_NoiseBudgetFalconCriteria)->DenseRange(0, 3)->Unit(benchmark::kMillisecond);

// The robust CE2 wall of the shipped Falcon profile (mass 0.22 .. 0.30 kg, 6 ms): range(0) 0 the backward difference
// without a budget (the baseline), 1 window 15 without a budget, 2 window 15 with the 0.05 N budget (q = 4.85e-5 m).
void BM_RobustFalcon(benchmark::State& state) {
    UncertainPlant box;
    box.mass = {0.22, 0.30};
    box.period = 1e-3;
    box.time_delay = {0.006, 0.006};
    RobustOptions o;
    if (state.range(0) > 0) o.estimator = VelocityEstimator::moving_window(15);
    if (state.range(0) == 2) {
        o.force_noise_budget = 0.05;
        o.position_resolution = 4.85e-5;
    }
    for (auto _ : state) benchmark::DoNotOptimize(robust_optimum(Criterion::CE2, box, o));
}
BENCHMARK(BM_RobustFalcon)->DenseRange(0, 2)->Unit(benchmark::kMillisecond);

// The describing-function limit cycle (limit_cycles.hpp) of the C_E2 optimum at d = 0, 1, 6 on m = 0.3 kg,
// T = 1 ms, q = 20 um, push half-way between two levels; range(1): Coulomb friction 0 or 0.3 N (with friction
// the plant is re-discretised at every amplitude and frequency). Baseline in the same run: BM_StabilityTest.
void BM_PredictLimitCycle(benchmark::State& state) {
    const double alpha[] = {0.2474, 0.0582, 0.00466432}, beta[] = {0.7445, 0.3796, 0.112281};
    const int delay[] = {0, 1, 6};
    const auto i = static_cast<std::size_t>(state.range(0));
    LimitCycleLoop loop;
    loop.plant = PhysicalPlant{0.3, 0, 0, 1e-3, delay[i] * 1e-3};
    loop.gains = to_physical(NormalizedGains{alpha[i], beta[i]}, 0.3, 1e-3);
    loop.coulomb_friction = state.range(1) == 0 ? 0.0 : 0.3;
    loop.position_step = 20e-6;
    loop.external_force = loop.gains.stiffness * loop.position_step * 100.5;
    for (auto _ : state) benchmark::DoNotOptimize(predict_limit_cycle(loop));
}
BENCHMARK(BM_PredictLimitCycle)
    ->Args({0, 0})
    ->Args({0, 1})
    ->Args({1, 0})
    ->Args({1, 1})
    ->Args({2, 0})
    ->Args({2, 1})
    ->Unit(benchmark::kMillisecond);

// The same with a velocity estimator at d = 6: range(0) 0 low-pass nu = 0.02, 1 window 15, with their CE2 optima
// (docs/velocity-estimation.md, "alpha_max and the CE2 optimum per estimator"); range(1): Coulomb friction 0 or
// 0.3 K q. The window's crossover scan and polynomials grow with N.
void BM_PredictLimitCycleEstimator(benchmark::State& state) {
    const bool window = state.range(0) == 1;
    LimitCycleLoop loop;
    loop.plant = PhysicalPlant{0.3, 0, 0, 1e-3, 6e-3};
    loop.gains =
        to_physical(window ? NormalizedGains{0.00126107, 0.0516488} : NormalizedGains{0.0012874, 0.0549007}, 0.3, 1e-3);
    loop.estimator = window ? VelocityEstimator::moving_window(15) : VelocityEstimator::low_pass(0.02);
    loop.position_step = 20e-6;
    loop.coulomb_friction = state.range(1) == 0 ? 0.0 : 0.3 * loop.gains.stiffness * loop.position_step;
    loop.external_force = loop.gains.stiffness * loop.position_step * 100.5;
    for (auto _ : state) benchmark::DoNotOptimize(predict_limit_cycle(loop));
}
BENCHMARK(BM_PredictLimitCycleEstimator)
    ->Args({0, 0})
    ->Args({0, 1})
    ->Args({1, 0})
    ->Args({1, 1})
    ->Unit(benchmark::kMillisecond);

// All 64 rows of Tables III and IV (8 criteria x 8 plants, one WallOptimizer per plant); arg: the energy
// optima's method (0 newton, the default; 1 brent). Criterion filter: arg 2 = -1 for all eight, else one
// criterion (its 8 rows), to show where the time goes.
void BM_AllTableRows(benchmark::State& state) {
    OptimumOptions o;
    o.method = state.range(0) == 0 ? OptimumMethod::newton : OptimumMethod::brent;
    const auto only = state.range(1);
    for (auto _ : state) {
        for (double d : {0.0, 1.0}) {
            for (double gamma : {0.0, 0.001}) {
                for (double delta : {0.0, 0.02}) {
                    const WallOptimizer opt(NormalizedPlant{gamma, delta, d}, o);
                    for (const Criterion c : kAllCriteria) {
                        if (only < 0 || static_cast<int>(c) == only) benchmark::DoNotOptimize(opt.optimum(c));
                    }
                }
            }
        }
    }
}
BENCHMARK(BM_AllTableRows)
    ->ArgNames({"brent", "criterion"})
    ->ArgsProduct({{0, 1}, {-1, 0, 1, 2, 3, 4, 5, 6, 7}})
    ->Unit(benchmark::kMillisecond)
    ->Iterations(1);

}  // namespace

BENCHMARK_MAIN();
