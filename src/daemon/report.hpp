// SPDX-License-Identifier: Apache-2.0
// What hapticd prints and writes at the end: the tuning lines, the loop statistics and the summary JSON.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include <nlohmann/json_fwd.hpp>

#include "daemon/daemon.hpp"
#include "config/options.hpp"
#include "loop/realtime_setup.hpp"
#include "tuning/tuning.hpp"

namespace hapticd {

struct WallReport {
    std::string spec;  // canonical "axis=.. position=.. direction=.. mode=.."
    TuningResult tuning;
};

struct RunReport {
    const Options* options = nullptr;
    const DeviceProfile* profile = nullptr;
    double period = 0.0;
    double delay = 0.0;  // total, s
    std::vector<WallReport> walls;
    bool ran = false;  // false: dry run or stopped before the loop
    RunResult run;
    const RealtimeLoop* loop = nullptr;  // statistics (null when not run)
    RealtimeReport realtime;
    bool realtime_requested = false;
    std::uint64_t trace_dropped = 0;
    std::uint64_t trace_written = 0;
    bool trace_error = false;
    std::uint64_t saturated_ticks = 0;  // ticks whose written force the force limiter saturated (run.limiter)
    bool passivity_control = false;     // --passivity-control: `passivity` holds its counters
    PassivityControlStats passivity;
    std::string device_error;  // device's last_error() after a device fault
    int exit_code = 0;
};

// "K = ... N/m, B = ... N s/m, alpha = ..., beta = ..., predicted CE2 = ..., alpha/alpha_max = ..."
std::string tuning_line(const TuningResult& t, bool rotary);
// "encoder step q m: force noise sigma_F = ...; at rest in contact ..." (TuningResult::force_noise_std, ::chatter);
// empty without an encoder step.
std::string encoder_line(const TuningResult& t, bool rotary);
std::string statistics_text(const RunReport& r);
nlohmann::json summary_json(const RunReport& r);

}  // namespace hapticd
