// SPDX-License-Identifier: Apache-2.0
// One run of the wall: per tick read the device position, compute the scene's force, delay it by the
// delay buffer, write it to the device, trace. Every path out of the loop ends with a tick that writes
// zero force: the last tick of --duration, the tick after SIGINT/SIGTERM, and the tick of a fault
// (device error, non-finite value, watchdog), after which the loop stops.
#pragma once

#include <cstdint>
#include <string>

#include "hapticd/state_layout.hpp"
#include "scene/delay_ring.hpp"
#include "scene/passivity_controller.hpp"
#include "devices/device.hpp"
#include "loop/realtime_loop.hpp"
#include "scene/safety.hpp"
#include "scene/scene.hpp"
#include "server/server_hooks.hpp"
#include "server/state_publisher.hpp"
#include "daemon/recorder.hpp"
#include "loop/trace.hpp"

namespace hapticd {

// --replay (daemon/replay.hpp): called at the start of every tick, before the objects' apply_commits, to hand
// the loop the batches it took at that tick in the recording. Real-time rules apply.
class TickFeeder {
  public:
    virtual void before_commits(std::uint64_t tick) noexcept = 0;

  protected:
    TickFeeder() = default;
    TickFeeder(const TickFeeder&) = default;
    TickFeeder& operator=(const TickFeeder&) = default;
    ~TickFeeder() = default;
};

struct DaemonConfig {
    LoopConfig loop;
    std::uint64_t max_ticks = 0;    // 0: until stopped
    std::size_t delay_samples = 0;  // the delay buffer N
    WatchdogConfig watchdog;
    bool watchdog_enabled = true;  // off in lockstep (no deadlines)
    std::size_t trace_axis = 0;
    // --passivity-control (scene/passivity_controller.hpp): applied to the force after the delay buffer; may be
    // null. Must outlive the daemon.
    PassivityController* passivity = nullptr;
    // --record (daemon/recorder.hpp): every tick's state; the batches come through SceneObjects' observer. May be null.
    Recorder* recorder = nullptr;
    // --replay: may be null.
    TickFeeder* feeder = nullptr;
};

struct RunResult {
    LoopCounters counters;
    StateFault fault = StateFault::None;
    SceneFault scene_fault = SceneFault::None;
    DeviceStatus device_status = DeviceStatus::Ok;
    std::uint64_t fault_tick = 0;
    bool stopped_by_signal = false;
    int signal = 0;
};

class Daemon {
  public:
    // Device, scene and trace (may be null) must outlive the daemon. The device must be open and homed.
    Daemon(Device& device, Scene& scene, TraceWriter* trace, const DaemonConfig& config);

    RunResult run() noexcept;

    // Before run(): render the clients' objects and publish the state (both must outlive the daemon).
    void attach(const ServerHooks& hooks) noexcept { hooks_ = hooks; }

    [[nodiscard]] const RealtimeLoop& loop() const noexcept { return loop_; }

  private:
    TickOutput tick(const TickInput& in) noexcept;

    Device& device_;
    Scene& scene_;
    TraceWriter* trace_;
    DaemonConfig config_;
    RealtimeLoop loop_;
    DelayRing<AxisVector> delay_;
    Watchdog watchdog_;
    RunResult result_;
    ServerHooks hooks_;
    // The published record, reused from tick to tick: every field is written before each publish, and a
    // fresh zero-initialised one per tick cost a ~112-byte `rep stos` (~10 ns of a 50 ns tick, perf).
    StateTick state_record_;
    recording::TickChunk record_chunk_;  // --record: likewise reused
};

}  // namespace hapticd
