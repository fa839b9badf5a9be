// SPDX-License-Identifier: Apache-2.0
// The real-time path: one tick of hapticd's loop (Daemon::tick), the only code of src/daemon/ that runs every
// period. The loop (loop/realtime_loop.hpp) calls it at each deadline, or back to back in lockstep; in order:
//  1. the stop request and the stop window (daemon.hpp);
//  2. --record's tick begins, --replay's feeder hands over this tick's batches, the clients' batches are applied
//     whole (SceneObjects::apply_commits);
//  3. the device's position (a device error is a fault), the watchdog;
//  4. the force: the config walls (Scene::evaluate) plus the clients' objects (SceneObjects::add_forces), checked
//     finite;
//  5. the delay buffer, passivity control (propose);
//  6. the force limiter (scene/force_limiter.hpp), the one stage that saturates and rate-limits the force written
//     (the changes the scene makes to the law, carried through the delay buffer beside the force): a fault zeroes
//     at once, a stop's target is zero;
//  7. write_force, --retune's identifier and gain switch (wall_retuner.hpp: the gains of the forces from the next
//     tick on), then the recording, the shared-memory state and contact events, the trace.
// No allocation, lock, exception or I/O other than the device's (tests/daemon/test_tick_allocation.cpp counts
// the allocations of a busy scene's ticks).
#include "daemon/daemon.hpp"

#include <limits>

#include "scene/scene_objects.hpp"
#include "server/contact_events.hpp"
#include "server/state_publisher.hpp"

namespace hapticd {

TickOutput Daemon::tick(const TickInput& in) noexcept {
    AxisVector position{};
    AxisVector force{};
    const std::uint64_t window = config_.end_without_stop_window ? 1U : limiter_.stop_ticks();
    if (stop_requested() && !result_.stopped_by_signal) {
        result_.stopped_by_signal = true;
        result_.signal = stop_signal();
        if (in.tick + window - 1 < final_tick_) final_tick_ = in.tick + window - 1;
    }
    // The stop window: the R ticks up to and including the final one (all of a run shorter than R).
    const bool stopping = in.tick + window > final_tick_;
    const bool last = in.tick >= final_tick_;

    if (config_.recorder != nullptr) config_.recorder->begin_tick(in.tick);
    if (config_.feeder != nullptr) config_.feeder->before_commits(in.tick);
    if (hooks_.objects != nullptr) hooks_.objects->apply_commits();  // whole batches, at this tick boundary

    DeviceStatus status = device_.read_position(position);
    const DeviceStatus read_status = status;
    if (status != DeviceStatus::Ok && result_.fault == StateFault::None) {
        result_.fault = StateFault::Device;
        result_.device_status = status;
        result_.fault_tick = in.tick;
    }
    if (result_.fault == StateFault::None && config_.watchdog_enabled &&
        watchdog_.check(in.consecutive_overruns, in.skipped_periods)) {
        result_.fault = StateFault::Watchdog;
        result_.fault_tick = in.tick;
    }
    if (result_.fault == StateFault::None) {
        SceneFault sf = scene_.evaluate(position, force);
        if (sf == SceneFault::None && hooks_.objects != nullptr && !hooks_.objects->add_forces(position, force)) {
            sf = SceneFault::NonFiniteForce;
        }
        if (sf != SceneFault::None) {
            result_.fault = StateFault::NonFinite;
            result_.scene_fault = sf;
            result_.fault_tick = in.tick;
        }
    }
    // The delay buffer keeps its timing whatever happens; its output is applied only while all is well. The
    // scene's change of the law travels with the force it belongs to; the config walls' law appears at tick 0.
    LawForce law{force, hooks_.objects != nullptr ? hooks_.objects->law_change() : LawChange{}};
    if (in.tick == 0) law.change.whole = true;
    LawForce out = delay_.push_pop(law);
    AxisVector& delayed = out.force;
    // Passivity control observes the port after the delay buffer and damps what it generated (same tick); it
    // books the force the limiter lets through (commit below).
    const bool passivity = config_.passivity != nullptr && result_.fault == StateFault::None;
    if (passivity) config_.passivity->propose(position, delayed);
    // The force limiter, last: a fault zeroes at once; a stop's target is zero, reached at the rate limit.
    AxisVector applied{};
    if (result_.fault != StateFault::None) {
        limiter_.zero();
    } else {
        applied =
            stopping ? limiter_.step(AxisVector{}, LawChange::whole_change()) : limiter_.step(delayed, out.change);
        if (last) applied = AxisVector{};  // zero already: R steps of max_step reach it from any saturated force
    }
    if (passivity) config_.passivity->commit(applied);

    status = device_.write_force(applied);
    if (status != DeviceStatus::Ok && result_.fault == StateFault::None) {
        result_.fault = StateFault::Device;
        result_.device_status = status;
        result_.fault_tick = in.tick;
    }
    // --retune: the identifier sees the force written; a switch changes the walls' gains from the next tick on (the
    // forces in the delay buffer keep theirs). Not in the stop window or after a fault (the force is not the law's).
    if (config_.retune != nullptr && result_.fault == StateFault::None && !stopping)
        config_.retune->update(in.tick, position, applied, scene_);
    // The protocol's fault number (docs/protocol.md, section 6): None, Device, NonFinite or Watchdog here.
    const auto fault_number = static_cast<std::uint8_t>(result_.fault);

    if (config_.recorder != nullptr) {
        recording::TickChunk& r = record_chunk_;
        r.read_status = static_cast<std::uint8_t>(read_status);
        r.write_status = static_cast<std::uint8_t>(status);
        r.fault = fault_number;
        r.gain_row = config_.retune != nullptr ? config_.retune->row() : 0U;
        r.tick = in.tick;
        r.time_s = in.time_s;
        const AxisVector v = hooks_.objects != nullptr ? hooks_.objects->velocity() : AxisVector{};
        for (std::size_t a = 0; a < kMaxAxes; ++a) {
            r.position[a] = position[a];
            r.velocity[a] = v[a];
            r.force[a] = applied[a];
        }
        r.contact_mask = hooks_.objects != nullptr ? hooks_.objects->contact_mask() : 0U;
        r.config_contact_mask = scene_.contact_mask();
        r.wake_latency_ns = in.wake_latency_ns;
        config_.recorder->push_tick(r);
    }

    if (hooks_.state != nullptr) {
        StateTick& st = state_record_;
        st.tick = in.tick;
        st.time_s = static_cast<double>(RealtimeLoop::now_ns()) * 1e-9;
        st.position = position;
        st.velocity = hooks_.objects != nullptr ? hooks_.objects->velocity() : AxisVector{};
        st.force = applied;
        st.overruns = loop_.counters().overruns;
        st.wake_latency_ns = in.wake_latency_ns;
        st.config_contact_mask = scene_.contact_mask();
        st.fault = result_.fault;
        hooks_.state->publish(st, hooks_.objects);
        if (hooks_.contacts != nullptr) {
            hooks_.contacts->detect(st, hooks_.objects);
            // The run's last tick: every contact still in progress ends here (docs/protocol.md, section 6).
            if (last || result_.fault != StateFault::None) hooks_.contacts->end_all(st);
        }
    }

    if (trace_ != nullptr) {
        AxisVector external{};
        const bool known = device_.read_external_force(external) == DeviceStatus::Ok;
        TraceRecord r;
        r.tick = in.tick;
        r.time_s = in.time_s;
        r.position_m = position[config_.trace_axis];
        r.wall_force_N = applied[config_.trace_axis];
        r.external_force_N = known ? external[config_.trace_axis] : std::numeric_limits<double>::quiet_NaN();
        r.wake_latency_us = static_cast<double>(in.wake_latency_ns) * 1e-3;
        trace_->push(r);
    }
    return TickOutput{.stop = last || result_.fault != StateFault::None};
}

}  // namespace hapticd
