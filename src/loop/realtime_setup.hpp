// SPDX-License-Identifier: Apache-2.0
// Process set-up for real-time operation: SCHED_FIFO, mlockall and optional CPU pinning, each tried
// when requested; what did not take effect is reported (one warning line, by the caller).
#pragma once

#include <string>

namespace hapticd {

struct RealtimeRequest {
    int priority = 80;  // SCHED_FIFO priority 1..99; 0: do not ask for SCHED_FIFO
    bool lock_memory = true;
    int cpu = -1;  // pin the calling thread to this CPU; -1: no pinning
};

struct RealtimeReport {
    bool fifo = false;
    bool memory_locked = false;
    bool pinned = false;
    std::string failures;  // e.g. "SCHED_FIFO priority 80 (Operation not permitted); mlockall (...)"
};

// Applies to the calling thread (call it from the thread that runs the loop, before starting other
// threads so that they do not inherit SCHED_FIFO: the trace writer is started afterwards and resets its
// own policy).
RealtimeReport apply_realtime(const RealtimeRequest& request);

// Sets the calling thread back to SCHED_OTHER (for helper threads created after apply_realtime()).
void drop_realtime_for_this_thread() noexcept;

}  // namespace hapticd
