// SPDX-License-Identifier: Apache-2.0
// The arm's verdict over the plant set (docs/robust-stability.md, "The arm"): sampled against certified, in the same
// run. The shipped Falcon's loop: window 15 at 1 kHz, 0.30 kg, the masses 0.200 .. 0.330 kg (s = 0.30 / m), the arms
// of Hulin et al. 2011 eq. 2 (k_H / m <= 1000 s^-2, b_H / m <= 20 s^-1: gamma_H <= 0.001, delta_H <= 0.02).
//  * BM_ArmGridSampled: the grid {0, 1/2, 1}^2 of the arm box, exact along the mass at each arm
//    (MassScalingTest::over) and, with the delay range, DelayRangeTest::over at each arm (estimated with an arm): the
//    verdict GainChecker took over the arm before it was certified.
//  * BM_ArmBoxCertified: ArmBoxTest::over, every arm, mass and delay (arm_box_stability.hpp); counter `boxes`.
// Arguments: delays 0: the total delay 6 periods alone, 1: 5 .. 7 periods (the shipped profile's range); gains 0: half
// the CE2 optimum for 0.30 kg (K 189.2 N/m, B 7.747 N s/m), 1: amax over the set with the delays 5 .. 7 ms (K 455.7
// N/m, B 7.107 N s/m, docs/robust-stability.md: a plant of the box within 0.1 % of the boundary).
//  * BM_NearFreeEdge: ArmBoxTest::segment_over of the longest edge of the numerical range's hull in the first tick of a
//    plane's ramp beside a wall (0.30 kg, backward difference, the masses 0.2727 .. 0.33 kg; from the soft corner
//    (alpha, beta) = (1.78e-7, 5.05e-5), roots near z = 1, to the stiff one (0.2249, 0.5431)) on four boxes: box 0 one
//    plant (no arm, no delay range), 1: gamma_H <= 1e-4, 2: delta_H <= 2e-3, 3: the arm of eq. 2 with the delays
//    0 .. 0.3 periods; 256 sub-boxes at most (the daemon's budget). Counters `stable` (1: proven) and `boxes`.
#include <benchmark/benchmark.h>

#include <hapticopt/arm_box_stability.hpp>
#include <hapticopt/delay_range_stability.hpp>
#include <hapticopt/mass_scaling_stability.hpp>
#include <stdexcept>
#include <utility>
#include <vector>

namespace {

struct ArmCase {
    double alpha = 0.0, beta = 0.0, d_lo = 6.0, d_hi = 6.0;
    static constexpr double s_lo = 0.30 / 0.33, s_hi = 0.30 / 0.20;
    hapticopt::VelocityEstimator estimator = hapticopt::VelocityEstimator::moving_window(15);
};

ArmCase arm_case(const benchmark::State& state) {
    ArmCase c;
    const bool delays = state.range(0) != 0, amax = state.range(1) != 0;
    const double K = amax ? 455.7 : 0.5 * 378.3, B = amax ? 7.107 : 0.5 * 15.49;
    c.alpha = K * 1e-6 / 0.30;
    c.beta = B * 1e-3 / 0.30;
    if (delays) {
        c.d_lo = 5.0;
        c.d_hi = 7.0;
    }
    return c;
}

void BM_ArmGridSampled(benchmark::State& state) {
    const ArmCase c = arm_case(state);
    std::vector<hapticopt::MassScalingTest> rays;
    std::vector<hapticopt::DelayRangeTest> delays;
    for (const double gamma : {0.0, 0.0005, 0.001}) {
        for (const double delta : {0.0, 0.01, 0.02}) {
            const hapticopt::NormalizedPlant p{gamma, delta, 6.0};
            rays.emplace_back(p, c.estimator, hapticopt::ArmAlongRay::per_mass);
            if (c.d_hi > c.d_lo) delays.emplace_back(p, c.estimator, c.d_lo, c.d_hi);
        }
    }
    for (auto _ : state) {
        bool stable = true;
        for (std::size_t a = 0; a < rays.size() && stable; ++a) {
            stable = rays[a].over(c.alpha, c.beta, c.s_lo, c.s_hi).stable &&
                     (delays.empty() || delays[a].over(c.alpha, c.beta, c.s_lo, c.s_hi).stable);
        }
        if (!stable) throw std::logic_error("benchmark gains not stable on the grid");
        benchmark::DoNotOptimize(stable);
    }
}

void BM_ArmBoxCertified(benchmark::State& state) {
    const ArmCase c = arm_case(state);
    const hapticopt::ArmBoxTest test(hapticopt::NormalizedPlant{0, 0, 0}, c.estimator, 0.001, 0.02, c.d_lo, c.d_hi);
    int boxes = 0;
    for (auto _ : state) {
        const hapticopt::ArmBoxStability v = test.over(c.alpha, c.beta, c.s_lo, c.s_hi);
        if (!v.stable) throw std::logic_error("benchmark gains not certified");
        boxes = v.boxes;
        benchmark::DoNotOptimize(v);
    }
    state.counters["boxes"] = boxes;
}

void BM_NearFreeEdge(benchmark::State& state) {
    const double boxes[4][4] = {{0, 0, 0, 0}, {1e-4, 0, 0, 0}, {0, 2e-3, 0, 0}, {1e-3, 0.02, 0, 0.3}};
    const double* b = boxes[state.range(0)];
    const hapticopt::ArmBoxTest test(hapticopt::NormalizedPlant{0, 0, 0}, hapticopt::VelocityEstimator{}, b[0], b[1],
                                     b[2], b[3]);
    const hapticopt::GainSegment edge = hapticopt::GainSegment::between(1.77654e-07, 5.05087e-05, 0.224927, 0.543072);
    hapticopt::ArmBoxStability v;
    for (auto _ : state) {
        v = test.segment_over(edge, 256);
        benchmark::DoNotOptimize(v);
    }
    state.counters["stable"] = v.stable ? 1.0 : 0.0;
    state.counters["boxes"] = v.boxes;
}

void arm_args(benchmark::internal::Benchmark* b) {
    b->ArgNames({"delays", "amax"});
    for (const int delays : {0, 1}) {
        for (const int amax : {0, 1}) b->Args({delays, amax});
    }
    b->Unit(benchmark::kMillisecond);
}

}  // namespace

BENCHMARK(BM_ArmGridSampled)->Apply(arm_args);
BENCHMARK(BM_ArmBoxCertified)->Apply(arm_args);
BENCHMARK(BM_NearFreeEdge)->ArgName("box")->DenseRange(0, 3)->Unit(benchmark::kMillisecond);
BENCHMARK_MAIN();
