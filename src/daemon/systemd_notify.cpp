// SPDX-License-Identifier: Apache-2.0
#include "daemon/systemd_notify.hpp"

#include <pthread.h>
#include <systemd/sd-daemon.h>

#include <cstdio>
#include <cstdlib>
#include <system_error>

#include "loop/realtime_setup.hpp"

namespace hapticd {

namespace {

// STATUS= is one line: newlines would start new assignments in the datagram.
std::string one_line(std::string s) {
    for (char& c : s) {
        if (c == '\n' || c == '\r') c = ' ';
    }
    return s;
}

}  // namespace

SystemdNotifier::SystemdNotifier() {
    const char* socket = std::getenv("NOTIFY_SOCKET");
    active_ = socket != nullptr && socket[0] != '\0';
    std::uint64_t usec = 0;
    // unset_environment = 0: the variables stay for sd_notify; hapticd starts no child processes.
    if (active_ && sd_watchdog_enabled(0, &usec) > 0 && usec > 0) {
        watchdog_timeout_ = std::chrono::microseconds(usec);
    }
}

SystemdNotifier::~SystemdNotifier() {
    if (ready_sent_ && !stopping_sent_) {
        stopping("hapticd: stopping");
    } else {
        stop_watching();
    }
}

void SystemdNotifier::ready(const std::string& status, const std::atomic<std::uint64_t>& heartbeat) {
    if (!active_ || ready_sent_) return;
    const std::string message = "READY=1\nSTATUS=" + one_line(status);
    const int rc = sd_notify(0, message.c_str());
    if (rc < 0) {
        std::fprintf(stderr,
                     "hapticd: warning: SystemdNotifier::ready: sd_notify(READY=1) failed (error %d); "
                     "systemd will not see the service as started\n",
                     -rc);
    }
    ready_sent_ = true;
    if (watchdog_timeout_.count() > 0) {
        try {
            thread_ = std::thread([this, &heartbeat] { watch(heartbeat); });
        } catch (const std::system_error& e) {  // e.g. no locked memory left for its stack after mlockall
            std::fprintf(stderr,
                         "hapticd: warning: SystemdNotifier::ready: the watchdog thread could not start (%s): "
                         "no WATCHDOG=1 will be sent; systemd acts on the service after WatchdogSec\n",
                         e.what());
        }
    }
}

void SystemdNotifier::stopping(const std::string& status) {
    stop_watching();
    if (!active_ || stopping_sent_) return;
    stopping_sent_ = true;
    const std::string message = "STOPPING=1\nSTATUS=" + one_line(status);
    sd_notify(0, message.c_str());
}

void SystemdNotifier::stop_watching() noexcept {
    {
        std::lock_guard<std::mutex> lock(mutex_);
        stop_ = true;
    }
    wake_.notify_all();
    if (thread_.joinable()) thread_.join();
}

void SystemdNotifier::watch(const std::atomic<std::uint64_t>& heartbeat) noexcept {
    // The thread may have inherited SCHED_FIFO from a caller that already applied the real-time set-up:
    // the keep-alive is no real-time work.
    drop_realtime_for_this_thread();
    pthread_setname_np(pthread_self(), "hapticd-wdog");  // as named in ps/top and the test
    const auto interval = watchdog_timeout_ / 2;
    std::uint64_t last = heartbeat.load(std::memory_order_relaxed);
    bool stalled = false;
    std::unique_lock<std::mutex> lock(mutex_);
    for (;;) {
        if (wake_.wait_for(lock, interval, [this] { return stop_; })) return;
        const std::uint64_t now = heartbeat.load(std::memory_order_relaxed);
        if (now != last) {
            sd_notify(0, "WATCHDOG=1");
            sent_.fetch_add(1, std::memory_order_relaxed);
            if (stalled) {
                std::fprintf(stderr, "hapticd: loop heartbeat advances again (tick %llu): WATCHDOG=1 resumed\n",
                             static_cast<unsigned long long>(now));
                stalled = false;
            }
            last = now;
        } else {
            withheld_.fetch_add(1, std::memory_order_relaxed);
            if (!stalled) {
                std::fprintf(stderr,
                             "hapticd: warning: loop heartbeat stalled at tick %llu: WATCHDOG=1 withheld (systemd acts "
                             "on the service after WatchdogSec = %.3f s without it)\n",
                             static_cast<unsigned long long>(now),
                             static_cast<double>(watchdog_timeout_.count()) * 1e-6);
                stalled = true;
            }
        }
    }
}

}  // namespace hapticd
