// SPDX-License-Identifier: Apache-2.0
// A departure (a client that left) is never queued behind other batches (docs/protocol.md, section 5, "A
// client that leaves"): the loop takes it from its own ring within the tick it is seen, brings the ramp in
// progress and every batch sent before it (held, or still in the ring) to their final state at once, and
// starts the ramp-out from there; batches sent after it wait for its ramp like any other.
#include <gtest/gtest.h>

#include "scene/scene_objects.hpp"

namespace hapticd {
namespace {

constexpr double kPeriod = 1e-3;

struct DepartureRig {
    CommitRing ring{16};
    CommitRing departures{8};
    SceneObjects objects;
    DepartureRig() : objects(config(), ring, &departures) {}
    static SceneObjectsConfig config() {
        SceneObjectsConfig c;
        c.period = kPeriod;
        c.ramp_time = 0.010;  // 10 ticks
        c.axes = 3;
        return c;
    }
    static ObjectCommit batch(std::uint64_t seq, std::initializer_list<SlotUpdate> updates) {
        ObjectCommit c;
        c.seq = seq;
        for (const auto& u : updates) c.updates[c.count++] = u;
        return c;
    }
    AxisVector tick() {
        objects.apply_commits();
        AxisVector f{};
        EXPECT_TRUE(objects.add_forces(AxisVector{}, f));
        return f;
    }
};

// A field of constant force F0 around the origin (the handle stays there): its force is r F0, r its ramp.
ObjectParams force_field(std::uint32_t id, const AxisVector& F0) {
    ObjectParams o;
    o.id = id;
    o.kind = ObjectKind::Field;
    o.radius = 1.0;
    o.force = F0;
    return o;
}

TEST(SceneObjectsDepartures, ADepartureStartsItsRampOutAtOnceAheadOfHeldAndQueuedBatches) {
    DepartureRig rig;
    using A = SlotUpdate::Action;
    ASSERT_TRUE(rig.ring.try_push(DepartureRig::batch(1, {{0, A::Set, force_field(1, {1, 0, 0})}})));
    ASSERT_TRUE(
        rig.ring.try_push(DepartureRig::batch(2, {{2, A::Set, force_field(2, {0, 0, 1})}})));  // the client that leaves
    for (int k = 0; k < 25; ++k) rig.tick();
    ASSERT_EQ(rig.objects.stats().last_commit_seq, 2U);
    ASSERT_EQ(rig.objects.slot_ramp(2), 1.0);
    // Another client's gain changes: batch 3 cross-fades slot 0 and runs; 4 and 5 are held behind it.
    ASSERT_TRUE(rig.ring.try_push(DepartureRig::batch(3, {{0, A::Set, force_field(1, {2, 0, 0})}})));
    rig.tick();
    rig.tick();
    ASSERT_TRUE(rig.ring.try_push(DepartureRig::batch(4, {{1, A::Set, force_field(4, {0, 1, 0})}})));
    ASSERT_TRUE(rig.ring.try_push(DepartureRig::batch(5, {{1, A::Set, force_field(4, {0, 3, 0})}})));
    rig.tick();
    ASSERT_EQ(rig.objects.held(), 2U);
    ASSERT_GT(rig.objects.slot_ramp(0), 0.0);
    ASSERT_LT(rig.objects.slot_ramp(0), 1.0);
    // Batch 6 still in the ring (the loop has not seen it), then the departure (7), then batch 8, sent after it.
    ASSERT_TRUE(rig.ring.try_push(DepartureRig::batch(6, {{3, A::Set, force_field(6, {0, 0, 0})}})));
    ASSERT_TRUE(rig.departures.try_push(DepartureRig::batch(7, {{2, A::Remove, force_field(2, {0, 0, 1})}})));
    ASSERT_TRUE(rig.ring.try_push(DepartureRig::batch(8, {{4, A::Set, force_field(8, {0, 0, 0})}})));
    // The next tick: 3 at its end, 4, 5, 6 at their final state (no ramp), the departing field at weight 1
    // starting its ramp-out, 8 held until that ramp has ended.
    AxisVector f = rig.tick();
    EXPECT_EQ(f[0], 2.0);
    EXPECT_EQ(f[1], 3.0);
    EXPECT_EQ(f[2], 1.0);
    EXPECT_EQ(rig.objects.slot_object_id(3), 6U);
    EXPECT_EQ(rig.objects.slot_ramp(3), 1.0);
    EXPECT_EQ(rig.objects.slot_object_id(4), 0U);
    EXPECT_EQ(rig.objects.stats().last_commit_seq, 7U);
    EXPECT_EQ(rig.objects.stats().commits_jumped, 3U);
    EXPECT_EQ(rig.objects.stats().departures_applied, 1U);
    EXPECT_EQ(rig.objects.held(), 1U);
    // The ramp-out: 10 ticks from the departure's, in whole steps of 0.1 (the ramp law: F0 weighted r).
    for (int j = 1; j < 10; ++j) {
        f = rig.tick();
        EXPECT_NEAR(f[2], 1.0 - 0.1 * j, 1e-12) << j;
        EXPECT_EQ(rig.objects.slot_object_id(4), 0U) << j;
        EXPECT_EQ(rig.objects.stats().last_commit_seq, 7U) << j;
    }
    f = rig.tick();
    EXPECT_EQ(f[2], 0.0);
    EXPECT_EQ(rig.objects.slot_object_id(2), 0U);
    EXPECT_EQ(rig.objects.slot_object_id(4), 8U);  // applied once the departure's ramp has ended
    EXPECT_EQ(rig.objects.stats().last_commit_seq, 8U);
}

// Two departures one tick apart: the second does not wait for the first's ramp; the first's objects are
// then at their final state (gone), the scene its plan left behind.
TEST(SceneObjectsDepartures, ASecondDepartureEndsTheFirstsRampAndStartsItsOwn) {
    DepartureRig rig;
    using A = SlotUpdate::Action;
    ASSERT_TRUE(rig.ring.try_push(
        DepartureRig::batch(1, {{0, A::Set, force_field(1, {1, 0, 0})}, {1, A::Set, force_field(2, {0, 1, 0})}})));
    for (int k = 0; k < 15; ++k) rig.tick();
    ASSERT_TRUE(rig.departures.try_push(DepartureRig::batch(2, {{0, A::Remove, force_field(1, {1, 0, 0})}})));
    AxisVector f = rig.tick();
    EXPECT_EQ(f[0], 1.0);
    f = rig.tick();
    EXPECT_NEAR(f[0], 0.9, 1e-12);
    ASSERT_TRUE(rig.departures.try_push(DepartureRig::batch(3, {{1, A::Remove, force_field(2, {0, 1, 0})}})));
    f = rig.tick();
    EXPECT_EQ(f[0], 0.0);
    EXPECT_EQ(f[1], 1.0);
    EXPECT_EQ(rig.objects.slot_object_id(0), 0U);
    EXPECT_EQ(rig.objects.stats().last_commit_seq, 3U);
    for (int j = 1; j < 10; ++j) EXPECT_NEAR(rig.tick()[1], 1.0 - 0.1 * j, 1e-12) << j;
    EXPECT_EQ(rig.tick()[1], 0.0);
    EXPECT_EQ(rig.objects.occupied(), 0U);
}

}  // namespace
}  // namespace hapticd
