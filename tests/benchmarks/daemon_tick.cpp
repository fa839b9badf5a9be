// hapticd benchmarks.
//  * BM_TickCompute: one tick of the real-time path without sleeping: simulated plant (exact ZOH step),
//    one bilateral wall, a delay buffer of 4 samples, saturation/finiteness checks, force write.
//  * BM_TickComputePercentiles: the same, each tick timed individually (clock_gettime around it, ~20-30 ns
//    of the figure is the clock itself) into the daemon's histogram: p50/p99/p99.9/max counters.
//  * BM_WakeLatency: in the same run, the wake-up latency of a bare clock_nanosleep(TIMER_ABSTIME) loop
//    and of hapticd's RealtimeLoop doing the full tick, both at 1 kHz for 2 s each (HAPTICD_LATENCY_SECONDS=60
//    for the cyclictest-style long run), p50/p99/p99.9/max, overruns of both, and their ratio.
//    SCHED_FIFO/mlockall are tried first (counter fifo = 1 when granted).
#include <benchmark/benchmark.h>

#include <cstdlib>
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

void BM_WakeLatency(benchmark::State& state) {
    constexpr std::int64_t period = 1'000'000;
    const char* seconds_env = std::getenv("HAPTICD_LATENCY_SECONDS");
    const double seconds = seconds_env != nullptr ? std::atof(seconds_env) : 2.0;
    const int ticks = seconds > 0 ? static_cast<int>(seconds * 1000.0) : 2000;
    const RealtimeReport rt = apply_realtime({80, true, -1});
    for (auto _ : state) {
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
    }
    state.counters["fifo"] = rt.fifo ? 1.0 : 0.0;
}
BENCHMARK(BM_WakeLatency)->Iterations(1)->Unit(benchmark::kMillisecond);

}  // namespace
