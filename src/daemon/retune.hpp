// SPDX-License-Identifier: Apache-2.0
// --retune's start-up step (docs/robust-stability.md, "Online re-tuning"): the re-tuning table of the config walls,
// row 0 the criterion's optimum for the held mass (the walls as resolve_walls tuned them) and row 1 for the released
// mass (the lower end of the profile's mass_range), each certified over the profile's whole plant set by the check
// the walls get (resolve_walls: GainChecker, a failing optimum derated); the dwell N_d of the switch certificate
// (hapticopt::minimum_dwell, the average dwell-time theorem with the Lyapunov bound per mode) over the family both
// rows x the set's masses (its ends, the released and held masses, their mean) x the arm's corners, at the loop's
// total delay; the daemon's own switches at least 2 N_d apart; the identifier's settings. Refused (StartupError
// naming what is missing) where it cannot apply: no config wall, no mass_range, an anisotropic mass, explicit gains,
// --robust, --identify, --passivity-control, --serve (the client objects' gains are not in the certificate). A --replay
// of a
// --retune recording re-tunes as the run did (the identifier sees the recorded positions and the same forces).
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "config/options.hpp"
#include "daemon/wall_retuner.hpp"
#include "daemon/wall_tuning.hpp"
#include "identification/online_mass.hpp"
#include "tuning/tuning.hpp"

namespace hapticd {

struct RetuneTable {
    double held_mass = 0.0;              // kg: the walls' tuning mass (the profile's)
    double released_mass = 0.0;          // kg: mass_range[0]
    std::vector<ResolvedWall> released;  // the walls tuned for the released mass, certified over the set
    // The switch certificate (hapticopt::DwellCertificate) over `modes` matrices: `masses` x `arms` plants x 2 rows
    // per wall with distinct gains.
    int dwell_ticks = 0;  // N_d
    double rate = 1.0;    // lambda
    double constant = 0;  // M
    double largest_spectral_radius = 0;
    std::size_t modes = 0, masses = 0, arms = 0;
    std::uint64_t min_gap = 0;  // 2 N_d: the daemon's switches at least this many ticks apart
    OnlineMassSettings identifier;
    std::size_t axis = 0;  // the identifier's axis: the first wall's
};

// Is --retune on (the flag or the profile's `retune = true`)?
[[nodiscard]] inline bool retune_requested(const Options& o, const DeviceProfile& p) { return o.retune || p.retune; }

// The table of the header comment; throws StartupError (Usage for an option it cannot apply with, BadConfig for a
// profile without what it needs, UnstableGains when no dwell is certified).
RetuneTable make_retune_table(const Options& o, const DeviceProfile& p, const TuningPlant& plant,
                              const std::vector<ResolvedWall>& walls, bool identified);

// The retuner the tick runs (validates the released rows' gains as VirtualWall does).
WallRetuner make_wall_retuner(const RetuneTable& t, const std::vector<ResolvedWall>& walls);

// The start-up lines: each wall's two rows, N_d, its method and the gap.
std::string retune_text(const RetuneTable& t, const std::vector<ResolvedWall>& walls, double period);
// The run's switches, one line each, and their count.
std::string retune_switches_text(const WallRetuner& r, double period);
// The summary's "retune" object: the table, N_d, the switches (after the run: `r` not null).
nlohmann::json retune_json(const RetuneTable& t, const std::vector<ResolvedWall>& walls, const WallRetuner* r,
                           double period);

}  // namespace hapticd
