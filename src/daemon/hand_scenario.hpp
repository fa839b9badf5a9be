// SPDX-License-Identifier: Apache-2.0
// hapticd's simulated-hand step: the scenario the simulated device runs (the hand's intent, its schedule of
// releases and grips), the warnings when a tuned wall is unstable with the hand, and the hand's events as they
// happened, for the statistics lines and the summary.
#pragma once

#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "config/options.hpp"
#include "daemon/report.hpp"
#include "daemon/wall_tuning.hpp"
#include "devices/sim_device.hpp"

namespace hapticd {

// The scenario of the options and the walls (the first wall's axis, surface and direction), the hand of the
// options and the profile, its schedule; refuses a release with no mass to take, warns when the schedule cannot
// act (a real device) and when a wall is unstable with the hand (warn_unstable_with_hand).
SimScenario make_scenario(const Options& o, const DeviceProfile& profile, const std::vector<ResolvedWall>& walls,
                          const RunReport& report, double period, double delay);

// The walls were tuned and checked for the profile's plant (the device with the arm's mass); the simulated
// hand adds b_H, k_H (and m_H). Usually that keeps them stable (docs/simulated-hand.md), not always: say so. The
// same for each plant the hand's schedule reaches (released: the mass without the hand's, no k_H, b_H).
void warn_unstable_with_hand(const RunReport& report, const DeviceProfile& profile, const SimScenario& scenario,
                             double period, double delay);

// The hand's events as they happened (SimDevice::hand_events): one line each.
std::string hand_events_text(const std::vector<HandEventRecord>& events, double period);
nlohmann::json hand_events_json(const std::vector<HandEventRecord>& events, double period);

}  // namespace hapticd
