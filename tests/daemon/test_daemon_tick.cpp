// SPDX-License-Identifier: Apache-2.0
// The loop and the daemon's tick logic (lockstep or scripted devices: no timing assertions).
#include <gtest/gtest.h>

#include <atomic>
#include <cmath>
#include <limits>
#include <thread>
#include <vector>

#include "daemon/daemon.hpp"
#include "loop/realtime_loop.hpp"
#include "scene/safety.hpp"

namespace hapticd {
namespace {

TEST(RealtimeLoop, LockstepRunsConsecutiveTicksUntilStop) {
    RealtimeLoop loop({1'000'000, true});
    std::vector<std::uint64_t> ticks;
    const auto c = loop.run([&](const TickInput& in) -> TickOutput {
        ticks.push_back(in.tick);
        EXPECT_EQ(in.wake_latency_ns, 0);
        EXPECT_DOUBLE_EQ(in.time_s, static_cast<double>(in.tick) * 1e-3);
        return {.stop = in.tick == 99};
    });
    EXPECT_EQ(c.ticks, 100U);
    EXPECT_EQ(c.overruns, 0U);
    ASSERT_EQ(ticks.size(), 100U);
    for (std::uint64_t i = 0; i < 100; ++i) EXPECT_EQ(ticks[i], i);
    EXPECT_EQ(loop.wake_latency().count(), 100U);
    EXPECT_EQ(loop.compute_time().count(), 100U);
}

// 20 ticks of a 0.5 ms loop whose tick 5 works for 2 ms: no tick starts before its deadline, the late
// tick's missed deadlines are skipped by whole periods (the schedule stays aligned) and counted.
void expect_schedule_with_one_overrun(const LoopConfig& config) {
    RealtimeLoop loop(config);
    std::uint64_t last_slot = 0;
    const auto c = loop.run([&](const TickInput& in) -> TickOutput {
        const auto slot = static_cast<std::uint64_t>(std::llround(in.time_s / 0.5e-3));
        if (in.tick > 0) {
            EXPECT_EQ(slot, last_slot + 1 + in.skipped_periods);  // skips are whole periods
        }
        last_slot = slot;
        EXPECT_GE(in.wake_latency_ns, 0);
        if (in.tick == 5) {  // force one overrun: 2 ms of work in a 0.5 ms period
            const auto until = RealtimeLoop::now_ns() + 2'000'000;
            while (RealtimeLoop::now_ns() < until) {
            }
        }
        return {.stop = in.tick == 19};
    });
    EXPECT_EQ(c.ticks, 20U);
    EXPECT_GE(c.overruns, 1U);
    EXPECT_GE(c.skipped_periods, 4U);
    EXPECT_EQ(loop.wake_latency().count(), 20U);
    EXPECT_GE(loop.compute_time().max_ns(), 2'000'000U);
}

TEST(RealtimeLoop, SleepingLoopRecordsStatisticsAndSkipsWholePeriods) {
    expect_schedule_with_one_overrun({500'000, false});
}

// With spin_ns the loop sleeps until spin_ns before each deadline and busy-waits the rest: the same
// schedule, and no tick starts before its deadline (a spin that ended early would show a negative wake
// latency).
TEST(RealtimeLoop, SpinningLoopStartsNoTickEarlyAndSkipsWholePeriods) {
    expect_schedule_with_one_overrun({500'000, false, 400'000});  // spinning the last 0.4 ms
}

TEST(Watchdog, RunOfOverrunsOrStallIsAFault) {
    Watchdog w({3, 10});
    EXPECT_FALSE(w.check(3, 1));
    EXPECT_TRUE(w.check(4, 1));
    EXPECT_FALSE(w.check(0, 10));
    EXPECT_TRUE(w.check(0, 11));
}

// A device replaying scripted positions and recording what it was told.
class ScriptedDevice final : public Device {
  public:
    explicit ScriptedDevice(std::vector<double> positions, std::int64_t fail_write_at = -1)
        : positions_(std::move(positions)), fail_write_at_(fail_write_at) {
        caps_.axes = 1;
        caps_.max_force = 5.0;
    }
    DeviceStatus open() override { return DeviceStatus::Ok; }
    DeviceStatus home() override { return DeviceStatus::Ok; }
    void close() noexcept override { closed = true; }
    DeviceStatus read_position(AxisVector& p) noexcept override {
        p = {positions_[static_cast<std::size_t>(reads_) % positions_.size()], 0.0, 0.0};
        ++reads_;
        return DeviceStatus::Ok;
    }
    DeviceStatus write_force(const AxisVector& f) noexcept override {
        if (fail_write_at_ >= 0 && reads_ - 1 >= fail_write_at_) return DeviceStatus::Timeout;
        forces.push_back(f[0]);
        writes.fetch_add(1);
        return DeviceStatus::Ok;
    }
    const DeviceCapabilities& capabilities() const noexcept override { return caps_; }
    std::string_view name() const noexcept override { return "scripted"; }
    std::string last_error() const override { return "timeout"; }

    std::vector<double> forces;
    std::atomic<std::size_t> writes{0};
    bool closed = false;

  private:
    std::vector<double> positions_;
    std::int64_t fail_write_at_;
    std::int64_t reads_ = 0;
    DeviceCapabilities caps_;
};

Scene one_wall() {
    std::vector<VirtualWall> walls;
    walls.emplace_back(WallGeometry{0, 0.0, 1.0, WallMode::Bilateral}, 1000.0, 1.0, 1e-3);
    return Scene(std::move(walls), 1, 5.0);
}

DaemonConfig lockstep_config(std::uint64_t ticks, std::size_t delay) {
    DaemonConfig c;
    c.loop = {1'000'000, true};
    c.max_ticks = ticks;
    c.delay_samples = delay;
    c.watchdog_enabled = false;
    return c;
}

TEST(Daemon, DelayBufferAndZeroForceOnTheLastTick) {
    clear_stop_request();
    ScriptedDevice dev({0.001, 0.002, 0.003, 0.004, 0.005, 0.006});
    Scene scene = one_wall();
    Daemon d(dev, scene, nullptr, lockstep_config(6, 2));
    const RunResult r = d.run();
    EXPECT_EQ(r.fault, StateFault::None);
    EXPECT_EQ(r.counters.ticks, 6U);
    ASSERT_EQ(dev.forces.size(), 6U);
    // forces computed at ticks 0..: -(1000 x_j + 1 (x_j - x_{j-1})/T), applied 2 ticks later
    EXPECT_EQ(dev.forces[0], 0.0);
    EXPECT_EQ(dev.forces[1], 0.0);
    EXPECT_DOUBLE_EQ(dev.forces[2], -(1.0 + 0.0));  // tick 0: x_{-1} = x_0
    EXPECT_DOUBLE_EQ(dev.forces[3], -(2.0 + 1.0));  // tick 1
    EXPECT_DOUBLE_EQ(dev.forces[4], -(3.0 + 1.0));  // tick 2
    EXPECT_EQ(dev.forces[5], 0.0);                  // last tick: zero
}

TEST(Daemon, StopRequestGivesZeroForceOnTheNextTick) {
    clear_stop_request();
    ScriptedDevice dev({0.001});
    Scene scene = one_wall();
    DaemonConfig cfg = lockstep_config(0, 0);
    Daemon d(dev, scene, nullptr, cfg);
    // Unlimited run: request the stop from "outside" after a few ticks via a scripted position count.
    std::thread stopper([&] {
        while (dev.writes.load() < 3) std::this_thread::yield();
        request_stop(15);
    });
    const RunResult r = d.run();
    stopper.join();
    EXPECT_TRUE(r.stopped_by_signal);
    EXPECT_EQ(r.signal, 15);
    EXPECT_EQ(r.fault, StateFault::None);
    ASSERT_FALSE(dev.forces.empty());
    EXPECT_EQ(dev.forces.back(), 0.0);
    clear_stop_request();
}

TEST(Daemon, NonFinitePositionGivesZeroForceFaultAndStop) {
    clear_stop_request();
    ScriptedDevice dev({0.001, 0.002, std::numeric_limits<double>::quiet_NaN(), 0.001});
    Scene scene = one_wall();
    Daemon d(dev, scene, nullptr, lockstep_config(100, 0));
    const RunResult r = d.run();
    EXPECT_EQ(r.fault, StateFault::NonFinite);
    EXPECT_EQ(r.scene_fault, SceneFault::NonFinitePosition);
    EXPECT_EQ(r.fault_tick, 2U);
    EXPECT_EQ(r.counters.ticks, 3U);
    ASSERT_EQ(dev.forces.size(), 3U);
    EXPECT_EQ(dev.forces.back(), 0.0);
}

TEST(Daemon, DeviceWriteErrorStopsWithDeviceFault) {
    clear_stop_request();
    ScriptedDevice dev({0.001}, 4);
    Scene scene = one_wall();
    Daemon d(dev, scene, nullptr, lockstep_config(100, 0));
    const RunResult r = d.run();
    EXPECT_EQ(r.fault, StateFault::Device);
    EXPECT_EQ(r.device_status, DeviceStatus::Timeout);
    EXPECT_EQ(r.counters.ticks, 5U);
}

}  // namespace
}  // namespace hapticd
