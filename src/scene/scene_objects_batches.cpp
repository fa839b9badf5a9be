// SPDX-License-Identifier: Apache-2.0
// SceneObjects' intake (scene_objects.hpp): the batches taken from the commit ring (held while another batch's
// ramps run), the departures taken from the second ring ahead of them, a batch applied to the slots, and the
// ramps (in, out, cross-fades) stepped per tick in whole ticks.
#include "scene/scene_objects.hpp"

namespace hapticd {

namespace {

// True when the batch only moves objects: no Set, no Remove (a Move that is not a move of the slot's
// object changes its gains without a ramp and counts as a change; the server never sends one).
bool only_moves_in(const ObjectCommit& c) noexcept {
    for (std::uint32_t i = 0; i < c.count && i < kSceneObjectCapacity; ++i) {
        if (c.updates[i].action != SlotUpdate::Action::Move) return false;
    }
    return true;
}

std::uint64_t slots_of(const ObjectCommit& c) noexcept {
    std::uint64_t m = 0;
    for (std::uint32_t i = 0; i < c.count && i < kSceneObjectCapacity; ++i) {
        if (c.updates[i].slot < kSceneObjectCapacity) m |= std::uint64_t{1} << c.updates[i].slot;
    }
    return m;
}

}  // namespace

bool SceneObjects::ramp_running() const noexcept {
    if (ramp_step_ >= 1.0) return false;  // no ramps at all
    for (const Slot& slot : slots_) {
        if (slot.fading.active || (slot.current.active && slot.current.ramp < 1.0)) return true;
    }
    return false;
}

// Batches are taken in ring order, at most commits_per_tick per tick. One that adds, changes or removes
// objects (it starts ramps) while another batch's ramps are running, or while an earlier such batch is
// held, is held (copied into held_, in order) and applied at the first tick with no ramp running: at most
// one batch ramps at a time, from the scene every earlier batch has reached, which is what the server
// checked (docs/protocol.md, section 5). Batches of moves only are never held: one whose slots no held
// batch touches is applied at once (it changes no gain, and the held batches no slot of it); one that
// moves an object a held batch adds or changes waits in the ring behind it, and the batches after it too.
// last_commit_seq stays below the oldest held batch's seq until it is applied ("every batch up to this seq
// is applied"). Departures go first (take_departures), at every step: the ring's front is read before the
// departure ring is looked at, so a departure the server sent before that batch is seen first.
void SceneObjects::apply_commits() noexcept {
    if (departures_ != nullptr) (void)take_departures();
    if (held_count_ == 0 && ring_.front() == nullptr) return;  // the usual tick: nothing to do
    for (std::size_t n = 0; n < config_.commits_per_tick; ++n) {
        const ObjectCommit* c = ring_.front();
        if (departures_ != nullptr && take_departures()) continue;
        if (held_count_ > 0 && !ramp_running()) {
            apply(held_[held_first_]);
            pop_held();
            continue;
        }
        if (c == nullptr) break;
        if (only_moves_in(*c)) {
            if ((slots_of(*c) & held_slots_) != 0) break;  // waits behind the held batch that touches its slot
        } else if (held_count_ > 0 || ramp_running()) {
            if (held_count_ == held_.size()) break;  // full: it waits in the ring
            held_[(held_first_ + held_count_) % held_.size()] = *c;
            ++held_count_;
            held_slots_ |= slots_of(*c);
            ++stats_.commits_held;
            if (observer_ != nullptr) observer_->on_taken(*c, CommitSource::Ring);
            ring_.pop();
            continue;
        }
        if (observer_ != nullptr) observer_->on_taken(*c, CommitSource::Ring);
        apply(*c);
        ring_.pop();
    }
    const std::uint64_t before_held = held_count_ > 0 ? held_[held_first_].seq - 1 : applied_seq_;
    stats_.last_commit_seq = before_held < applied_seq_ ? before_held : applied_seq_;
}

void SceneObjects::pop_held() noexcept {
    held_first_ = (held_first_ + 1) % held_.size();
    --held_count_;
    held_slots_ = 0;
    for (std::size_t i = 0; i < held_count_; ++i) held_slots_ |= slots_of(held_[(held_first_ + i) % held_.size()]);
}

// Every departure waiting in the second ring, in order. For each: the ramps in progress jump to their end,
// every batch the server sent before it (held here, or still in the ring: seq below the departure's) is
// applied at once, in order, at its final state — the scene the server's model had when it planned the
// departure, which it checked — and then the departure's ramp-out starts from there, the scenes
// plan_departure checked. Bounded: each batch is applied once, the rings and held_ hold 64 each.
bool SceneObjects::take_departures() noexcept {
    bool any = false;
    for (const ObjectCommit* d = departures_->front(); d != nullptr; d = departures_->front()) {
        finish_ramps();
        while (held_count_ > 0) {
            apply(held_[held_first_], true);
            ++stats_.commits_jumped;
            pop_held();
        }
        for (const ObjectCommit* c = ring_.front(); c != nullptr && c->seq < d->seq; c = ring_.front()) {
            if (observer_ != nullptr) observer_->on_taken(*c, CommitSource::Jumped);
            apply(*c, true);
            ++stats_.commits_jumped;
            ring_.pop();
        }
        if (observer_ != nullptr) observer_->on_taken(*d, CommitSource::Departure);
        apply(*d);
        ++stats_.departures_applied;
        departures_->pop();
        any = true;
    }
    if (any) stats_.last_commit_seq = applied_seq_;
    return any;
}

// Every ramp in progress at its end: objects ramping in at weight 1, fading ones gone.
void SceneObjects::finish_ramps() noexcept {
    bool changed = false;
    for (Slot& slot : slots_) {
        if (slot.fading.active) {
            slot.fading.active = false;
            changed = true;
        }
        if (slot.current.active && slot.current.ramp < 1.0) {
            slot.current.ramp = 1.0;
            changed = true;
        }
    }
    if (changed) {
        whole_change_pending_ = true;
        scene_changed_ = true;
        ++slot_table_version_;
        count_occupied();
    }
}

// The slot's current object starts to fade out from its ramp factor now (1 unless a batch was applied
// while its ramp ran, which apply_commits prevents); without ramps it is gone at once.
void SceneObjects::start_fading(Slot& slot) noexcept {
    const auto s = static_cast<std::size_t>(&slot - slots_.data());
    std::swap(proxy_of_[2 * s], proxy_of_[2 * s + 1]);  // the fading entry keeps the current one's proxy
    slot.fading = slot.current;
    slot.fading.active = ramp_step_ < 1.0;
    slot.fading.start = slot.current.ramp;
    slot.fading.steps = 0;
}

void SceneObjects::apply(const ObjectCommit& commit, bool at_once) noexcept {
    bool only_moves = true;
    for (std::uint32_t i = 0; i < commit.count && i < kSceneObjectCapacity; ++i) {
        const SlotUpdate& u = commit.updates[i];
        if (u.slot >= kSceneObjectCapacity) continue;  // the server never sends one; ignore rather than crash
        Slot& slot = slots_[u.slot];
        switch (u.action) {
            case SlotUpdate::Action::Set:
                only_moves = false;
                note_new_object(u.slot, u.params, !slot.current.active);
                if (slot.current.active) start_fading(slot);  // cross-fade from wherever the old one is
                if (at_once) slot.fading.active = false;
                slot.current.active = true;
                slot.current.ramp = ramp_step_ >= 1.0 || at_once ? 1.0 : 0.0;
                slot.current.steps = 0;
                slot.current.params = u.params;
                if (u.params.kind == ObjectKind::Mesh) bind_mesh(2 * u.slot, u.params);
                break;
            case SlotUpdate::Action::Move:
                if (slot.current.active) {
                    if (is_move(slot.current.params, u.params)) {  // same gains, new place: no ramp
                        begin_glide(u.slot, u.params);
                    } else {
                        only_moves = false;
                        cancel_glide(u.slot);
                        slot.current.params = u.params;
                        if (u.params.kind == ObjectKind::Mesh) bind_mesh(2 * u.slot, u.params);
                    }
                }
                break;
            case SlotUpdate::Action::Remove:
                only_moves = false;
                cancel_glide(u.slot);
                if (slot.current.active) {
                    start_fading(slot);
                    slot.current.active = false;
                }
                if (at_once) slot.fading.active = false;
                break;
            case SlotUpdate::Action::Cut:
                only_moves = false;
                cancel_glide(u.slot);
                slot.current.active = false;
                slot.fading.active = false;
                break;
        }
    }
    if (!only_moves) {
        whole_change_pending_ = true;
        scene_changed_ = true;
        ++slot_table_version_;
        count_occupied();
    }
    ++stats_.commits_applied;
    applied_seq_ = commit.seq > applied_seq_ ? commit.seq : applied_seq_;
}

void SceneObjects::count_occupied() noexcept {
    std::uint32_t n = 0;
    std::uint64_t mask = 0;
    for (std::size_t s = 0; s < kSceneObjectCapacity; ++s) {
        const bool used = slot_object_id(s) != 0;
        n += used ? 1U : 0U;
        mask |= static_cast<std::uint64_t>(used) << s;
    }
    occupied_ = n;
    occupied_mask_ = mask;
}

// Ramp factors are counted in whole ticks, r = j step (in) and start - j step (out), not summed step by
// step: the same arithmetic as GainChecker::ramp_is_stable, so the loop renders the very weights the
// server checked (a sum of j steps drifts by up to j eps and can take one tick more to reach 1).
void SceneObjects::step_ramps() noexcept {
    for (std::size_t s = 0; s < kSceneObjectCapacity; ++s) {
        Slot& slot = slots_[s];
        if (slot.current.active && slot.current.ramp < 1.0) {
            const double r = static_cast<double>(++slot.current.steps) * ramp_step_;
            slot.current.ramp = r >= 1.0 ? 1.0 : r;
        }
        if (slot.fading.active) {
            const double r = slot.fading.start - static_cast<double>(++slot.fading.steps) * ramp_step_;
            slot.fading.ramp = r > 0.0 ? r : 0.0;
            slot.fading.active = r > 0.0;
        }
    }
    whole_change_pending_ = true;
    scene_changed_ = true;
    ++slot_table_version_;
    count_occupied();
}

}  // namespace hapticd
