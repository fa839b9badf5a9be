// SPDX-License-Identifier: Apache-2.0
// The replay step (replay_main.hpp).
#include "daemon/replay_main.hpp"

#include <algorithm>
#include <cstdio>
#include <iostream>
#include <string>
#include <string_view>
#include <vector>

#include <unistd.h>

#include <nlohmann/json.hpp>

#include "common/startup_error.hpp"
#include "daemon/exit_codes.hpp"
#include "daemon/recording_reader.hpp"
#include "daemon/run.hpp"
#include "server/serve_runtime.hpp"

namespace hapticd {

void apply_replay_overrides(Options& o, const Recording* replay) {
    if (replay != nullptr) {
        o.lockstep = true;
        o.quiet = true;
        o.trace.clear();
        o.summary_json.clear();
        o.record.clear();
        o.replay.clear();
        o.serve_wait_commit = false;
        o.dry_run = false;
        o.list_devices = false;
    } else if (!o.replay.empty()) {
        throw StartupError(ErrorKind::Usage,
                           "--replay takes the options from the recording: only --quiet may be given with it");
    }
}

ReplayObjects make_replay_objects(const Recording* replay, const Options& o, const DeviceProfile& profile,
                                  double period, DaemonConfig& cfg) {
    ReplayObjects r;
    if (replay != nullptr && o.serve) {
        r.ring = std::make_unique<CommitRing>(replay_ring_capacity(*replay));
        r.departures = std::make_unique<CommitRing>(replay_ring_capacity(*replay));
        r.objects =
            std::make_unique<SceneObjects>(scene_objects_config(o, profile, period), *r.ring, r.departures.get());
        r.feeder = std::make_unique<ReplayFeeder>(*replay, *r.objects, *r.ring, *r.departures);
        r.objects->set_observer(r.feeder.get());
        cfg.feeder = r.feeder.get();
    }
    return r;
}

int replay_verdict(const Recording& r, const RunResult& run, const PlaybackDevice& device, const ReplayFeeder* feeder) {
    const std::uint64_t taken = feeder != nullptr ? feeder->batches_taken() : 0;
    bool same = true;
    char line[512];
    if (device.mismatched_ticks() > 0) {
        const auto& m = device.first_mismatch();
        std::snprintf(
            line, sizeof line,
            "%llu of %llu ticks differ; the first is tick %llu: force[%zu] recorded %.17g N, replayed %.17g N",
            static_cast<unsigned long long>(device.mismatched_ticks()),
            static_cast<unsigned long long>(device.ticks_compared()), static_cast<unsigned long long>(m.tick), m.axis,
            m.recorded, m.replayed);
        std::cerr << "hapticd: error: replay of '" << r.path << "': " << line << "\n";
        same = false;
    }
    if (feeder != nullptr && feeder->mismatch()) {
        std::cerr << "hapticd: error: replay of '" << r.path << "': " << feeder->mismatch_text() << "\n";
        same = false;
    }
    if (device.ticks_compared() != r.ticks.size() || taken != r.batches.size()) {
        std::cerr << "hapticd: error: replay of '" << r.path << "': the replay ran " << device.ticks_compared()
                  << " ticks and took " << taken << " batches; the recording has " << r.ticks.size() << " ticks and "
                  << r.batches.size() << " batches"
                  << (run.fault != StateFault::None
                          ? " (the replay faulted at tick " + std::to_string(run.fault_tick) + ")"
                          : std::string())
                  << "\n";
        same = false;
    }
    if (!same) return kExitReplayMismatch;
    std::cout << "hapticd: replay of '" << r.path << "': " << device.ticks_compared() << " ticks, " << taken
              << " batches: every force identical to the recording (bit for bit)" << std::endl;
    return kExitOk;
}

int replay_main(int argc, const char* const* argv) {
    std::string file;
    bool quiet = false;
    for (int i = 1; i < argc; ++i) {
        const std::string_view a = argv[i];
        if (a == "--replay" && i + 1 < argc) {
            file = argv[++i];
        } else if (a.starts_with("--replay=")) {
            file = std::string(a.substr(9));
        } else if (a == "--quiet") {
            quiet = true;
        } else {
            throw StartupError(
                ErrorKind::Usage,
                "--replay takes the options from the recording: only --quiet may be given with it (got '" +
                    std::string(a) + "')");
        }
    }
    if (file.empty()) throw StartupError(ErrorKind::Usage, "--replay needs a FILE (a recording made with --record)");
    Recording r;
    try {
        r = read_recording(file);
    } catch (const RecordingError& e) {
        throw StartupError(ErrorKind::BadRecording, e.what());
    }
    const nlohmann::json& args = r.header.contains("argv") ? r.header["argv"] : nlohmann::json();
    if (!args.is_array() ||
        !std::all_of(args.begin(), args.end(), [](const nlohmann::json& a) { return a.is_string(); })) {
        throw StartupError(ErrorKind::BadRecording,
                           "recording '" + file + "': corrupt header: 'argv' is not an array of strings");
    }
    const std::string cwd = r.header.value("cwd", std::string());
    if (!cwd.empty() && ::chdir(cwd.c_str()) != 0) {
        throw StartupError(ErrorKind::BadRecording,
                           "recording '" + file + "': cannot enter its working directory '" + cwd +
                               "' (the relative paths of its command line are relative to it)");
    }
    std::vector<std::string> strings{"hapticd"};
    for (const auto& a : args) strings.push_back(a.get<std::string>());
    std::vector<const char*> pointers;
    for (const auto& a : strings) pointers.push_back(a.c_str());
    if (!quiet) {
        std::cout << "hapticd: replaying '" << file << "': " << r.ticks.size() << " ticks, " << r.batches.size()
                  << " batches, recorded with:";
        for (std::size_t i = 1; i < strings.size(); ++i) {
            const bool quote = strings[i].empty() || strings[i].find_first_of(" \t'\"") != std::string::npos;
            std::cout << " " << (quote ? "'" + strings[i] + "'" : strings[i]);
        }
        std::cout << std::endl;
    }
    return run_main(static_cast<int>(pointers.size()), pointers.data(), &r);
}

}  // namespace hapticd
