// SPDX-License-Identifier: Apache-2.0
// The commit transaction on the server thread (docs/protocol.md, section 5): a batch of operations (add,
// modify, remove, clear) applied to a copy of the slot table, all-or-nothing. Each operation resolves and
// checks its object (server/object_resolution.hpp) and its slot; then the scene that would result is checked
// as a whole: the summed stiffness against the device's limit, and every scene the loop can render on the way
// (the final scene and each ramp scene, every engagement pattern; tuning/engagement_patterns.hpp), the last in a
// stage of its own so that the server can run it on another thread (stage_commit, finish_commit). The result
// is either the refusal (with the failing operation's index, -1 for the scene checks) or the plan: the new slot
// table, the loop's batch and the new objects' ids. Nothing here touches a socket, a ring or a session: the
// server hands the plan's batch to the loop and adopts its table only once the batch is in the ring.
#pragma once

#include <cstdint>
#include <variant>
#include <vector>

#include "server/message_decoder.hpp"
#include "server/object_resolution.hpp"
#include "tuning/engagement_patterns.hpp"

namespace hapticd::server {

// What a commit reads besides the slot table: the device and its limits (config: config walls, axes, period,
// ramp_time, session_max_objects), the stability checker and the object resolver built on the two.
struct CommitContext {
    const ServerConfig& config;
    const GainChecker& checker;
    ObjectResolver& resolver;
    const MeshLookup* meshes = nullptr;  // the committing session's meshes (null: a mesh object is refused)
};

struct CommitPlan {
    SlotTable slots{};   // the table after the batch (removed objects Draining, drain_seq kNotPushed)
    ObjectCommit batch;  // the loop's updates, one per changed slot (count 0: nothing changes); seq unset
    std::vector<std::uint32_t> new_ids;  // the added objects' ids, in the order of the adds
    std::uint32_t next_object_id = 1;    // the id the next add gets
    std::size_t scenes_checked = 0;      // scene verdicts of the rendered-scene check (EngagementCheck::checks) ...
    std::size_t scenes_sampled = 0;      // ... and of them accepted on the sampled verdict (EngagementCheck::sampled)
};

struct CommitRefusal {
    Refusal refusal;  // message prefixed "commit: ops[i]: " or "commit: "
    int op_index = -1;
};

using CommitOutcome = std::variant<CommitPlan, CommitRefusal>;

// A batch whose operations are applied and whose summed stiffness is within the limit: what is left is the check of
// every scene it renders (check_engagement_patterns on `terms` with `step`), the one part that can take seconds
// (docs/protocol.md, section 5). The server runs that part off its thread (server/scene_check_worker.hpp).
struct StagedCommit {
    CommitPlan plan;               // scenes_checked / scenes_sampled unset
    std::vector<SceneTerm> terms;  // every term of the check: config walls, Base, In, Out
    double step = 1.0;             // period / ramp_time (1: no ramp)
};

using StagedOutcome = std::variant<StagedCommit, CommitRefusal>;

// The batch `request` of session `session` on the scene `slots` (next_object_id: the id the next add gets,
// at least 1 + the number of config walls): every operation applied, the summed stiffness checked.
[[nodiscard]] StagedOutcome stage_commit(const CommitContext& context, const SlotTable& slots, std::uint64_t session,
                                         std::uint32_t next_object_id, const CommitRequest& request);

// A staged batch's plan with the verdict of its scenes (not cancelled): the plan, or the refusal naming the scene.
[[nodiscard]] CommitOutcome finish_commit(CommitPlan plan, const EngagementCheck& verdict);

// stage_commit, the scene check on this thread, finish_commit.
[[nodiscard]] CommitOutcome plan_commit(const CommitContext& context, const SlotTable& slots, std::uint64_t session,
                                        std::uint32_t next_object_id, const CommitRequest& request);

}  // namespace hapticd::server
