// SPDX-License-Identifier: Apache-2.0
// One run of the wall: per tick read the device position, compute the scene's force, delay it by the
// delay buffer, apply passivity control, pass it through the force limiter (scene/force_limiter.hpp: saturation
// and the rate limit on the changes the scene makes to the law), write it to the device, trace. Every path out
// of the loop ends with a tick that writes zero force:
//  * a fault (device error, non-finite value, watchdog): zero at once in the tick of the fault, and the loop
//    stops — the one step the rate limit does not bound;
//  * a stop (SIGINT/SIGTERM, the end of --duration): the stop window, ForceLimiter::stop_ticks() = R ticks
//    whose target is zero, the rate limit bringing the force there; the last writes exactly zero. A signal at
//    tick S ends the run after tick S + R - 1; --duration's R last ticks are its stop window (a run of N ticks
//    renders ticks 0 .. N - R - 1), so a replay of N recorded ticks stops where the recorded run did.
#pragma once

#include <cstdint>
#include <string>

#include "hapticd/state_layout.hpp"
#include "scene/delay_ring.hpp"
#include "scene/force_limiter.hpp"
#include "scene/passivity_controller.hpp"
#include "devices/device.hpp"
#include "loop/realtime_loop.hpp"
#include "scene/safety.hpp"
#include "scene/scene.hpp"
#include "server/server_hooks.hpp"
#include "server/state_publisher.hpp"
#include "daemon/recorder.hpp"
#include "daemon/wall_retuner.hpp"
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
    // --replay of a run that ended by a fault (the recording's last tick has one): the last tick zeroes at once
    // as the recorded one did, no stop window before it (a watchdog fault, which lockstep does not detect again,
    // is reproduced so).
    bool end_without_stop_window = false;
    // The force limiter (scene/force_limiter.hpp): 0 takes the scene's max_force and default_max_force_rate.
    double max_force = 0.0;       // N per axis
    double max_force_rate = 0.0;  // N/s
    // --retune (daemon/wall_retuner.hpp): updated after each tick's write, switches the config walls' gains for the
    // next ticks. May be null. Must outlive the daemon.
    WallRetuner* retune = nullptr;
};

struct RunResult {
    LoopCounters counters;
    StateFault fault = StateFault::None;
    SceneFault scene_fault = SceneFault::None;
    DeviceStatus device_status = DeviceStatus::Ok;
    std::uint64_t fault_tick = 0;
    bool stopped_by_signal = false;
    int signal = 0;
    ForceLimiterStats limiter;     // the force written: rate-limited and saturated ticks, the largest step
    std::uint64_t stop_ticks = 0;  // the stop window, ticks (ForceLimiter::stop_ticks)
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
    // The delay buffer holds each tick's force with what the scene changed in its law (the limiter's input).
    struct LawForce {
        AxisVector force{};
        LawChange change{};
    };
    DelayRing<LawForce> delay_;
    ForceLimiter limiter_;
    Watchdog watchdog_;
    // The last tick of the run: max_ticks - 1, or S + R - 1 after a stop request seen at tick S.
    std::uint64_t final_tick_ = ~std::uint64_t{0};
    RunResult result_;
    ServerHooks hooks_;
    // The published record, reused from tick to tick: every field is written before each publish, and a
    // fresh zero-initialised one per tick cost a ~112-byte `rep stos` (~10 ns of a 50 ns tick, perf).
    StateTick state_record_;
    recording::TickChunk record_chunk_;  // --record: likewise reused
};

}  // namespace hapticd
