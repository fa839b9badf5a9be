// SPDX-License-Identifier: Apache-2.0
#include "server/commit_transaction.hpp"

#include <array>
#include <optional>
#include <string>
#include <utility>
#include <variant>
#include <vector>

namespace hapticd::server {

namespace {

using client::ErrorCode;

// One batch under construction: the proposed slot table and one merged update per slot it changes.
class Transaction {
  public:
    Transaction(const CommitContext& context, const SlotTable& slots, std::uint64_t session,
                std::uint32_t next_object_id)
        : context_(context), before_(slots), proposal_(slots), session_(session), next_id_(next_object_id) {}

    // The operation applied to the proposal, or why it is refused (the message without the commit's prefix).
    std::optional<Refusal> apply(const CommitOperation& op) {
        switch (op.kind) {
            case CommitOperation::Kind::Add:
                return add(*op.object);
            case CommitOperation::Kind::Modify:
                return modify(op.object_id, *op.object);
            case CommitOperation::Kind::Remove:
                return remove(op.object_id);
            case CommitOperation::Kind::Clear:
                clear();
                return std::nullopt;
        }
        return std::nullopt;
    }

    // The stiffness limit holds for the sum as well: the device renders it when all are in contact. Every
    // term's symmetric stiffness is positive semi-definite, so no engagement pattern's sum is stiffer.
    std::optional<Refusal> check_summed_stiffness() const {
        const std::optional<double> limit = context_.checker.max_stiffness();
        if (!limit) return std::nullopt;
        // The summed stiffness of the scene that would result (every session's objects and the config walls).
        Matrix3 K_sum{}, B_unused{};
        add_config_walls(context_.config.config_walls, K_sum, B_unused);
        for (const auto& slot : proposal_) {
            if (slot.state == ServerSlot::State::Used) add_to(K_sum, slot.resolved.K_matrix);
        }
        const double largest = GainChecker::largest_stiffness(K_sum);
        if (!(largest > *limit)) return std::nullopt;
        return Refusal{ErrorCode::BeyondDeviceLimits,
                       "commit: the summed stiffness of the scene along its stiffest direction, " +
                           short_number(largest) +
                           " N/m, exceeds the device's stiffness limit (device profile key max_stiffness = " +
                           short_number(*limit) + " N/m); accepted range: <= " + short_number(*limit) +
                           " N/m (all objects are counted as in contact at once)"};
    }

    // Every scene the loop can render from this batch (tuning/engagement_patterns.hpp): the final scene and
    // every ramp scene, each with every engagement pattern of the conditional objects. The batch's new and
    // changed objects ramp in, the ones they replace or remove ramp out, everything else sits at its final
    // weight — exactly what the loop renders, since it starts this batch's ramps only once every earlier
    // batch's have ended (SceneObjects::apply_commits). Moves have no ramp.
    std::vector<SceneTerm> rendered_scene_terms() const {
        std::vector<SceneTerm> terms = terms_of_config_walls(context_.config.config_walls);
        for (std::size_t i = 0; i < kSceneObjectCapacity; ++i) {
            if (updates_[i] && updates_[i]->action != SlotUpdate::Action::Move) {
                if (updates_[i]->action == SlotUpdate::Action::Set)
                    terms.push_back(slot_term(proposal_[i], SceneTerm::Role::In));
                if (before_[i].state == ServerSlot::State::Used)
                    terms.push_back(slot_term(before_[i], SceneTerm::Role::Out));
            } else if (proposal_[i].state == ServerSlot::State::Used) {
                terms.push_back(slot_term(proposal_[i], SceneTerm::Role::Base));
            }
        }
        return terms;
    }

    double ramp_step() const {
        return context_.config.ramp_time > 0.0 ? context_.config.period / context_.config.ramp_time : 1.0;
    }

    CommitPlan finish() const {
        CommitPlan plan;
        plan.slots = proposal_;
        for (const auto& u : updates_) {
            if (u) plan.batch.updates[plan.batch.count++] = *u;
        }
        plan.new_ids = new_ids_;
        plan.next_object_id = next_id_;
        return plan;
    }

  private:
    std::optional<Refusal> add(const client::ObjectDescription& object) {
        Resolved r;
        if (auto refusal = context_.resolver.resolve(object, r, context_.meshes)) return refusal;
        std::array<bool, kSceneObjectCapacity> taken{};
        for (std::size_t i = 0; i < kSceneObjectCapacity; ++i) taken[i] = updates_[i].has_value();
        const int slot = free_slot(proposal_, taken);
        if (const std::size_t held = objects_held(proposal_, session_); held >= context_.config.session_max_objects) {
            return Refusal{ErrorCode::SessionLimit, "this session holds " + std::to_string(held) +
                                                        " objects; accepted: at most " +
                                                        std::to_string(context_.config.session_max_objects) +
                                                        " per session (option session-max-objects; the scene holds " +
                                                        std::to_string(kSceneObjectCapacity) + ")"};
        }
        if (slot < 0) {
            return Refusal{ErrorCode::Capacity,
                           "the scene holds " + std::to_string(kSceneObjectCapacity) +
                               " client objects (removed ones count until their ramp-out ends); remove some first"};
        }
        const auto first_client_id = static_cast<std::uint32_t>(1 + context_.config.config_walls.size());
        if (next_id_ < first_client_id) next_id_ = first_client_id;
        r.params.id = next_id_++;
        ServerSlot& s = proposal_[static_cast<std::size_t>(slot)];
        s.state = ServerSlot::State::Used;
        s.id = r.params.id;
        s.owner = session_;
        s.description = object;
        s.resolved = r;
        merge(static_cast<std::size_t>(slot), SlotUpdate::Action::Set, r.params);
        new_ids_.push_back(r.params.id);
        return std::nullopt;
    }

    // A modify that keeps everything but where the object is goes to the loop as a Move (no ramp).
    std::optional<Refusal> modify(std::uint32_t object_id, const client::ObjectDescription& object) {
        const SlotLookup found = owned_slot(proposal_, object_id, session_, context_.config.config_walls.size());
        if (found.refusal) return found.refusal;
        Resolved r;
        if (auto refusal = context_.resolver.resolve(object, r, context_.meshes)) return refusal;
        ServerSlot& s = proposal_[static_cast<std::size_t>(found.slot)];
        r.params.id = s.id;
        const bool move = is_move(s.resolved.params, r.params);
        s.description = object;
        s.resolved = r;
        merge(static_cast<std::size_t>(found.slot), move ? SlotUpdate::Action::Move : SlotUpdate::Action::Set,
              r.params);
        return std::nullopt;
    }

    std::optional<Refusal> remove(std::uint32_t object_id) {
        const SlotLookup found = owned_slot(proposal_, object_id, session_, context_.config.config_walls.size());
        if (found.refusal) return found.refusal;
        drain(static_cast<std::size_t>(found.slot));
        return std::nullopt;
    }

    void clear() {
        for (std::size_t i = 0; i < kSceneObjectCapacity; ++i) {
            if (proposal_[i].state == ServerSlot::State::Used && proposal_[i].owner == session_) drain(i);
        }
    }

    void drain(std::size_t slot) {
        ServerSlot& s = proposal_[slot];
        s.state = ServerSlot::State::Draining;
        s.drain_seq = kNotPushed;
        merge(slot, SlotUpdate::Action::Remove, s.resolved.params);
    }

    // Several operations on one slot become one update: a Remove wins, a Set and a Move make a Set, the last
    // operation's params are what the loop gets.
    void merge(std::size_t slot, SlotUpdate::Action action, const ObjectParams& params) {
        auto& u = updates_[slot];
        if (!u) {
            u = SlotUpdate{static_cast<std::uint8_t>(slot), action, params};
            return;
        }
        if (action == SlotUpdate::Action::Remove) {
            u->action = SlotUpdate::Action::Remove;
        } else if (action == SlotUpdate::Action::Set || u->action == SlotUpdate::Action::Set) {
            u->action = SlotUpdate::Action::Set;
        }
        u->params = params;
    }

    const CommitContext& context_;
    const SlotTable& before_;
    SlotTable proposal_;
    std::array<std::optional<SlotUpdate>, kSceneObjectCapacity> updates_{};
    std::vector<std::uint32_t> new_ids_;
    std::uint64_t session_;
    std::uint32_t next_id_;
};

}  // namespace

StagedOutcome stage_commit(const CommitContext& context, const SlotTable& slots, std::uint64_t session,
                           std::uint32_t next_object_id, const CommitRequest& request) {
    Transaction t(context, slots, session, next_object_id);
    int op_index = 0;
    for (const auto& op : request.ops) {
        if (auto refusal = t.apply(op)) {
            refusal->message = "commit: ops[" + std::to_string(op_index) + "]: " + refusal->message;
            return CommitRefusal{std::move(*refusal), op_index};
        }
        ++op_index;
    }
    if (auto refusal = t.check_summed_stiffness()) return CommitRefusal{std::move(*refusal), -1};
    return StagedCommit{t.finish(), t.rendered_scene_terms(), t.ramp_step()};
}

CommitOutcome finish_commit(CommitPlan plan, const EngagementCheck& verdict) {
    if (!verdict.stable) {
        return CommitRefusal{Refusal{verdict.over_limit ? ErrorCode::Capacity : ErrorCode::UnstableSum,
                                     "commit: " + verdict.why + " (docs/protocol.md, section 5)"},
                             -1};
    }
    plan.scenes_checked = verdict.checks;
    plan.scenes_sampled = verdict.sampled;
    return plan;
}

CommitOutcome plan_commit(const CommitContext& context, const SlotTable& slots, std::uint64_t session,
                          std::uint32_t next_object_id, const CommitRequest& request) {
    StagedOutcome staged = stage_commit(context, slots, session, next_object_id, request);
    if (auto* refusal = std::get_if<CommitRefusal>(&staged)) return std::move(*refusal);
    StagedCommit& s = std::get<StagedCommit>(staged);
    const EngagementCheck verdict = check_engagement_patterns(context.checker, s.terms, s.step);
    return finish_commit(std::move(s.plan), verdict);
}

}  // namespace hapticd::server
