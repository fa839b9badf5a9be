// SPDX-License-Identifier: Apache-2.0
// The record step (run_outputs.hpp).
#include "daemon/run_outputs.hpp"

#include <iostream>
#include <string>

#include "common/startup_error.hpp"
#include "daemon/record_replay.hpp"

namespace hapticd {

std::unique_ptr<TraceWriter> open_trace(const Options& o) {
    std::unique_ptr<TraceWriter> trace;
    if (!o.trace.empty()) {
        try {
            trace = std::make_unique<TraceWriter>(o.trace, static_cast<std::size_t>(o.trace_capacity), o.lockstep);
        } catch (const std::exception& e) {
            throw StartupError(ErrorKind::Usage, e.what());
        }
    }
    return trace;
}

std::unique_ptr<Recorder> open_recorder(int argc, const char* const* argv, const Options& o,
                                        const DeviceProfile& profile) {
    std::unique_ptr<Recorder> recorder;
    if (!o.record.empty()) {
        try {
            recorder = std::make_unique<Recorder>(o.record, recording_header(argc, argv, o, profile).dump(),
                                                  static_cast<std::size_t>(o.record_capacity), o.lockstep);
        } catch (const std::exception& e) {
            throw StartupError(ErrorKind::Usage, e.what());
        }
    }
    return recorder;
}

std::ofstream open_summary(const Options& o) {
    std::ofstream summary;
    if (!o.summary_json.empty()) {
        summary.open(o.summary_json);
        if (!summary)
            throw StartupError(ErrorKind::Usage, "summary-json = '" + o.summary_json + "': cannot open for writing");
    }
    return summary;
}

void finish_trace(TraceWriter* trace, RunReport& report, const Options& o) {
    if (trace) {
        report.trace_error = !trace->close();
        report.trace_dropped = trace->dropped();
        report.trace_written = trace->written();
        if (report.trace_error) std::cerr << "hapticd: error: writing trace '" << o.trace << "' failed\n";
        if (report.trace_dropped > 0) {
            std::cerr << "hapticd: warning: " << report.trace_dropped << " trace records dropped (trace ring full; "
                      << "raise --trace-capacity)\n";
        }
    }
}

void finish_recording(Recorder* recorder, const Options& o, std::ostream& out) {
    if (recorder) {
        const bool ok = recorder->close();
        if (!ok)
            std::cerr << "hapticd: error: writing recording '" << o.record << "' failed (it is marked incomplete)\n";
        if (recorder->dropped_ticks() + recorder->dropped_batches() > 0) {
            std::cerr << "hapticd: warning: " << recorder->dropped_ticks() << " tick and "
                      << recorder->dropped_batches()
                      << " batch records dropped (recorder ring full; raise --record-capacity, or record with "
                         "--lockstep): the "
                      << "recording '" << o.record << "' is marked incomplete and cannot be replayed\n";
        }
        if (!o.quiet) {
            out << "hapticd: recorded " << recorder->ticks_written() << " ticks and " << recorder->batches_written()
                << " batches to '" << o.record << "'\n";
        }
    }
}

}  // namespace hapticd
