// SPDX-License-Identifier: Apache-2.0
// The loop and the daemon's tick logic (lockstep or scripted devices: no timing assertions).
#include <gtest/gtest.h>

#include <atomic>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include "daemon/daemon.hpp"
#include "loop/realtime_loop.hpp"
#include "scene/force_limiter.hpp"
#include "scene/scene_objects.hpp"
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

// The limiter's rate at its largest for this device (step 4.999 N < max_force 5 N): R = ceil(5 / 4.999) + 1 = 3.
DaemonConfig unlimited_config(std::uint64_t ticks, std::size_t delay) {
    DaemonConfig c = lockstep_config(ticks, delay);
    c.max_force_rate = 4999.0;
    return c;
}

TEST(Daemon, DelayBufferAndTheStopWindowOfTheLastTicks) {
    clear_stop_request();
    ScriptedDevice dev({0.001, 0.002, 0.003, 0.004, 0.0045, 0.004, 0.003, 0.002});
    Scene scene = one_wall();
    Daemon d(dev, scene, nullptr, unlimited_config(8, 2));
    const RunResult r = d.run();
    EXPECT_EQ(r.fault, StateFault::None);
    EXPECT_EQ(r.stop_ticks, 3U);
    EXPECT_EQ(r.counters.ticks, 8U);
    ASSERT_EQ(dev.forces.size(), 8U);
    // forces computed at ticks 0..: -(1000 x_j + 1 (x_j - x_{j-1})/T), applied 2 ticks later
    EXPECT_EQ(dev.forces[0], 0.0);
    EXPECT_EQ(dev.forces[1], 0.0);
    EXPECT_DOUBLE_EQ(dev.forces[2], -(1.0 + 0.0));  // tick 0: x_{-1} = x_0
    EXPECT_DOUBLE_EQ(dev.forces[3], -(2.0 + 1.0));  // tick 1
    EXPECT_DOUBLE_EQ(dev.forces[4], -(3.0 + 1.0));  // tick 2
    // Ticks 5, 6, 7: the stop window, target zero, 4 N reached in one step of at most 4.999 N.
    EXPECT_EQ(dev.forces[5], 0.0);
    EXPECT_EQ(dev.forces[6], 0.0);
    EXPECT_EQ(dev.forces[7], 0.0);  // the last tick: zero
}

// The handle held 10 mm into the wall (10 N asked, saturated to 5 N) under the default rate: max_force per
// 4 ms, 1.25 N per tick. The force rises by 1.25 N per tick, stays at 5 N, and the last R = 5 ticks bring it
// to zero by the same steps; no step anywhere exceeds 1.25 N.
TEST(Daemon, TheDefaultRateBoundsEveryStepUpAndDownAtTheEndOfTheDuration) {
    clear_stop_request();
    ScriptedDevice dev({0.01});
    Scene scene = one_wall();
    Daemon d(dev, scene, nullptr, lockstep_config(60, 0));
    const RunResult r = d.run();
    EXPECT_EQ(r.fault, StateFault::None);
    EXPECT_EQ(r.stop_ticks, 5U);
    ASSERT_EQ(dev.forces.size(), 60U);
    double previous = 0.0;
    for (std::size_t j = 0; j < dev.forces.size(); ++j) {
        EXPECT_LE(std::fabs(dev.forces[j] - previous), 1.25 + 1e-12) << "tick " << j;
        previous = dev.forces[j];
    }
    EXPECT_NEAR(dev.forces[0], -1.25, 1e-12);
    EXPECT_NEAR(dev.forces[3], -5.0, 1e-12);
    EXPECT_NEAR(dev.forces[54], -5.0, 1e-12);   // the last rendered tick (60 - 5 - 1)
    EXPECT_NEAR(dev.forces[55], -3.75, 1e-12);  // the stop window's first
    EXPECT_NEAR(dev.forces[57], -1.25, 1e-12);
    EXPECT_NEAR(dev.forces[58], 0.0, 1e-12);
    EXPECT_EQ(dev.forces[59], 0.0);
    // 3 up and 3 down (the 4th step of each, exactly 1.25 N, is limited or not by the step's rounding).
    EXPECT_GE(r.limiter.rate_limited_ticks, 6U);
    EXPECT_LE(r.limiter.rate_limited_ticks, 8U);
    EXPECT_NEAR(r.limiter.largest_step, 1.25, 1e-12);
}

TEST(Daemon, StopRequestRampsTheForceToZeroInTheStopWindow) {
    clear_stop_request();
    ScriptedDevice dev({0.01});
    Scene scene = one_wall();
    DaemonConfig cfg = lockstep_config(0, 0);
    Daemon d(dev, scene, nullptr, cfg);
    // Unlimited run: request the stop from "outside" once the force is saturated.
    std::thread stopper([&] {
        while (dev.writes.load() < 20) std::this_thread::yield();
        request_stop(15);
    });
    const RunResult r = d.run();
    stopper.join();
    EXPECT_TRUE(r.stopped_by_signal);
    EXPECT_EQ(r.signal, 15);
    EXPECT_EQ(r.fault, StateFault::None);
    ASSERT_GE(dev.forces.size(), 20U + 5U);
    EXPECT_EQ(dev.forces.back(), 0.0);
    // The last 5 ticks are the stop window; the force was saturated before it; no step above 1.25 N.
    const std::size_t n = dev.forces.size();
    EXPECT_NEAR(dev.forces[n - 6], -5.0, 1e-12);
    EXPECT_NEAR(dev.forces[n - 5], -3.75, 1e-12);
    double previous = 0.0;
    for (const double f : dev.forces) {
        EXPECT_LE(std::fabs(f - previous), 1.25 + 1e-12);
        previous = f;
    }
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

// Hands the loop batches at given ticks (as --replay does, through the TickFeeder hook).
class CommitFeeder final : public TickFeeder {
  public:
    explicit CommitFeeder(CommitRing& ring) : ring_(ring) {}
    void at(std::uint64_t tick, const ObjectCommit& commit) { batches_.emplace_back(tick, commit); }
    void before_commits(std::uint64_t tick) noexcept override {
        for (const auto& [t, c] : batches_) {
            if (t == tick) (void)ring_.try_push(c);
        }
    }

  private:
    CommitRing& ring_;
    std::vector<std::pair<std::uint64_t, ObjectCommit>> batches_;
};

// A client's spring pulls the handle with 4 N; at tick 30 its departure cuts it at once (SlotUpdate::Cut, no
// ramp). The force written (the objects neither saturate nor rate-limit their sum) still
// changes by at most the limiter's 1.25 N per tick (the default for 5 N): 4 -> 2.75 -> 1.5 -> 0.25 -> 0, and
// the same on the way up.
TEST(Daemon, ACutDepartureStepsTheForceWrittenByAtMostTheRateLimit) {
    clear_stop_request();
    ScriptedDevice dev({0.0});
    Scene scene(std::vector<VirtualWall>{}, 1, 5.0);
    CommitRing ring(8);
    SceneObjectsConfig oc;
    oc.ramp_time = 0.0;
    oc.axes = 1;
    SceneObjects objects(oc, ring);
    ObjectParams spring;
    spring.id = 7;
    spring.kind = ObjectKind::Spring;
    spring.point = {0.004, 0.0, 0.0};
    spring.K = 1000.0;
    ObjectCommit add;
    add.seq = 1;
    add.count = 1;
    add.updates[0] = SlotUpdate{0, SlotUpdate::Action::Set, spring};
    ObjectCommit cut;
    cut.seq = 2;
    cut.count = 1;
    cut.updates[0] = SlotUpdate{0, SlotUpdate::Action::Cut, spring};
    CommitFeeder feeder(ring);
    feeder.at(0, add);
    feeder.at(30, cut);
    DaemonConfig cfg = lockstep_config(60, 0);
    cfg.feeder = &feeder;
    Daemon d(dev, scene, nullptr, cfg);
    d.attach(ServerHooks{&objects, nullptr, nullptr});
    const RunResult r = d.run();
    EXPECT_EQ(r.fault, StateFault::None);
    ASSERT_EQ(dev.forces.size(), 60U);
    EXPECT_NEAR(dev.forces[0], 1.25, 1e-12);
    EXPECT_NEAR(dev.forces[29], 4.0, 1e-12);
    EXPECT_NEAR(dev.forces[30], 2.75, 1e-12);  // the cut: 4 N asked away in one tick
    EXPECT_NEAR(dev.forces[31], 1.5, 1e-12);
    EXPECT_NEAR(dev.forces[32], 0.25, 1e-12);
    EXPECT_EQ(dev.forces[33], 0.0);
    double previous = 0.0;
    for (std::size_t j = 0; j < dev.forces.size(); ++j) {
        EXPECT_LE(std::fabs(dev.forces[j] - previous), 1.25 + 1e-12) << "tick " << j;
        previous = dev.forces[j];
    }
}

// The force limiter is the one stage that saturates: it saturates the total (config walls plus the clients'
// objects), not the walls' sum first. The handle 2 mm into a bilateral wall of 10 kN/m (20 N asked, pushing out)
// while a client's spring pulls it 8 N the other way: the total, -12 N, is written saturated to -5 N (the walls'
// sum saturated first, -5 + 8 = 3 N, was written before the limiter became the only stage).
TEST(Daemon, TheForceLimiterSaturatesTheTotalOfWallsAndObjects) {
    clear_stop_request();
    ScriptedDevice dev({0.002});
    std::vector<VirtualWall> walls;
    walls.emplace_back(WallGeometry{0, 0.0, 1.0, WallMode::Bilateral}, 1e4, 0.0, 1e-3);
    Scene scene(std::move(walls), 1, 5.0);
    CommitRing ring(8);
    SceneObjectsConfig oc;
    oc.ramp_time = 0.0;
    oc.axes = 1;
    SceneObjects objects(oc, ring);
    ObjectParams spring;
    spring.id = 7;
    spring.kind = ObjectKind::Spring;
    spring.point = {0.010, 0.0, 0.0};
    spring.K = 1000.0;
    ObjectCommit add;
    add.seq = 1;
    add.count = 1;
    add.updates[0] = SlotUpdate{0, SlotUpdate::Action::Set, spring};
    CommitFeeder feeder(ring);
    feeder.at(0, add);
    DaemonConfig cfg = lockstep_config(40, 0);
    cfg.feeder = &feeder;
    Daemon d(dev, scene, nullptr, cfg);
    d.attach(ServerHooks{&objects, nullptr, nullptr});
    const RunResult r = d.run();
    EXPECT_EQ(r.fault, StateFault::None);
    ASSERT_EQ(dev.forces.size(), 40U);
    EXPECT_EQ(dev.forces[30], -5.0);
    EXPECT_GT(r.limiter.saturated_ticks, 25U);
}

// A fault is the exception to the rate limit: the force goes from 5 N to zero in the tick of the fault.
TEST(Daemon, AFaultZeroesTheForceAtOnce) {
    clear_stop_request();
    std::vector<double> positions(30, 0.01);
    positions.push_back(std::numeric_limits<double>::quiet_NaN());
    ScriptedDevice dev(positions);
    Scene scene = one_wall();
    Daemon d(dev, scene, nullptr, lockstep_config(100, 0));
    const RunResult r = d.run();
    EXPECT_EQ(r.fault, StateFault::NonFinite);
    EXPECT_EQ(r.fault_tick, 30U);
    ASSERT_EQ(dev.forces.size(), 31U);
    EXPECT_NEAR(dev.forces[29], -5.0, 1e-12);
    EXPECT_EQ(dev.forces[30], 0.0);
}

// A rate whose step per tick is max_force or more is refused, naming --max-force-rate and the range.
TEST(ForceLimiter, ARateStepOfTheWholeForceLimitIsRefusedNamingTheRange) {
    EXPECT_DOUBLE_EQ(default_max_force_rate(9.0, 1e-3), 2250.0);  // the Falcon: 9 N in 4 ms
    EXPECT_DOUBLE_EQ(default_max_force_rate(10.0, 0.05), 50.0);   // 20 Hz: a quarter of 10 N per tick
    EXPECT_EQ(max_force_rate_error(2250.0, 9.0, 1e-3), "");
    const std::string e = max_force_rate_error(10000.0, 10.0, 1e-3);
    EXPECT_NE(e.find("--max-force-rate = 10000"), std::string::npos) << e;
    EXPECT_NE(e.find("accepted range: > 0 and < max_force / T = 10000 N/s"), std::string::npos) << e;
    EXPECT_NE(max_force_rate_error(-1.0, 10.0, 1e-3), "");
    EXPECT_NE(max_force_rate_error(std::numeric_limits<double>::infinity(), 10.0, 1e-3), "");
    EXPECT_THROW(ForceLimiter(10.0, 10000.0, 1e-3, 3), std::invalid_argument);
    ForceLimiter l(10.0, 1000.0, 1e-3, 3);
    EXPECT_EQ(l.stop_ticks(), 11U);
    // The change is scaled as a whole: direction kept, infinity norm 1 N.
    const AxisVector f = l.step({4.0, -2.0, 0.0}, LawChange::whole_change());
    EXPECT_DOUBLE_EQ(f[0], 1.0);
    EXPECT_DOUBLE_EQ(f[1], -0.5);
    // Saturation per axis first (40 N -> 10 N), then the rate limit.
    const AxisVector g = l.step({40.0, -0.5, 0.0}, LawChange::whole_change());
    EXPECT_DOUBLE_EQ(g[0], 2.0);
    EXPECT_DOUBLE_EQ(g[1], -0.5);
    EXPECT_EQ(l.stats().saturated_ticks, 1U);
    EXPECT_EQ(l.stats().rate_limited_ticks, 2U);
    l.zero();
    EXPECT_EQ(l.last(), AxisVector{});
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
