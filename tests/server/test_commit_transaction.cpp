// SPDX-License-Identifier: Apache-2.0
// The commit transaction (server/commit_transaction.hpp) without a socket: a batch applied to a copy of the
// slot table, all-or-nothing; ids after the config walls; one merged update per slot (Set, Move, Remove);
// the refusals' codes, operation indices and messages (docs/protocol.md, sections 5 and 8); and the scene
// checks (summed stiffness limit, summed stability) with op_index -1. The device: 0.3 kg per axis, 3 axes,
// T = 1 ms, a delay of one period.
#include <cmath>
#include <string>
#include <variant>

#include <gtest/gtest.h>

#include "server/commit_transaction.hpp"

namespace hapticd::server {
namespace commit_transaction_test {

namespace cl = hapticd::client;
using cl::ErrorCode;

constexpr double kMass = 0.3, kT = 1e-3;

GainCheckPlant device_plant(std::optional<double> max_stiffness) {
    GainCheckPlant p;
    p.mass = kMass;
    p.period = kT;
    p.time_delay = kT;
    p.mass_matrix = DeviceMass::isotropic_mass(kMass, 3);
    p.max_stiffness = max_stiffness;
    return p;
}

ServerConfig device_config(std::size_t config_walls) {
    ServerConfig c;
    c.axes = 3;
    c.period = kT;
    c.delay = kT;
    c.mass = kMass;
    c.max_force = 10.0;
    c.ramp_time = 0.03;
    c.workspace_min = {-0.06, -0.06, -0.06};
    c.workspace_max = {0.06, 0.06, 0.06};
    for (std::size_t i = 0; i < config_walls; ++i)
        c.config_walls.push_back(ConfigWallInfo{2, 0.05, 1.0, false, 100.0, 1.0});
    return c;
}

cl::Plane plane_z(double offset, double K, double B) {
    return cl::Plane{
        .normal = {0, 0, -1}, .offset = offset, .bilateral = false, .gains = cl::Gains::explicit_gains(K, B)};
}

CommitOperation add_op(const cl::ObjectDescription& d) { return CommitOperation{CommitOperation::Kind::Add, 0, d}; }
CommitOperation modify_op(std::uint32_t id, const cl::ObjectDescription& d) {
    return CommitOperation{CommitOperation::Kind::Modify, id, d};
}
CommitOperation remove_op(std::uint32_t id) { return CommitOperation{CommitOperation::Kind::Remove, id, std::nullopt}; }
CommitOperation clear_op() { return CommitOperation{CommitOperation::Kind::Clear, 0, std::nullopt}; }

// One device, its checker and resolver, and the slot table the commits of the tests build up.
struct Rig {
    explicit Rig(std::size_t config_walls = 1, std::optional<double> max_stiffness = std::nullopt)
        : config(device_config(config_walls)), checker(device_plant(max_stiffness)), resolver(config, checker) {}

    CommitOutcome commit(std::uint64_t session, std::vector<CommitOperation> ops) {
        return plan_commit(CommitContext{config, checker, resolver}, slots, session, next_id,
                           CommitRequest{std::move(ops)});
    }
    // Commits and adopts the plan (as the server does once the batch is in the ring); fails the test if refused.
    CommitPlan adopt(std::uint64_t session, std::vector<CommitOperation> ops) {
        CommitOutcome o = commit(session, std::move(ops));
        if (const auto* r = std::get_if<CommitRefusal>(&o)) {
            ADD_FAILURE() << r->refusal.message;
            return {};
        }
        CommitPlan plan = std::get<CommitPlan>(o);
        slots = plan.slots;
        next_id = plan.next_object_id;
        return plan;
    }

    ServerConfig config;
    GainChecker checker;
    ObjectResolver resolver;
    SlotTable slots{};
    std::uint32_t next_id = 1;
};

const SlotUpdate* update_of(const ObjectCommit& c, std::size_t slot) {
    for (std::uint32_t i = 0; i < c.count; ++i) {
        if (c.updates[i].slot == slot) return &c.updates[i];
    }
    return nullptr;
}

TEST(CommitTransaction, AddsGetIdsAfterTheConfigWallsAndOneSetEach) {
    Rig rig(2);
    const CommitPlan plan = rig.adopt(7, {add_op(plane_z(-0.01, 100, 1)), add_op(plane_z(-0.02, 100, 1))});
    EXPECT_EQ(plan.new_ids, (std::vector<std::uint32_t>{3, 4}));  // config walls are 1 and 2
    EXPECT_EQ(plan.next_object_id, 5U);
    ASSERT_EQ(plan.batch.count, 2U);
    for (std::size_t slot = 0; slot < 2; ++slot) {
        const SlotUpdate* u = update_of(plan.batch, slot);
        ASSERT_NE(u, nullptr);
        EXPECT_EQ(u->action, SlotUpdate::Action::Set);
        EXPECT_EQ(u->params.id, plan.new_ids[slot]);
        EXPECT_EQ(plan.slots[slot].state, ServerSlot::State::Used);
        EXPECT_EQ(plan.slots[slot].owner, 7U);
        EXPECT_EQ(plan.slots[slot].id, plan.new_ids[slot]);
    }
    EXPECT_EQ(plan.slots[2].state, ServerSlot::State::Free);
}

TEST(CommitTransaction, ARefusedOperationRefusesTheWholeBatchNamingIt) {
    Rig rig;
    const SlotTable before = rig.slots;
    const CommitOutcome o = rig.commit(7, {add_op(plane_z(-0.01, 100, 1)), modify_op(99, plane_z(-0.01, 100, 1))});
    const auto* r = std::get_if<CommitRefusal>(&o);
    ASSERT_NE(r, nullptr);
    EXPECT_EQ(r->refusal.code, ErrorCode::UnknownObject);
    EXPECT_EQ(r->op_index, 1);
    EXPECT_EQ(r->refusal.message, "commit: ops[1]: object_id = 99: no such object in the scene");
    for (std::size_t i = 0; i < kSceneObjectCapacity; ++i) EXPECT_EQ(rig.slots[i].state, before[i].state);
}

TEST(CommitTransaction, ConfigWallsAndOtherSessionsObjectsAreNotOwned) {
    Rig rig(1);
    const std::uint32_t id = rig.adopt(7, {add_op(plane_z(-0.01, 100, 1))}).new_ids.at(0);
    auto refusal_of = [&](std::uint64_t session, CommitOperation op) {
        const CommitOutcome o = rig.commit(session, {std::move(op)});
        const auto* r = std::get_if<CommitRefusal>(&o);
        return r != nullptr ? std::optional<CommitRefusal>(*r) : std::nullopt;
    };
    const auto wall = refusal_of(7, remove_op(1));
    ASSERT_TRUE(wall);
    EXPECT_EQ(wall->refusal.code, ErrorCode::NotOwner);
    EXPECT_NE(wall->refusal.message.find("config-file wall"), std::string::npos) << wall->refusal.message;
    const auto other = refusal_of(8, modify_op(id, plane_z(-0.02, 100, 1)));
    ASSERT_TRUE(other);
    EXPECT_EQ(other->refusal.code, ErrorCode::NotOwner);
    EXPECT_EQ(other->op_index, 0);
    EXPECT_NE(other->refusal.message.find("belongs to session 7, not to this one (8)"), std::string::npos)
        << other->refusal.message;
    EXPECT_FALSE(refusal_of(7, remove_op(id)));
}

TEST(CommitTransaction, AModifyOfWhereOnlyIsAMoveAnyOtherChangeASet) {
    Rig rig;
    const std::uint32_t id = rig.adopt(7, {add_op(plane_z(-0.01, 100, 1))}).new_ids.at(0);
    const CommitPlan moved = rig.adopt(7, {modify_op(id, plane_z(-0.02, 100, 1))});
    ASSERT_EQ(moved.batch.count, 1U);
    EXPECT_EQ(moved.batch.updates[0].action, SlotUpdate::Action::Move);
    EXPECT_EQ(moved.batch.updates[0].params.offset, -0.02);
    EXPECT_EQ(moved.batch.updates[0].params.id, id);
    const CommitPlan stiffer = rig.adopt(7, {modify_op(id, plane_z(-0.02, 200, 1))});
    ASSERT_EQ(stiffer.batch.count, 1U);
    EXPECT_EQ(stiffer.batch.updates[0].action, SlotUpdate::Action::Set);
    EXPECT_EQ(stiffer.batch.updates[0].params.K, 200.0);
    EXPECT_TRUE(stiffer.new_ids.empty());
}

TEST(CommitTransaction, RemoveAndClearDrainOnlyTheSessionsObjects) {
    Rig rig;
    const auto mine = rig.adopt(7, {add_op(plane_z(-0.01, 100, 1)), add_op(plane_z(-0.02, 100, 1))}).new_ids;
    const auto theirs = rig.adopt(8, {add_op(plane_z(-0.03, 100, 1))}).new_ids;
    const CommitPlan cleared = rig.adopt(7, {clear_op()});
    ASSERT_EQ(cleared.batch.count, 2U);
    for (std::uint32_t i = 0; i < cleared.batch.count; ++i)
        EXPECT_EQ(cleared.batch.updates[i].action, SlotUpdate::Action::Remove);
    std::size_t draining = 0, used = 0;
    for (const ServerSlot& s : cleared.slots) {
        if (s.state == ServerSlot::State::Draining) {
            ++draining;
            EXPECT_EQ(s.owner, 7U);
            EXPECT_EQ(s.drain_seq, kNotPushed);
        }
        if (s.state == ServerSlot::State::Used) {
            ++used;
            EXPECT_EQ(s.id, theirs.at(0));
        }
    }
    EXPECT_EQ(draining, 2U);
    EXPECT_EQ(used, 1U);
    EXPECT_EQ(objects_held(cleared.slots, 7), 0U);  // ramping out: no longer the session's
}

TEST(CommitTransaction, AnAddThenRemoveInOneBatchIsOneRemoveOfThatSlot) {
    Rig rig(0);
    const CommitPlan plan = rig.adopt(7, {add_op(plane_z(-0.01, 100, 1)), remove_op(1)});
    EXPECT_EQ(plan.new_ids, (std::vector<std::uint32_t>{1}));
    ASSERT_EQ(plan.batch.count, 1U);
    EXPECT_EQ(plan.batch.updates[0].action, SlotUpdate::Action::Remove);
    EXPECT_EQ(plan.slots[0].state, ServerSlot::State::Draining);
}

TEST(CommitTransaction, TheSessionLimitAndTheScenesCapacity) {
    Rig rig;
    rig.config.session_max_objects = 1;
    rig.adopt(7, {add_op(plane_z(-0.01, 100, 1))});
    const CommitOutcome limited = rig.commit(7, {add_op(plane_z(-0.02, 100, 1))});
    const auto* r = std::get_if<CommitRefusal>(&limited);
    ASSERT_NE(r, nullptr);
    EXPECT_EQ(r->refusal.code, ErrorCode::SessionLimit);
    EXPECT_EQ(r->op_index, 0);
    // Every slot taken (by other sessions' objects, some ramping out): capacity.
    rig.config.session_max_objects = 32;
    for (std::size_t i = 1; i < kSceneObjectCapacity; ++i) {
        rig.slots[i] = rig.slots[0];
        rig.slots[i].owner = 9;
        rig.slots[i].id = static_cast<std::uint32_t>(100 + i);
        if (i % 2 == 0) rig.slots[i].state = ServerSlot::State::Draining;
    }
    const CommitOutcome full = rig.commit(8, {add_op(plane_z(-0.02, 100, 1))});
    const auto* f = std::get_if<CommitRefusal>(&full);
    ASSERT_NE(f, nullptr);
    EXPECT_EQ(f->refusal.code, ErrorCode::Capacity);
    EXPECT_NE(f->refusal.message.find("the scene holds 64 client objects"), std::string::npos) << f->refusal.message;
}

TEST(CommitTransaction, AnUnstableObjectIsRefusedWithItsLargestStableK) {
    Rig rig;
    // alpha = K T^2 / m = 33: far outside the stability region of every delay.
    const CommitOutcome o = rig.commit(7, {add_op(plane_z(-0.01, 100, 1)), add_op(plane_z(-0.01, 1e7, 0))});
    const auto* r = std::get_if<CommitRefusal>(&o);
    ASSERT_NE(r, nullptr);
    EXPECT_EQ(r->refusal.code, ErrorCode::UnstableGains);
    EXPECT_EQ(r->op_index, 1);
    ASSERT_TRUE(r->refusal.largest_stable_K);
    EXPECT_LT(*r->refusal.largest_stable_K, 1e7);
    EXPECT_EQ(r->refusal.message.rfind("commit: ops[1]: plane: K = 1e+07 N/m", 0), 0U) << r->refusal.message;
}

TEST(CommitTransaction, TheSummedStiffnessLimitRefusesTheSceneNotAnObject) {
    Rig rig(0, 1000.0);
    const CommitOutcome o = rig.commit(7, {add_op(plane_z(-0.01, 600, 5)), add_op(plane_z(-0.01, 600, 5))});
    const auto* r = std::get_if<CommitRefusal>(&o);
    ASSERT_NE(r, nullptr) << "each plane is within the limit, their sum 1200 N/m is not";
    EXPECT_EQ(r->refusal.code, ErrorCode::BeyondDeviceLimits);
    EXPECT_EQ(r->op_index, -1);
    EXPECT_EQ(
        r->refusal.message.rfind("commit: the summed stiffness of the scene along its stiffest direction, 1200 N/m", 0),
        0U)
        << r->refusal.message;
    EXPECT_TRUE(std::holds_alternative<CommitPlan>(rig.commit(7, {add_op(plane_z(-0.01, 600, 5))})));
}

TEST(CommitTransaction, TwoStablePlanesWhoseSumIsUnstableAreRefusedAsASum) {
    Rig rig(0);
    // A pair (K, B) stable with the mass (and 1.2 K as well: not at the edge) while (2K, 2B) is not: the sum
    // of two such bilateral planes on one axis (always engaged together) is the latter. The stability region
    // is bounded, so K near the edge at some beta = B T / m is such a pair; found by a scan.
    double K = 0.0, B = 0.0;
    for (double beta = 0.05; beta < 2.0 && K == 0.0; beta += 0.05) {
        const double b = beta * kMass / kT;
        for (double k = 100.0; k < 1e7; k *= 1.05) {
            if (rig.checker.pair_is_stable(k, b, kMass) && rig.checker.pair_is_stable(1.2 * k, b, kMass) &&
                !rig.checker.pair_is_stable(2 * k, 2 * b, kMass)) {
                K = k;
                B = b;
                break;
            }
        }
    }
    ASSERT_GT(K, 0.0);
    cl::Plane p = plane_z(-0.01, K, B);
    p.bilateral = true;
    const CommitOutcome o = rig.commit(7, {add_op(p), add_op(p)});
    const auto* r = std::get_if<CommitRefusal>(&o);
    ASSERT_NE(r, nullptr);
    EXPECT_EQ(r->refusal.code, ErrorCode::UnstableSum);
    EXPECT_EQ(r->op_index, -1);
    EXPECT_EQ(r->refusal.message.rfind("commit: ", 0), 0U);
    // One of them alone is accepted.
    EXPECT_TRUE(std::holds_alternative<CommitPlan>(rig.commit(7, {add_op(p)})));
}

}  // namespace commit_transaction_test
}  // namespace hapticd::server
