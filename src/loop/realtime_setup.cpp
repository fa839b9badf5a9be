// SPDX-License-Identifier: Apache-2.0
#include "loop/realtime_setup.hpp"

#include <pthread.h>
#include <sched.h>
#include <sys/mman.h>

#include <cerrno>
#include <cstring>

#if defined(__SANITIZE_ADDRESS__) || defined(__SANITIZE_THREAD__)
#define HAPTICD_SANITIZER_BUILD 1
#elif defined(__has_feature)
#if __has_feature(address_sanitizer) || __has_feature(thread_sanitizer)
#define HAPTICD_SANITIZER_BUILD 1
#endif
#endif

namespace hapticd {

namespace {
void append(std::string& s, const std::string& what, int err) {
    if (!s.empty()) s += "; ";
    s += what + " (" + std::strerror(err) + ")";
}
}  // namespace

RealtimeReport apply_realtime(const RealtimeRequest& request) {
    RealtimeReport report;
    if (request.lock_memory) {
#ifdef HAPTICD_SANITIZER_BUILD
        // ASan/TSan map terabytes of shadow memory: locking it all would exhaust the machine.
        if (!report.failures.empty()) report.failures += "; ";
        report.failures += "mlockall (skipped: sanitizer build)";
#else
        if (mlockall(MCL_CURRENT | MCL_FUTURE) == 0) {
            report.memory_locked = true;
        } else {
            append(report.failures, "mlockall", errno);
        }
#endif
    }
    if (request.priority > 0) {
        sched_param param{};
        param.sched_priority = request.priority;
        const int rc = pthread_setschedparam(pthread_self(), SCHED_FIFO, &param);
        if (rc == 0) {
            report.fifo = true;
        } else {
            append(report.failures, "SCHED_FIFO priority " + std::to_string(request.priority), rc);
        }
    }
    if (request.cpu >= 0) {
        cpu_set_t set;
        CPU_ZERO(&set);
        CPU_SET(request.cpu, &set);
        const int rc = pthread_setaffinity_np(pthread_self(), sizeof set, &set);
        if (rc == 0) {
            report.pinned = true;
        } else {
            append(report.failures, "CPU pinning to CPU " + std::to_string(request.cpu), rc);
        }
    }
    return report;
}

void drop_realtime_for_this_thread() noexcept {
    sched_param param{};
    param.sched_priority = 0;
    pthread_setschedparam(pthread_self(), SCHED_OTHER, &param);
}

}  // namespace hapticd
