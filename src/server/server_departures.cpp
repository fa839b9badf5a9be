// SPDX-License-Identifier: Apache-2.0
// A departed session's objects ramped out by the departure rule (server/departure_plan.hpp), the waiting
// departure batches pushed in order, and slots reclaimed once the loop has emptied them (Server::Impl,
// server_impl.hpp).
#include "server/server_impl.hpp"

#include <algorithm>
#include <cmath>

#include "server/departure_plan.hpp"
#include "server/replies.hpp"

namespace hapticd {

// A session's objects ramp out by the departure rule (departure_plan.hpp, docs/protocol.md section 5):
// with them, if the scene they leave or a ramp scene would be unstable, the fewest further client
// objects (or all of them, or all cut at once); the owners of those get an event with the reason.
std::size_t Server::Impl::ramp_out_objects_of(std::uint64_t session) {
    std::vector<DepartureObject> leaving, staying;
    for (std::size_t i = 0; i < kSceneObjectCapacity; ++i) {
        const ServerSlot& slot = slots[i];
        if (slot.state != ServerSlot::State::Used) continue;
        (slot.owner == session ? leaving : staying)
            .push_back(DepartureObject{i, slot.owner, server::slot_term(slot, SceneTerm::Role::Base)});
    }
    if (leaving.empty()) return 0;
    const double step = config.ramp_time > 0.0 ? config.period / config.ramp_time : 1.0;
    const DeparturePlan plan =
        plan_departure(checker, server::terms_of_config_walls(config.config_walls), leaving, staying, step);
    ObjectCommit c;
    std::map<std::uint64_t, std::vector<std::uint32_t>> further_by_owner;
    for (const std::size_t i : plan.out) {
        ServerSlot& slot = slots[i];
        if (slot.owner != session) further_by_owner[slot.owner].push_back(slot.id);
        slot.state = ServerSlot::State::Draining;
        slot.drain_seq = server::kNotPushed;
        SlotUpdate& u = c.updates[c.count++];
        u.slot = static_cast<std::uint8_t>(i);
        u.action = plan.cut ? SlotUpdate::Action::Cut : SlotUpdate::Action::Remove;
        u.params = slot.resolved.params;
    }
    pending.push_back(c);   // before the events: a send may close another session, whose batch must follow
    restart_scene_check();  // a commit being checked was staged on the scene before this departure
    push_pending();
    if (!plan.further.empty()) {
        const std::string how =
            plan.cut ? "removed at once (no ramp-out of them all is stable either)" : "ramped out with them";
        log("session " + std::to_string(session) + " left; " + std::to_string(plan.further.size()) +
            " objects of other sessions " + how + ": " + plan.reason);
        for (const auto& [owner, ids] : further_by_owner) {
            const auto it = sessions.find(owner);
            if (it == sessions.end() || it->second.closed) continue;
            send_reply(it->second, server::objects_removed_event(
                                       ids, "objects " + json(ids).dump() + " are " + how + " because session " +
                                                std::to_string(session) + " left and, without them, " + plan.reason +
                                                " (docs/protocol.md, section 5)"));
        }
    }
    return leaving.size();
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
