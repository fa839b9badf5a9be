// SPDX-License-Identifier: Apache-2.0
// The loop's contact events (server/contact_events.hpp), in process: ContactDetector driven tick by tick
// over the loop's object slots (scene/scene_objects.hpp) and a config mask, against a reference written here
// from the definition (docs/protocol.md, section 6, "Contact events"): the set of ids in contact per tick
// (config bit i -> id i + 1; slot s in contact_mask & occupied_mask -> slot_object_id(s)); an id in this
// tick's set and not the last's is a begin, the reverse an end, at this tick, with this tick's state.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <iterator>
#include <map>
#include <set>
#include <vector>

#include "scene/scene_objects.hpp"
#include "server/contact_events.hpp"
#include "server/state_publisher.hpp"

namespace hapticd {
namespace {

struct DetectorRig {
    CommitRing commits{8};
    SceneObjects objects;
    ContactRing ring;
    ContactDetector detector{ring};
    std::uint64_t tick = 0;
    std::set<std::uint32_t> last;  // the reference's set of the last tick
    explicit DetectorRig(std::size_t ring_capacity = 1024) : objects(objects_config(), commits), ring(ring_capacity) {}
    static SceneObjectsConfig objects_config() {
        SceneObjectsConfig c;
        c.period = 1e-3;
        c.ramp_time = 0.005;  // 5 ticks
        c.axes = 3;
        return c;
    }
    void commit(std::initializer_list<SlotUpdate> updates, std::uint64_t seq) {
        ObjectCommit c;
        c.seq = seq;
        for (const auto& u : updates) c.updates[c.count++] = u;
        ASSERT_TRUE(commits.try_push(c));
    }
    // One loop tick at handle position x; returns the reference's expected records (begin/end sets) and
    // checks the detector's records of this tick against them.
    void step(const AxisVector& x, std::uint64_t config_mask, bool check = true) {
        objects.apply_commits();
        StateTick st;
        st.tick = tick;
        st.time_s = 1e-3 * static_cast<double>(tick);
        st.position = x;
        EXPECT_TRUE(objects.add_forces(x, st.force));
        st.config_contact_mask = config_mask;
        detector.detect(st, &objects);
        std::set<std::uint32_t> now;
        for (std::uint32_t i = 0; i < 64; ++i) {
            if (((config_mask >> i) & 1U) != 0U) now.insert(i + 1);
        }
        for (std::size_t s = 0; s < kSceneObjectCapacity; ++s) {
            if ((((objects.contact_mask() & objects.occupied_mask()) >> s) & 1U) != 0U)
                now.insert(objects.slot_object_id(s));
        }
        if (check) {
            std::set<std::uint32_t> begins, ends;
            ContactRecord r;
            while (ring.try_pop(r)) {
                EXPECT_EQ(r.tick, tick);
                EXPECT_EQ(r.time_s, st.time_s);
                for (std::size_t a = 0; a < 3; ++a) {
                    EXPECT_EQ(r.position[a], st.position[a]);
                    EXPECT_EQ(r.force[a], st.force[a]);
                }
                EXPECT_TRUE((r.begin ? begins : ends).insert(r.object_id).second)
                    << "a duplicate record of " << r.object_id;
                records.push_back(r);
            }
            std::set<std::uint32_t> want_begins, want_ends;
            std::set_difference(now.begin(), now.end(), last.begin(), last.end(),
                                std::inserter(want_begins, want_begins.end()));
            std::set_difference(last.begin(), last.end(), now.begin(), now.end(),
                                std::inserter(want_ends, want_ends.end()));
            EXPECT_EQ(begins, want_begins) << "tick " << tick;
            EXPECT_EQ(ends, want_ends) << "tick " << tick;
        }
        last = now;
        ++tick;
    }
    std::vector<ContactRecord> records;  // every record popped, in order
};

ObjectParams zero_field(std::uint32_t id, double radius) {
    ObjectParams o;
    o.id = id;
    o.kind = ObjectKind::Field;
    o.radius = radius;
    return o;
}

ObjectParams unilateral_plane_x(std::uint32_t id, double offset) {
    ObjectParams o;
    o.id = id;
    o.kind = ObjectKind::Plane;
    o.direction = {-1.0, 0.0, 0.0};  // p = offset + x: in contact for x > -offset
    o.offset = offset;
    o.K = 100.0;
    o.B = 1.0;
    return o;
}

// A field's contact from its commit to the tick its ramp-out frees the slot; that tick the loop's
// contact_mask still has the slot's bit (the fading entry was rendered), the published mask does not: the
// end is at that tick, not one later.
TEST(ContactDetector, ARemovedObjectEndsAtTheTickItsRampOutFreesTheSlot) {
    DetectorRig rig;
    const AxisVector x{0.0, 0.0, 0.0};
    rig.commit({{3, SlotUpdate::Action::Set, zero_field(10, 0.05)}}, 1);
    for (int i = 0; i < 10; ++i) rig.step(x, 0);
    rig.commit({{3, SlotUpdate::Action::Remove, zero_field(10, 0.05)}}, 2);
    std::uint64_t freed = 0;
    bool kept_bit = false;
    for (int i = 0; i < 20; ++i) {
        rig.step(x, 0);
        if (freed == 0 && (rig.objects.occupied_mask() & (1ULL << 3)) == 0) {
            freed = rig.tick - 1;
            kept_bit = (rig.objects.contact_mask() & (1ULL << 3)) != 0;
        }
    }
    ASSERT_NE(freed, 0U);
    EXPECT_TRUE(kept_bit) << "the scenario of the ended ramp-out's bit was not exercised";
    ASSERT_EQ(rig.records.size(), 2U);
    EXPECT_TRUE(rig.records[0].begin);
    EXPECT_EQ(rig.records[0].object_id, 10U);
    EXPECT_FALSE(rig.records[1].begin);
    EXPECT_EQ(rig.records[1].object_id, 10U);
    EXPECT_EQ(rig.records[1].tick, freed);
}

// The loop's last tick (ContactDetector::end_all): an end for every object in contact, config walls by ascending id
// then the slots in order, at that tick with its state; nothing is in contact afterwards (a later detect() of the
// same contacts begins them again).
TEST(ContactDetector, TheLastTickEndsEveryContactInProgress) {
    DetectorRig rig;
    const AxisVector x{0.0, 0.0, 0.0};
    rig.commit({{5, SlotUpdate::Action::Set, zero_field(20, 0.05)}, {2, SlotUpdate::Action::Set, zero_field(21, 0.05)}},
               1);
    for (int i = 0; i < 10; ++i) rig.step(x, 0b101);  // config walls 1 and 3, fields 21 (slot 2) and 20 (slot 5)
    ASSERT_EQ(rig.records.size(), 4U);
    StateTick last;
    last.tick = 9;
    last.time_s = 0.009;
    last.position = {0.001, 0.0, 0.0};
    rig.detector.end_all(last);
    std::vector<ContactRecord> ends;
    ContactRecord r;
    while (rig.ring.try_pop(r)) ends.push_back(r);
    ASSERT_EQ(ends.size(), 4U);
    const std::uint32_t order[4] = {1, 3, 21, 20};
    for (std::size_t i = 0; i < 4; ++i) {
        EXPECT_FALSE(ends[i].begin);
        EXPECT_EQ(ends[i].object_id, order[i]);
        EXPECT_EQ(ends[i].tick, 9U);
        EXPECT_EQ(ends[i].position[0], 0.001);
    }
    rig.detector.end_all(last);  // nothing left in contact
    EXPECT_FALSE(rig.ring.try_pop(r));
}

// A slot that changes hands in one tick (object 10 cut and object 11 set in the same batch, both in contact):
// the old id's end, then the new id's begin, at that tick. Config walls first, in ascending id.
TEST(ContactDetector, ASlotGivenToAnotherObjectEndsTheOldIdBeforeItBeginsTheNew) {
    DetectorRig rig;
    const AxisVector x{0.0, 0.0, 0.0};
    rig.commit({{5, SlotUpdate::Action::Set, zero_field(10, 0.05)}}, 1);
    for (int i = 0; i < 10; ++i) rig.step(x, 0);
    rig.records.clear();
    rig.commit({{5, SlotUpdate::Action::Cut, zero_field(10, 0.05)}, {5, SlotUpdate::Action::Set, zero_field(11, 0.05)}},
               2);
    rig.step(x, 0b101);  // walls 1 and 3 begin in the same tick
    for (int i = 0; i < 10; ++i) rig.step(x, 0b101);
    ASSERT_GE(rig.records.size(), 4U);
    EXPECT_EQ(rig.records[0].object_id, 1U);
    EXPECT_EQ(rig.records[1].object_id, 3U);
    EXPECT_FALSE(rig.records[2].begin);
    EXPECT_EQ(rig.records[2].object_id, 10U);
    EXPECT_TRUE(rig.records[3].begin);
    EXPECT_EQ(rig.records[3].object_id, 11U);
    EXPECT_EQ(rig.records[2].tick, rig.records[3].tick);
}

// A plane the handle crosses back and forth every few ticks, and a config mask of 3 walls changing: every
// tick's records are the reference's (the rig checks each tick); begins and ends alternate per id.
TEST(ContactDetector, EveryTickOfACrossingHandleGivesTheReferencesTransitions) {
    DetectorRig rig;
    rig.commit({{0, SlotUpdate::Action::Set, unilateral_plane_x(20, 0.0)},
                {9, SlotUpdate::Action::Set, zero_field(21, 0.004)}},
               1);
    for (int i = 0; i < 1000; ++i) {                   // 8 periods of 126 ticks: 16 crossings of x = 0
        const double xi = 0.005 * std::sin(0.05 * i);  // the plane's surface at x = 0, the field's edge at |x| = 4 mm
        rig.step({xi, 0.0, 0.0}, static_cast<std::uint64_t>((i / 7) % 8));
    }
    std::map<std::uint32_t, bool> in;
    std::size_t of_plane = 0;
    for (const auto& r : rig.records) {
        EXPECT_NE(in[r.object_id], r.begin) << "object " << r.object_id << " tick " << r.tick;
        in[r.object_id] = r.begin;
        of_plane += r.object_id == 20 ? 1U : 0U;
    }
    EXPECT_GE(of_plane, 10U);  // the crossing was exercised (the plane may appear later: the activation rule)
    EXPECT_EQ(rig.detector.lost(), 0U);
}

// A full ring drops the record and counts it; the next record pushed carries the count so far.
TEST(ContactDetector, AFullRingDropsRecordsAndTheNextCarriesTheCount) {
    DetectorRig rig(2);
    ASSERT_EQ(rig.ring.capacity(), 2U);
    const AxisVector x{};
    rig.step(x, 0b111, false);  // 3 begins: 2 fit, 1 lost
    EXPECT_EQ(rig.detector.lost(), 1U);
    ContactRecord r;
    std::vector<ContactRecord> got;
    while (rig.ring.try_pop(r)) got.push_back(r);
    ASSERT_EQ(got.size(), 2U);
    EXPECT_EQ(got[0].lost_before, 0U);
    EXPECT_EQ(got[1].lost_before, 0U);
    rig.step(x, 0b110, false);  // wall 1 ends
    ASSERT_TRUE(rig.ring.try_pop(r));
    EXPECT_EQ(r.object_id, 1U);
    EXPECT_FALSE(r.begin);
    EXPECT_EQ(r.lost_before, 1U);
}

}  // namespace
}  // namespace hapticd
