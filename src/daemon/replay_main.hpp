// SPDX-License-Identifier: Apache-2.0
// hapticd's replay step (docs/recording.md): `hapticd --replay FILE` reads the recording and runs its command line
// (run.hpp's run_main with the recording), whose run then takes these steps: the options a replay overrides, the
// loop's object slots fed from the recording (--serve), and the verdict.
#pragma once

#include <memory>

#include "config/options.hpp"
#include "daemon/daemon.hpp"
#include "daemon/record_replay.hpp"
#include "scene/scene_objects.hpp"

namespace hapticd {

// hapticd --replay FILE [--quiet]: reads the recording, enters its working directory and runs its command line
// (run_main with the recording). Exit 10 for a recording that cannot be read or rebuilt.
int replay_main(int argc, const char* const* argv);

// A replay's run (replay non-null): lockstep, quiet, no trace, summary, recorder, --serve-wait-commit, dry run
// or device list. Without a replay, --replay among the options is refused (it takes no other option).
void apply_replay_overrides(Options& o, const Recording* replay);

// --replay --serve: the loop's object slots and their rings, fed from the recording (no server).
struct ReplayObjects {
    std::unique_ptr<CommitRing> ring, departures;
    std::unique_ptr<SceneObjects> objects;
    std::unique_ptr<ReplayFeeder> feeder;
};
// Empty unless a replay of a --serve run; then cfg.feeder is its feeder.
ReplayObjects make_replay_objects(const Recording* replay, const Options& o, const DeviceProfile& profile,
                                  double period, DaemonConfig& cfg);

// The replay's exit code (0 identical, 11 not) and its lines: the first tick whose force differs (both values,
// %.17g), or the first batch taken otherwise than recorded, or a run that ended before the recording's last tick.
int replay_verdict(const Recording& r, const RunResult& run, const PlaybackDevice& device, const ReplayFeeder* feeder);

}  // namespace hapticd
