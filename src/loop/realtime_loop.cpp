// SPDX-License-Identifier: Apache-2.0
#include "loop/realtime_loop.hpp"

#include <cerrno>
#include <ctime>

namespace hapticd {

std::int64_t RealtimeLoop::now_ns() noexcept {
    timespec ts{};
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return static_cast<std::int64_t>(ts.tv_sec) * 1'000'000'000 + ts.tv_nsec;
}

void RealtimeLoop::sleep_until(std::int64_t t_ns) noexcept {
    timespec ts{};
    ts.tv_sec = static_cast<time_t>(t_ns / 1'000'000'000);
    ts.tv_nsec = static_cast<long>(t_ns % 1'000'000'000);
    while (clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &ts, nullptr) == EINTR) {
    }
}

}  // namespace hapticd
