// SPDX-License-Identifier: Apache-2.0
// A departed session's objects ramped out by the departure rule (server/departure_plan.hpp), planned off the server
// thread (server/scene_check_worker.hpp), the waiting departure batches pushed in order, and slots reclaimed once the
// loop has emptied them (Server::Impl, server_impl.hpp).
#include "server/server_impl.hpp"

#include <algorithm>
#include <cmath>

#include "server/departure_plan.hpp"
#include "server/replies.hpp"

namespace hapticd {

// A session's objects ramp out by the departure rule (departure_plan.hpp, docs/protocol.md section 5): with them, if
// the scene they leave or a ramp scene would be unstable, the fewest further client objects (or all of them, or all
// cut at once); the owners of those get an event with the reason. The plan is made by scene_checker (seconds over the
// Falcon's set with oblique planes): meanwhile the objects render as they were (a scene checked when it was committed),
// the server answers the other sessions, and every commit waits, so the plan is made on the scene the loop renders.
std::size_t Server::Impl::queue_departure(const Session& s) {
    const auto leaving =
        static_cast<std::size_t>(std::count_if(slots.begin(), slots.end(), [&](const ServerSlot& slot) {
            return slot.state == ServerSlot::State::Used && slot.owner == s.id;
        }));
    if (leaving == 0) return 0;
    departures_waiting.push_back(Departure{s.id,
                                           "session " + std::to_string(s.id) + " (" +
                                               (s.name.empty() ? "unnamed" : s.name) + ", pid " +
                                               std::to_string(s.pid) + ")",
                                           Clock::now()});
    restart_scene_check();  // a commit being checked was staged on the scene before this departure
    start_departure();
    return leaving;
}

void Server::Impl::start_departure() {
    if (departure_check || departures_waiting.empty() || scene_check || !scene_checker.idle()) return;
    const Departure d = departures_waiting.front();
    std::vector<DepartureObject> leaving, staying;
    for (std::size_t i = 0; i < kSceneObjectCapacity; ++i) {
        const ServerSlot& slot = slots[i];
        if (slot.state != ServerSlot::State::Used) continue;
        (slot.owner == d.session ? leaving : staying)
            .push_back(DepartureObject{i, slot.owner, server::slot_term(slot, SceneTerm::Role::Base)});
    }
    const std::size_t count = leaving.size();
    const double step = config.ramp_time > 0.0 ? config.period / config.ramp_time : 1.0;
    if (count > 0 && !scene_checker.start_departure(server::terms_of_config_walls(config.config_walls),
                                                    std::move(leaving), std::move(staying), step))
        return;  // idle was checked above: never
    departures_waiting.pop_front();
    if (count > 0) departure_check = d;
}

void Server::Impl::finish_departure() {
    if (!departure_check) return;
    std::optional<server::SceneCheckWorker::Outcome> outcome = scene_checker.take();
    if (!outcome) return;
    const Departure d = std::move(*departure_check);
    departure_check.reset();
    const double planned_ms = std::chrono::duration<double, std::milli>(Clock::now() - d.queued).count();
    if (outcome->departure) {
        ramp_out(d, *outcome->departure, planned_ms);
    } else {
        // No verdict (the check threw): step 4 of the rule, which needs none. Every client object is cut at once, the
        // loop jumping from the scene it renders (checked when committed) to the config walls (checked at start-up).
        DeparturePlan cut;
        cut.cut = true;
        cut.reason =
            std::string("the departure's check failed: ") + (outcome->failure ? outcome->failure : "no verdict");
        for (std::size_t i = 0; i < kSceneObjectCapacity; ++i) {
            if (slots[i].state == ServerSlot::State::Used && slots[i].owner == d.session) cut.out.push_back(i);
        }
        for (std::size_t i = 0; i < kSceneObjectCapacity; ++i) {
            if (slots[i].state == ServerSlot::State::Used && slots[i].owner != d.session) {
                cut.out.push_back(i);
                cut.further.push_back(i);
            }
        }
        ramp_out(d, cut, planned_ms);
    }
    start_departure();
}

void Server::Impl::ramp_out(const Departure& d, const DeparturePlan& plan, double planned_ms) {
    ObjectCommit c;
    std::map<std::uint64_t, std::vector<std::uint32_t>> further_by_owner;
    for (const std::size_t i : plan.out) {
        ServerSlot& slot = slots[i];
        if (slot.owner != d.session) further_by_owner[slot.owner].push_back(slot.id);
        slot.state = ServerSlot::State::Draining;
        slot.drain_seq = server::kNotPushed;
        SlotUpdate& u = c.updates[c.count++];
        u.slot = static_cast<std::uint8_t>(i);
        u.action = plan.cut ? SlotUpdate::Action::Cut : SlotUpdate::Action::Remove;
        u.params = slot.resolved.params;
    }
    pending.push_back(c);  // before the events: a send may close another session, whose batch must follow
    push_pending();
    log(d.label + ": " + std::to_string(plan.out.size() - plan.further.size()) + " of its objects " +
        (plan.cut ? "removed at once" : "ramp out") + ", departure planned in " + g(planned_ms) + " ms");
    if (!plan.further.empty()) {
        const std::string how =
            plan.cut ? "removed at once (no ramp-out of them all is stable either)" : "ramped out with them";
        log("session " + std::to_string(d.session) + " left; " + std::to_string(plan.further.size()) +
            " objects of other sessions " + how + ": " + plan.reason);
        for (const auto& [owner, ids] : further_by_owner) {
            const auto it = sessions.find(owner);
            if (it == sessions.end() || it->second.closed) continue;
            send_reply(it->second, server::objects_removed_event(
                                       ids, "objects " + json(ids).dump() + " are " + how + " because session " +
                                                std::to_string(d.session) + " left and, without them, " + plan.reason +
                                                " (docs/protocol.md, section 5)"));
        }
    }
}

// Pushes waiting departure batches in order; assigns their sequence numbers when they enter the ring.
// The loop applies every batch with a smaller seq (sent before) at once when it takes a departure, and
// none with a larger one before it: the departure was planned on exactly that scene (`slots` now).
void Server::Impl::push_pending() {
    while (!pending.empty()) {
        ObjectCommit& c = pending.front();
        c.seq = next_commit_seq;
        if (!departure_ring.try_push(c)) return;
        ++next_commit_seq;
        for (std::uint32_t i = 0; i < c.count; ++i) slots[c.updates[i].slot].drain_seq = c.seq;
        commits_pushed.fetch_add(1, std::memory_order_release);
        count(&ServerCounters::commits_pushed);
        pending.pop_front();
    }
}

void Server::Impl::reclaim_slots() {
    if (!state.read(snapshot)) return;  // no consistent tick now: slots are reclaimed on a later pass
    for (std::size_t i = 0; i < kSceneObjectCapacity; ++i) {
        ServerSlot& slot = slots[i];
        if (slot.state != ServerSlot::State::Draining || slot.drain_seq == server::kNotPushed) continue;
        if (snapshot.last_commit_seq >= slot.drain_seq && snapshot.slot_object_id[i] == 0) slot = ServerSlot{};
    }
    const auto ramp_ticks = static_cast<std::uint64_t>(std::ceil(config.ramp_time / config.period)) + 2;
    for (Retired& r : retired) {
        if (r.applied_tick == 0 && snapshot.last_commit_seq >= r.seq) r.applied_tick = snapshot.tick + 1;
    }
    std::erase_if(
        retired, [&](const Retired& r) { return r.applied_tick != 0 && snapshot.tick >= r.applied_tick + ramp_ticks; });
}

}  // namespace hapticd
