// SPDX-License-Identifier: Apache-2.0
// Safety pieces of the daemon: the watchdog over the loop's timing. The faults that end a run are
// hapticd::StateFault (include/hapticd/state_layout.hpp); the stop request from SIGINT/SIGTERM is
// common/stop_flag.hpp.
#pragma once

#include <cstdint>

#include "common/stop_flag.hpp"

namespace hapticd {

struct WatchdogConfig {
    std::uint32_t max_consecutive_overruns = 50;  // more than this many overruns in a row is a fault
    std::uint64_t max_skipped_periods = 100;      // a single late tick skipping more periods is a stall
};

class Watchdog {
  public:
    explicit Watchdog(const WatchdogConfig& config) : config_(config) {}
    // true when the timing of this tick is a fault.
    [[nodiscard]] bool check(std::uint32_t consecutive_overruns, std::uint64_t skipped_periods) const noexcept {
        return consecutive_overruns > config_.max_consecutive_overruns || skipped_periods > config_.max_skipped_periods;
    }
    [[nodiscard]] const WatchdogConfig& config() const noexcept { return config_; }

  private:
    WatchdogConfig config_;
};

}  // namespace hapticd
