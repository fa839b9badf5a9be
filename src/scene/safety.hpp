// SPDX-License-Identifier: Apache-2.0
// Safety pieces of the daemon: the stop request from SIGINT/SIGTERM (an async-signal-safe atomic flag
// set by a sigaction handler) and the watchdog over the loop's timing.
#pragma once

#include <cstdint>
#include <string_view>

namespace hapticd {

// Installs handlers for SIGINT and SIGTERM that only set the stop flag (no SA_RESTART, so blocking calls
// outside the loop return EINTR; the loop's sleep resumes on its own).
void install_stop_signal_handlers();
[[nodiscard]] bool stop_requested() noexcept;
[[nodiscard]] int stop_signal() noexcept;  // the signal that requested the stop, 0 if none
void request_stop(int signal_number = 0) noexcept;
void clear_stop_request() noexcept;  // for tests

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
