// SPDX-License-Identifier: Apache-2.0
// A criterion's first tuning off the server thread: OV on the Falcon's window:15 loop takes over a second, and the
// server thread would answer no other session meanwhile. The server parks the request that needs it (the session
// reads nothing more until it is answered), asks this worker, and takes the request again once
// GainChecker::criterion_ready says the cache holds the gains (or the tuning's error).
#pragma once

#include <condition_variable>
#include <deque>
#include <mutex>
#include <thread>

#include "tuning/object_checks.hpp"

namespace hapticd::server {

class CriterionWorker {
  public:
    explicit CriterionWorker(GainChecker& checker);
    ~CriterionWorker();  // waits for the tuning in progress (at most one criterion's)
    CriterionWorker(const CriterionWorker&) = delete;
    CriterionWorker& operator=(const CriterionWorker&) = delete;

    // Queues the criterion's tuning unless it is ready or already queued. Server thread; never blocks on a tuning.
    void request(hapticopt::Criterion criterion);

  private:
    void run();

    GainChecker& checker_;
    std::mutex mutex_;
    std::condition_variable wake_;
    std::deque<hapticopt::Criterion> queue_;  // at most one entry per criterion
    bool stop_ = false;
    std::thread thread_;
};

}  // namespace hapticd::server
