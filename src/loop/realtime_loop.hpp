// SPDX-License-Identifier: Apache-2.0
// The periodic loop, with a typed callback:
//     RealtimeLoop loop(config);
//     loop.run([&](const TickInput& in) -> TickOutput { ...; return {.stop = false}; });
// Absolute deadlines (clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME), optionally the last spin_ns spent
// busy-waiting on the clock); when a tick ends after the next
// deadline, that is an overrun: the missed deadlines are skipped by whole periods (the schedule stays
// aligned to the start) and counted. Wake latency (wake-up time - deadline) and compute time (callback
// duration) are recorded in preallocated statistics. In lockstep mode there is no sleeping: ticks run
// back to back, latency is 0 and no overrun is possible.
// run() does not allocate, lock, throw or do I/O; the callback must not either.
// heartbeat(): the number of completed ticks, published (relaxed atomic store) after each tick so that
// a non-real-time thread can see the loop advance (the systemd watchdog, daemon/systemd_notify.hpp).
#pragma once

#include <atomic>
#include <cstdint>

#include "loop/stats.hpp"

namespace hapticd {

struct LoopConfig {
    std::int64_t period_ns = 1'000'000;
    bool lockstep = false;
    // Sleep until spin_ns before each deadline, then busy-wait for it (0: sleep until the deadline). The
    // kernel's wake-up latency (here ~80 us mean, ~180 us p99 on a VM without PREEMPT_RT) is then spent
    // in the sleep, and the tick starts within the clock's read time of its deadline, at the cost of
    // spin_ns of CPU per period. A wake-up later than the deadline is not spun.
    std::int64_t spin_ns = 0;
};

struct TickInput {
    std::uint64_t tick = 0;             // ticks processed before this one (consecutive, no gaps)
    double time_s = 0.0;                // scheduled time of this tick since the start (period * slot)
    std::int64_t wake_latency_ns = 0;   // actual wake-up - deadline (0 in lockstep)
    std::uint64_t skipped_periods = 0;  // periods skipped just before this tick (late previous tick)
    std::uint32_t consecutive_overruns = 0;
};

struct TickOutput {
    bool stop = false;  // end the loop after this tick
};

struct LoopCounters {
    std::uint64_t ticks = 0;
    std::uint64_t overruns = 0;
    std::uint64_t skipped_periods = 0;
    std::uint32_t max_consecutive_overruns = 0;
};

class RealtimeLoop {
  public:
    explicit RealtimeLoop(const LoopConfig& config) : config_(config) {}

    template <class Callback>
    LoopCounters run(Callback&& callback) noexcept {
        const std::int64_t period = config_.period_ns;
        const std::int64_t start = now_ns() + (config_.lockstep ? 0 : period);
        std::uint64_t slot = 0;  // index of the schedule slot of the current tick
        std::uint64_t skipped = 0;
        std::uint32_t consecutive = 0;
        for (;;) {
            const std::int64_t deadline = start + static_cast<std::int64_t>(slot) * period;
            std::int64_t wake = 0;
            if (!config_.lockstep) {
                if (config_.spin_ns > 0) {
                    sleep_until(deadline - config_.spin_ns);
                    do {
                        wake = now_ns();
                    } while (wake < deadline);
                } else {
                    sleep_until(deadline);
                    wake = now_ns();
                }
            } else {
                wake = now_ns();
            }
            TickInput in;
            in.tick = counters_.ticks;
            in.time_s = static_cast<double>(slot) * static_cast<double>(period) * 1e-9;
            in.wake_latency_ns = config_.lockstep ? 0 : wake - deadline;
            in.skipped_periods = skipped;
            in.consecutive_overruns = consecutive;
            const TickOutput out = callback(static_cast<const TickInput&>(in));
            const std::int64_t end = now_ns();
            wake_latency_.record(in.wake_latency_ns);
            compute_time_.record(end - wake);
            ++counters_.ticks;
            heartbeat_.store(counters_.ticks, std::memory_order_relaxed);
            if (out.stop) {
                break;
            }
            ++slot;
            skipped = 0;
            if (!config_.lockstep) {
                const std::int64_t next = start + static_cast<std::int64_t>(slot) * period;
                if (end > next) {
                    const auto late = static_cast<std::uint64_t>((end - next) / period) + 1U;
                    slot += late;
                    skipped = late;
                    counters_.skipped_periods += late;
                    ++counters_.overruns;
                    ++consecutive;
                    if (consecutive > counters_.max_consecutive_overruns) {
                        counters_.max_consecutive_overruns = consecutive;
                    }
                } else {
                    consecutive = 0;
                }
            }
        }
        return counters_;
    }

    [[nodiscard]] const LatencyStats& wake_latency() const noexcept { return wake_latency_; }
    [[nodiscard]] const LatencyStats& compute_time() const noexcept { return compute_time_; }
    [[nodiscard]] const LoopCounters& counters() const noexcept { return counters_; }
    [[nodiscard]] const LoopConfig& config() const noexcept { return config_; }
    // Completed ticks, readable from any thread while run() runs.
    [[nodiscard]] const std::atomic<std::uint64_t>& heartbeat() const noexcept { return heartbeat_; }

    static std::int64_t now_ns() noexcept;
    // Sleeps until the absolute CLOCK_MONOTONIC time; resumes after signals (EINTR).
    static void sleep_until(std::int64_t t_ns) noexcept;

  private:
    LoopConfig config_;
    LatencyStats wake_latency_;
    LatencyStats compute_time_;
    LoopCounters counters_;
    std::atomic<std::uint64_t> heartbeat_{0};
};

}  // namespace hapticd
