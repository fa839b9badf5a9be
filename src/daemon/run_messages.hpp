// SPDX-License-Identifier: Apache-2.0
// What hapticd says around its run (the report step's lines; the statistics and the summary are report.hpp's):
// the start-up lines (device, velocity estimate, identification, each wall's tuning), the real-time set-up, the
// running line, systemd's ready status, the device's dropped packets, and the exit code of the run's fault with its
// error line.
#pragma once

#include <cstdint>
#include <optional>
#include <ostream>
#include <string>
#include <vector>

#include "config/options.hpp"
#include "daemon/report.hpp"
#include "daemon/wall_tuning.hpp"
#include "devices/device.hpp"
#include "devices/sim_device.hpp"
#include "identification/identification_run.hpp"
#include "tuning/tuning.hpp"

namespace hapticd {

// The start-up lines (printed unless --quiet).
void print_startup(std::ostream& out, const Options& o, const DeviceProfile& profile, double period, double delay,
                   std::int64_t period_ns, const std::vector<ResolvedWall>& walls, const RunReport& report,
                   const std::optional<IdentificationStage>& ident,
                   const std::optional<TuningResult>& configured_tuning,
                   const std::optional<IdentifiedTuning>& ident_tuning);
// Real time (not in lockstep): SCHED_FIFO, mlockall, pinning as asked, the result into the report, its line
// (unless --quiet) and a warning for what did not take effect.
void apply_realtime_step(RunReport& report, const Options& o, std::ostream& out);
// "hapticd: running ..." (printed unless --quiet).
void print_running(std::ostream& out, const Options& o, std::uint64_t max_ticks, const SimScenario& scenario,
                   const DeviceProfile& profile);
// systemd's STATUS= with READY=1.
std::string ready_status_text(const DeviceProfile& profile, const std::vector<ResolvedWall>& walls, const Options& o);
// A warning for the packets the device dropped (unless --quiet).
void warn_device_counters(const Device& device, const DeviceProfile& profile, const Options& o);
// The exit code of the run's fault, with its error line.
int fault_exit_code(const RunReport& report, const Options& o, const DeviceProfile& profile);

}  // namespace hapticd
