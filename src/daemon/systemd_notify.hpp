// SPDX-License-Identifier: Apache-2.0
// hapticd under systemd's Type=notify (sd_notify(3), systemd.service(5) "WatchdogSec="):
//   * READY=1 (with a STATUS= line) once the tuning is done and the device is open and homed, sent by
//     hapticd_main just before the loop starts;
//   * WATCHDOG=1 from a watchdog thread of its own (SCHED_OTHER, never the tick), every half of
//     WATCHDOG_USEC, and only when the loop's heartbeat (RealtimeLoop::heartbeat(), the count of completed
//     ticks) has advanced since the previous check: a loop that stalls while the process lives stops the
//     keep-alive, and systemd acts on the service after WatchdogSec;
//   * STOPPING=1 when the loop has ended.
// Outside systemd (no NOTIFY_SOCKET) every call is a no-op; without WATCHDOG_USEC (or with a WATCHDOG_PID
// naming another process) no watchdog thread is started. Nothing here runs on the real-time path: the loop
// only stores its tick counter into a relaxed atomic.
#pragma once

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <mutex>
#include <string>
#include <thread>

namespace hapticd {

class SystemdNotifier {
  public:
    // Reads NOTIFY_SOCKET and the watchdog interval (sd_watchdog_enabled) from the environment.
    SystemdNotifier();
    SystemdNotifier(const SystemdNotifier&) = delete;
    SystemdNotifier& operator=(const SystemdNotifier&) = delete;
    // Stops the watchdog thread; sends STOPPING=1 if READY=1 was sent and stopping() was not called.
    ~SystemdNotifier();

    // True when NOTIFY_SOCKET names a socket (hapticd runs under systemd or a test that listens).
    [[nodiscard]] bool active() const noexcept { return active_; }
    // The service's watchdog timeout (WATCHDOG_USEC); zero when the watchdog is off.
    [[nodiscard]] std::chrono::microseconds watchdog_timeout() const noexcept { return watchdog_timeout_; }

    // Sends READY=1 and STATUS=<status>; when the watchdog is on, starts the thread that sends WATCHDOG=1
    // every watchdog_timeout()/2 while `heartbeat` advances. `heartbeat` must outlive stopping().
    void ready(const std::string& status, const std::atomic<std::uint64_t>& heartbeat);
    // Stops the watchdog thread and sends STOPPING=1 and STATUS=<status>. Idempotent.
    void stopping(const std::string& status);

    // Keep-alives sent and checks at which the heartbeat had not advanced (readable after stopping()).
    [[nodiscard]] std::uint64_t keepalives_sent() const noexcept { return sent_.load(std::memory_order_relaxed); }
    [[nodiscard]] std::uint64_t keepalives_withheld() const noexcept {
        return withheld_.load(std::memory_order_relaxed);
    }

  private:
    void watch(const std::atomic<std::uint64_t>& heartbeat) noexcept;
    void stop_watching() noexcept;

    bool active_ = false;
    bool ready_sent_ = false;
    bool stopping_sent_ = false;
    std::chrono::microseconds watchdog_timeout_{0};
    std::mutex mutex_;  // guards stop_ for the condition variable (watchdog thread and main thread only)
    std::condition_variable wake_;
    bool stop_ = false;
    std::atomic<std::uint64_t> sent_{0};
    std::atomic<std::uint64_t> withheld_{0};
    std::thread thread_;
};

}  // namespace hapticd
