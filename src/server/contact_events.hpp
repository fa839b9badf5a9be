// SPDX-License-Identifier: Apache-2.0
// Contact events (docs/protocol.md, section 6, "Contact events"): the loop's side. Once per tick, after the
// state is published, ContactDetector::detect compares the contacts published this tick (the config walls'
// config_contact_mask; the client objects' contact_mask & occupied_mask with the slot table's ids) with the
// previous tick's and hands one fixed-size record per begin and per end to the server thread through a
// preallocated lock-free SPSC ring; at the loop's last tick, end_all ends every contact still in progress. A
// full ring drops the record and counts it (the next record carries the
// count); detect() never blocks, allocates, locks, throws or makes a system call.
#pragma once

#include <array>
#include <cstdint>

#include "common/axis_vector.hpp"
#include "hapticd/state_layout.hpp"
#include "loop/spsc_ring.hpp"

namespace hapticd {

class SceneObjects;
struct StateTick;

struct ContactRecord {
    std::uint64_t tick = 0;
    double time_s = 0.0;            // the state's time_s of that tick
    AxisVector position{};          // the handle, m
    AxisVector force{};             // the force commanded to the device that tick, N (the state's `force`)
    std::uint64_t lost_before = 0;  // records the ring could not take since the loop started, before this one
    std::uint32_t object_id = 0;    // config walls 1 .. n, client objects by their id
    bool begin = false;             // true: contact began this tick; false: it ended this tick
};

using ContactRing = SpscRing<ContactRecord>;

// Records a ring holds: the server takes them at least every millisecond (its poll period), and a request's
// checks hold it for milliseconds (tens on a loaded machine); 4096 are 4 begins and ends per tick for 1 s.
inline constexpr std::size_t kContactRingCapacity = 4096;

class ContactDetector {
  public:
    explicit ContactDetector(ContactRing& ring) noexcept : ring_(ring) {}

    // The loop, once per tick after StatePublisher::publish(t, objects) (objects may be null). Within a tick:
    // the config walls in ascending id, then the slots in order; in a slot whose object changed (a slot freed
    // and given to another object), the old object's end before the new one's begin.
    void detect(const StateTick& t, const SceneObjects* objects) noexcept;

    // The loop's last tick (a stop's last tick or a fault's), after detect(t, objects): an `end` for every
    // object still in contact (config walls in ascending id, then the slots in order), at that tick, so that
    // per object every begin has its end. Nothing is in contact afterwards.
    void end_all(const StateTick& t) noexcept;

    // Records the ring could not take so far (loop thread).
    [[nodiscard]] std::uint64_t lost() const noexcept { return lost_; }

  private:
    void push(const StateTick& t, std::uint32_t object_id, bool begin) noexcept;

    ContactRing& ring_;
    std::uint64_t config_mask_ = 0;                          // the last tick's config_contact_mask
    std::uint64_t object_mask_ = 0;                          // the last tick's published contact_mask
    std::uint64_t slot_table_version_ = 0;                   // SceneObjects::slot_table_version() at the last tick
    std::array<std::uint32_t, kStateObjectCapacity> ids_{};  // the object in contact in each slot last tick (0: none)
    std::uint64_t lost_ = 0;
};

}  // namespace hapticd
