// SPDX-License-Identifier: Apache-2.0
#include "daemon/fatal_signal.hpp"

#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <csignal>
#include <cstdlib>
#include <cstring>
#include <exception>
#include <system_error>

#include "devices/device.hpp"
#include "hapticd/state_layout.hpp"
#include "server/state_publisher.hpp"

namespace hapticd {

namespace {

std::atomic<Device*> g_device{nullptr};
std::atomic<StatePublisher*> g_state{nullptr};
std::atomic<bool> g_dying{false};
constexpr int kFatalSignals[] = {SIGSEGV, SIGBUS, SIGFPE, SIGILL, SIGABRT};
alignas(16) char g_alt_stack[64 * 1024];

void write_text(const char* text) noexcept {
    std::size_t n = 0;
    while (text[n] != '\0') ++n;
    (void)!::write(STDERR_FILENO, text, n);
}

void write_number(int v) noexcept {
    char buf[16];
    int i = 15;
    buf[i] = '\0';
    unsigned u = v < 0 ? 0U : static_cast<unsigned>(v);
    do {
        buf[--i] = static_cast<char>('0' + u % 10U);
        u /= 10U;
    } while (u != 0U && i > 0);
    write_text(buf + i);
}

// Async-signal-safe: atomics, the device's signal-safe zero, the seqlock store, write(2).
void stop_everything(StateFault fault, int signal_number) noexcept {
    Device* device = g_device.load(std::memory_order_acquire);
    const bool zeroed = device != nullptr && device->zero_force_from_signal_handler();
    if (StatePublisher* state = g_state.load(std::memory_order_acquire)) state->mark_fatal(fault, signal_number);
    write_text(fault == StateFault::Terminate ? "hapticd: fatal: std::terminate" : "hapticd: fatal: signal ");
    if (fault != StateFault::Terminate) write_number(signal_number);
    write_text(zeroed ? "; zero force written to the device"
                      : (device != nullptr ? "; zero force could not be written to the device from the signal "
                                             "handler (docs/devices.md, \"A fatal signal\")"
                                           : "; no device open"));
    write_text(g_state.load(std::memory_order_acquire) != nullptr ? "; the state says fault " : "");
    if (g_state.load(std::memory_order_acquire) != nullptr) write_number(static_cast<int>(fault));
    write_text("\n");
}

void die_with(int signal_number) noexcept {
    struct sigaction sa;
    std::memset(&sa, 0, sizeof sa);
    sa.sa_handler = SIG_DFL;
    sigemptyset(&sa.sa_mask);
    (void)sigaction(signal_number, &sa, nullptr);
    sigset_t unblock;
    sigemptyset(&unblock);
    sigaddset(&unblock, signal_number);
    (void)pthread_sigmask(SIG_UNBLOCK, &unblock, nullptr);
    (void)::raise(signal_number);
    ::_exit(128 + signal_number);  // not reached: the default action of every handled signal ends the process
}

extern "C" void on_fatal_signal(int signal_number) {
    if (!g_dying.exchange(true)) stop_everything(StateFault::FatalSignal, signal_number);
    die_with(signal_number);
}

[[noreturn]] void on_terminate() noexcept {
    if (!g_dying.exchange(true)) stop_everything(StateFault::Terminate, SIGABRT);
    die_with(SIGABRT);
    std::_Exit(128 + SIGABRT);
}

}  // namespace

void install_fatal_signal_handlers(Device* device, StatePublisher* state) {
    g_device.store(device, std::memory_order_release);
    g_state.store(state, std::memory_order_release);
    stack_t ss{};
    ss.ss_sp = g_alt_stack;
    ss.ss_size = sizeof g_alt_stack;
    ss.ss_flags = 0;
    if (sigaltstack(&ss, nullptr) != 0) throw std::system_error(errno, std::generic_category(), "sigaltstack");
    struct sigaction sa;
    std::memset(&sa, 0, sizeof sa);
    sa.sa_handler = on_fatal_signal;
    sigemptyset(&sa.sa_mask);
    sa.sa_flags = SA_ONSTACK;
    for (const int sig : kFatalSignals) {
        if (sigaction(sig, &sa, nullptr) != 0) throw std::system_error(errno, std::generic_category(), "sigaction");
    }
    std::set_terminate(on_terminate);
}

void clear_fatal_signal_targets() noexcept {
    g_device.store(nullptr, std::memory_order_release);
    g_state.store(nullptr, std::memory_order_release);
}

}  // namespace hapticd
