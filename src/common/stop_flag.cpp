// SPDX-License-Identifier: Apache-2.0
#include "common/stop_flag.hpp"

#include <atomic>
#include <cerrno>
#include <csignal>
#include <cstring>
#include <system_error>

namespace hapticd {

namespace {
std::atomic<int> g_stop_signal{0};
std::atomic<bool> g_stop{false};
static_assert(std::atomic<int>::is_always_lock_free && std::atomic<bool>::is_always_lock_free,
              "the signal handler needs lock-free atomics");

extern "C" void on_stop_signal(int sig) {
    g_stop_signal.store(sig, std::memory_order_relaxed);
    g_stop.store(true, std::memory_order_release);
}
}  // namespace

void install_stop_signal_handlers() {
    struct sigaction sa;
    std::memset(&sa, 0, sizeof sa);
    sa.sa_handler = on_stop_signal;
    sigemptyset(&sa.sa_mask);
    sa.sa_flags = 0;
    for (int sig : {SIGINT, SIGTERM}) {
        if (sigaction(sig, &sa, nullptr) != 0) {
            throw std::system_error(errno, std::generic_category(), "sigaction");
        }
    }
}

bool stop_requested() noexcept { return g_stop.load(std::memory_order_acquire); }
int stop_signal() noexcept { return g_stop_signal.load(std::memory_order_relaxed); }

void request_stop(int signal_number) noexcept {
    g_stop_signal.store(signal_number, std::memory_order_relaxed);
    g_stop.store(true, std::memory_order_release);
}

void clear_stop_request() noexcept {
    g_stop_signal.store(0, std::memory_order_relaxed);
    g_stop.store(false, std::memory_order_release);
}

}  // namespace hapticd
