// SPDX-License-Identifier: Apache-2.0
#include "server/contact_events.hpp"

#include "scene/scene_objects.hpp"
#include "server/state_publisher.hpp"

namespace hapticd {

void ContactDetector::push(const StateTick& t, std::uint32_t object_id, bool begin) noexcept {
    ContactRecord r;
    r.tick = t.tick;
    r.time_s = t.time_s;
    r.position = t.position;
    r.force = t.force;
    r.lost_before = lost_;
    r.object_id = object_id;
    r.begin = begin;
    if (!ring_.try_push(r)) ++lost_;
}

void ContactDetector::detect(const StateTick& t, const SceneObjects* objects) noexcept {
    // Config walls: bit i is the wall with id i + 1; a changed bit is a begin (set now) or an end.
    const std::uint64_t config = t.config_contact_mask;
    for (std::uint64_t changed = config ^ config_mask_; changed != 0; changed &= changed - 1) {
        const auto i = static_cast<unsigned>(__builtin_ctzll(changed));
        push(t, i + 1U, ((config >> i) & 1U) != 0U);
    }
    config_mask_ = config;
    if (objects == nullptr) return;
    // Client objects: the mask the state publishes (an entry whose ramp-out ended this tick keeps its
    // contact bit, but its slot is free: no contact). Per slot the id in contact now against last tick's:
    // the slots whose bit changed, and, when the slot table changed (an id can change only then), every slot
    // in contact on both ticks. A steady scene looks at no slot.
    const std::uint64_t mask = objects->contact_mask() & objects->occupied_mask();
    std::uint64_t candidates = mask ^ object_mask_;
    const std::uint64_t version = objects->slot_table_version();
    if (version != slot_table_version_) candidates |= mask & object_mask_;
    slot_table_version_ = version;
    for (std::uint64_t m = candidates; m != 0; m &= m - 1) {
        const auto s = static_cast<std::size_t>(__builtin_ctzll(m));
        const std::uint32_t now = ((mask >> s) & 1U) != 0U ? objects->slot_object_id(s) : 0U;
        const std::uint32_t before = ids_[s];
        if (now == before) continue;
        if (before != 0U) push(t, before, false);
        if (now != 0U) push(t, now, true);
        ids_[s] = now;
    }
    object_mask_ = mask;
}

void ContactDetector::end_all(const StateTick& t) noexcept {
    for (std::uint64_t m = config_mask_; m != 0; m &= m - 1)
        push(t, static_cast<unsigned>(__builtin_ctzll(m)) + 1U, false);
    config_mask_ = 0;
    for (std::size_t s = 0; s < ids_.size(); ++s) {
        if (ids_[s] != 0U) push(t, ids_[s], false);
        ids_[s] = 0;
    }
    object_mask_ = 0;
}

}  // namespace hapticd
