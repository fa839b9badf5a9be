// SPDX-License-Identifier: Apache-2.0
// What ramps out when a session ends (a disconnect, a lost lease, a closed slow consumer): the rule of
// docs/protocol.md, section 5, "A client that leaves". Runs in the scene-check worker (server/scene_check_worker.hpp),
// never in the loop.
//
// The loop renders, from the tick the departure batch is applied, base + (1 - s_j)^2 K_out and
// base + (1 - s_j) B_out (s_j = j T / ramp_s, the loop's ramp weights r^2 for stiffness, r for damping),
// then base alone: "out" the objects that ramp out, "base" the config walls and every object that stays,
// at its final weight (the loop brings every batch sent before the departure to its final state before it
// starts the ramp-out, SceneObjects::take_departures, so base is the scene the server's slots describe). The departing
// session's objects alone need not leave a stable scene: a sum may be stable only with them (A + B unstable, A + B + C
// stable). So:
//   1. out = the departing objects; accepted if base and every ramp scene pass, each with every engagement
//      pattern of the conditional objects (check_engagement_patterns: every scene the loop will render).
//   2. Otherwise the fewest further client objects ramp out with them: every set of 1, then 2, ... of the
//      staying client objects (slot order), until one passes, kDepartureSearchBudget sets have been
//      tried, or the sets tried have cost kDepartureCheckBudget scene verdicts (each set up to 1 / step
//      scenes times its patterns, ~20-60 us a verdict).
//   3. Otherwise every client object ramps out (base = the config walls, checked at start-up), if its
//      ramp scenes pass.
//   4. Otherwise every client object is cut at once (SlotUpdate::Action::Cut, no ramp): the loop jumps from
//      the scene before (checked when it was committed) to the config walls alone (checked at start-up),
//      and renders no scene in between.
// The owners of objects removed in 2-4 get an event naming them and the reason (server_departures.cpp).
#pragma once

#include <atomic>
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "tuning/engagement_patterns.hpp"
#include "tuning/object_checks.hpp"

namespace hapticd {

// Sets a departure may try, and scene verdicts it may spend, on finding the fewest further objects (step 2
// above): bounds step 2 to ~2048 x 20-60 us ~ 40-120 ms (the sets' count
// alone, 64 x 30 scenes at the default 30 ms ramp, was the bound before engagement patterns).
inline constexpr std::size_t kDepartureSearchBudget = 64;
inline constexpr std::size_t kDepartureCheckBudget = 2048;

struct DepartureObject {
    std::size_t slot = 0;
    std::uint64_t owner = 0;
    SceneTerm term;  // what it renders (its role is set by the plan)
};

struct DeparturePlan {
    std::vector<std::size_t> out;      // slots that ramp out (or are cut): the departing ones first
    std::vector<std::size_t> further;  // of those, the staying objects removed with them (steps 2-4)
    bool cut = false;                  // step 4: removed at once, no ramp
    std::string reason;                // why the departing objects alone could not ramp out (steps 2-4)
    bool cancelled = false;            // stopped at `cancel`: nothing above holds
};

// The rule above. `fixed`: the config walls (Base terms); `step` = T / ramp_s (>= 1: no ramp). `cancel` (may be
// null) is read before each verdict: once true the plan ends at once and means nothing (`cancelled`).
DeparturePlan plan_departure(const GainChecker& checker, const std::vector<SceneTerm>& fixed,
                             const std::vector<DepartureObject>& leaving, const std::vector<DepartureObject>& staying,
                             double step, const std::atomic<bool>* cancel = nullptr);

}  // namespace hapticd
