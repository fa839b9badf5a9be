// SPDX-License-Identifier: Apache-2.0
// hapticd's run (hapticd_main.cpp calls it; replay_main.hpp calls it with a recording): options, identification,
// tuning, the simulated hand's scenario, the device, the scene, the outputs, signals, the daemon's loop with the
// server, systemd, and the report, each a named step (the files of src/daemon/ named in run.cpp).
#pragma once

#include "daemon/record_replay.hpp"

namespace hapticd {

// replay: null, or the recording whose command line argv is (--replay, replay_main): then the run is that
// recording's, in lockstep on its PlaybackDevice, without server, trace, summary or recorder, and the exit code
// is the comparison's (daemon/record_replay.hpp, replay_main.hpp's replay_verdict). Throws StartupError.
int run_main(int argc, const char* const* argv, const Recording* replay = nullptr);

}  // namespace hapticd
