// SPDX-License-Identifier: Apache-2.0
// hapticd's outputs besides the device (the record step): the --trace CSV, the --record recording and the
// --summary-json file, opened before the loop (an unwritable path stops the start-up, exit 2) and closed after it
// with what they dropped or failed to write reported.
#pragma once

#include <fstream>
#include <memory>
#include <ostream>

#include "config/options.hpp"
#include "daemon/recorder.hpp"
#include "daemon/report.hpp"
#include "loop/trace.hpp"

namespace hapticd {

// Null without --trace.
std::unique_ptr<TraceWriter> open_trace(const Options& o);
// Null without --record; the header is the run's command line and files (record_replay.hpp, recording_header).
std::unique_ptr<Recorder> open_recorder(int argc, const char* const* argv, const Options& o,
                                        const DeviceProfile& profile);
// Not open without --summary-json.
std::ofstream open_summary(const Options& o);

// After the loop: closes the trace (its counters into the report) and the recording, with an error or a
// warning for what failed or was dropped; `out` gets the recording's line unless --quiet.
void finish_trace(TraceWriter* trace, RunReport& report, const Options& o);
void finish_recording(Recorder* recorder, const Options& o, std::ostream& out);

}  // namespace hapticd
