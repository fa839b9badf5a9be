// SPDX-License-Identifier: Apache-2.0
// hapticd benchmarks.
//  * BM_TickCompute: one tick of the real-time path without sleeping: simulated plant (exact ZOH step),
//    one bilateral wall, a delay buffer of 4 samples, saturation/finiteness checks, force write.
//  * BM_TickComputePercentiles: the same, each tick timed individually (clock_gettime around it, ~20-30 ns
//    of the figure is the clock itself) into the daemon's histogram: p50/p99/p99.9/max counters.
//  * BM_WakeLatency: in the same run, the wake-up latency of a bare clock_nanosleep(TIMER_ABSTIME) loop
//    and of hapticd's RealtimeLoop doing the full tick, both at 1 kHz for 2 s each (HAPTICD_LATENCY_SECONDS=60
//    for the cyclictest-style long run), p50/p99/p99.9/max, overruns of both, and their ratio; and, in the
//    same run before them, Debian's cyclictest (rt-tests) with the same priority (SCHED_FIFO 80), period
//    (1000 us), number of ticks and mlockall (-m), one thread, its latency histogram (-h, 1 us bins)
//    giving cyclictest_p50/p99/p99.9/max and cyclictest_overruns (samples >= one period late, the rule
//    of the other two). cyclictest_ran = 0 when cyclictest is not installed or could not run.
//    SCHED_FIFO/mlockall are tried first (counter fifo = 1 when granted).
#include <benchmark/benchmark.h>

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include "scene/delay_ring.hpp"
#include "devices/sim_device.hpp"
#include "loop/realtime_loop.hpp"
#include "loop/realtime_setup.hpp"
#include "scene/scene.hpp"
#include "loop/stats.hpp"

namespace {

using namespace hapticd;

struct TickRig {
    SimDevice device;
    Scene scene;
    DelayRing<AxisVector> delay{4};

    static SimDeviceConfig device_config() {
        SimDeviceConfig c;
        c.capabilities.axes = 1;
        c.capabilities.max_force = 10.0;
        c.plant = {0.3, 6.0, 300.0};
        c.period = 1e-3;
        c.scenario.kind = Scenario::Step;
        return c;
    }
    static Scene make_scene() {
        std::vector<VirtualWall> walls;
        walls.emplace_back(WallGeometry{0, 0.0, 1.0, WallMode::Bilateral}, 18000.0, 110.0, 1e-3);  // stable at d = 4
        return Scene(std::move(walls), 1, 10.0);
    }
    TickRig() : device(device_config()), scene(make_scene()) { device.open(); }

    double tick() noexcept {
        AxisVector p{};
        AxisVector f{};
        device.read_position(p);
        scene.evaluate(p, f);
        const AxisVector applied = delay.push_pop(f);
        device.write_force(applied);
        return p[0];
    }
};

void BM_TickCompute(benchmark::State& state) {
    TickRig rig;
    for (auto _ : state) {
        benchmark::DoNotOptimize(rig.tick());
    }
}
BENCHMARK(BM_TickCompute);

void BM_TickComputePercentiles(benchmark::State& state) {
    TickRig rig;
    LatencyStats stats;
    for (auto _ : state) {
        const auto t0 = RealtimeLoop::now_ns();
        benchmark::DoNotOptimize(rig.tick());
        stats.record(RealtimeLoop::now_ns() - t0);
    }
    state.counters["p50_ns"] = static_cast<double>(stats.percentile_ns(0.5));
    state.counters["p99_ns"] = static_cast<double>(stats.percentile_ns(0.99));
    state.counters["p99.9_ns"] = static_cast<double>(stats.percentile_ns(0.999));
    state.counters["max_ns"] = static_cast<double>(stats.max_ns());
}
BENCHMARK(BM_TickComputePercentiles);

void report(benchmark::State& state, const char* prefix, const LatencyStats& s) {
    const std::string p(prefix);
    state.counters[p + "_mean_us"] = s.mean_ns() * 1e-3;
    state.counters[p + "_p50_us"] = static_cast<double>(s.percentile_ns(0.50)) * 1e-3;
    state.counters[p + "_p99_us"] = static_cast<double>(s.percentile_ns(0.99)) * 1e-3;
    state.counters[p + "_p99.9_us"] = static_cast<double>(s.percentile_ns(0.999)) * 1e-3;
    state.counters[p + "_max_us"] = static_cast<double>(s.max_ns()) * 1e-3;
}

// cyclictest's histogram: "LATENCY_US COUNT" lines, then "# Max Latencies: N" and "# Histogram Overflows: N".
struct CyclictestResult {
    bool ran = false;
    std::vector<std::uint64_t> histogram;  // samples per us of latency
    std::uint64_t overflows = 0;           // beyond the histogram range
    std::uint64_t max_us = 0;
    std::uint64_t total = 0;
    [[nodiscard]] double percentile_us(double q) const {
        const auto wanted = static_cast<std::uint64_t>(q * static_cast<double>(total) + 0.5);
        std::uint64_t seen = 0;
        for (std::size_t us = 0; us < histogram.size(); ++us) {
            seen += histogram[us];
            if (seen >= wanted) return static_cast<double>(us);
        }
        return static_cast<double>(max_us);
    }
    [[nodiscard]] std::uint64_t at_least(std::size_t us) const {
        std::uint64_t n = overflows;
        for (std::size_t i = us; i < histogram.size(); ++i) n += histogram[i];
        return n;
    }
};

CyclictestResult run_cyclictest(int ticks, int priority, std::int64_t period_ns) {
    CyclictestResult r;
    constexpr int kRangeUs = 100000;  // 100 ms of histogram; longer stalls count as overflows
    const std::string command = "cyclictest -m -t1 -q -p " + std::to_string(priority) + " -i " +
                                std::to_string(period_ns / 1000) + " -l " + std::to_string(ticks) + " -h " +
                                std::to_string(kRangeUs) + " 2>/dev/null";
    FILE* pipe = popen(command.c_str(), "r");
    if (pipe == nullptr) return r;
    r.histogram.assign(kRangeUs + 1, 0);
    char line[256];
    while (std::fgets(line, sizeof line, pipe) != nullptr) {
        unsigned long long a = 0, b = 0;
        if (line[0] != '#' && std::sscanf(line, "%llu %llu", &a, &b) == 2 && a < r.histogram.size()) {
            r.histogram[a] += b;
            r.total += b;
        } else if (std::sscanf(line, "# Max Latencies: %llu", &a) == 1) {
            r.max_us = a;
        } else if (std::sscanf(line, "# Histogram Overflows: %llu", &a) == 1) {
            r.overflows = a;
        }
    }
    r.total += r.overflows;
    r.ran = pclose(pipe) == 0 && r.total > 0;
    return r;
}

void BM_WakeLatency(benchmark::State& state) {
    constexpr std::int64_t period = 1'000'000;
    const char* seconds_env = std::getenv("HAPTICD_LATENCY_SECONDS");
    const double seconds = seconds_env != nullptr ? std::atof(seconds_env) : 2.0;
    const int ticks = seconds > 0 ? static_cast<int>(seconds * 1000.0) : 2000;
    const RealtimeReport rt = apply_realtime({80, true, -1});
    for (auto _ : state) {
        const CyclictestResult ct = run_cyclictest(ticks, 80, period);
        LatencyStats bare;
        std::uint64_t bare_overruns = 0;  // wake-ups after the next deadline (same rule as the loop)
        std::int64_t deadline = RealtimeLoop::now_ns() + period;
        for (int i = 0; i < ticks; ++i) {
            RealtimeLoop::sleep_until(deadline);
            const std::int64_t late = RealtimeLoop::now_ns() - deadline;
            bare.record(late);
            if (late >= period) {
                ++bare_overruns;
                deadline += (late / period) * period;  // skip whole periods, like RealtimeLoop
            }
            deadline += period;
        }
        TickRig rig;
        RealtimeLoop loop({period, false});
        loop.run([&](const TickInput& in) -> TickOutput {
            benchmark::DoNotOptimize(rig.tick());
            return {.stop = in.tick + 1 >= static_cast<std::uint64_t>(ticks)};
        });
        report(state, "bare", bare);
        report(state, "loop", loop.wake_latency());
        state.counters["ratio_mean"] = loop.wake_latency().mean_ns() / bare.mean_ns();
        state.counters["ratio_p99"] = static_cast<double>(loop.wake_latency().percentile_ns(0.99)) /
                                      static_cast<double>(bare.percentile_ns(0.99));
        state.counters["loop_overruns"] = static_cast<double>(loop.counters().overruns);
        state.counters["bare_overruns"] = static_cast<double>(bare_overruns);
        state.counters["ticks"] = static_cast<double>(ticks);
        state.counters["cyclictest_ran"] = ct.ran ? 1.0 : 0.0;
        if (ct.ran) {
            state.counters["cyclictest_p50_us"] = ct.percentile_us(0.50);
            state.counters["cyclictest_p99_us"] = ct.percentile_us(0.99);
            state.counters["cyclictest_p99.9_us"] = ct.percentile_us(0.999);
            state.counters["cyclictest_max_us"] = static_cast<double>(ct.max_us);
            state.counters["cyclictest_overruns"] =
                static_cast<double>(ct.at_least(static_cast<std::size_t>(period / 1000)));
            state.counters["ratio_p99_loop_cyclictest"] = static_cast<double>(loop.wake_latency().percentile_ns(0.99)) *
                                                          1e-3 / std::max(1.0, ct.percentile_us(0.99));
        } else {
            state.SetLabel("cyclictest (rt-tests) not run: not installed or no permission for SCHED_FIFO");
        }
    }
    state.counters["fifo"] = rt.fifo ? 1.0 : 0.0;
}
BENCHMARK(BM_WakeLatency)->Iterations(1)->Unit(benchmark::kMillisecond);

}  // namespace
