// SPDX-License-Identifier: Apache-2.0
// A commit's scene check off the server thread: on the Falcon's plant set a batch of oblique planes renders ramp
// scenes whose coupled verdicts take seconds (docs/benchmarks.md), and the server thread would answer no other
// session, send no state message and notice no departure meanwhile. The server stages the commit on its own thread
// (server/commit_transaction.hpp: operations, summed stiffness), hands the scene terms here, parks the session, and
// finishes the commit once the verdict is taken. One check at a time: a later commit is checked on the scene the
// earlier one leaves, so the server holds it until this worker is idle.
#pragma once

#include <atomic>
#include <condition_variable>
#include <mutex>
#include <optional>
#include <thread>
#include <vector>

#include "tuning/engagement_patterns.hpp"

namespace hapticd::server {

class CommitCheckWorker {
  public:
    struct Outcome {
        EngagementCheck verdict;
        const char* failure = nullptr;  // the check threw and has no verdict: what it threw (a literal)
    };

    explicit CommitCheckWorker(const GainChecker& checker);
    ~CommitCheckWorker();  // cancels the check in progress and waits for it (at most one verdict)
    CommitCheckWorker(const CommitCheckWorker&) = delete;
    CommitCheckWorker& operator=(const CommitCheckWorker&) = delete;

    // Starts check_engagement_patterns(checker, terms, step) (PatternLimit::Enforced). False, and nothing started,
    // unless idle(). Server thread.
    bool start(std::vector<SceneTerm> terms, double step);
    // No check started whose verdict has not been taken or whose cancellation has not ended.
    [[nodiscard]] bool idle() const;
    // The verdict of the check started, once it is done (the worker is idle again); nothing while it runs, when
    // none was started, or when it was cancelled.
    std::optional<Outcome> take();
    // The check in progress stops before its next verdict and its verdict is dropped; idle() once it has stopped.
    void cancel();

  private:
    void run();

    const GainChecker& checker_;
    mutable std::mutex mutex_;
    std::condition_variable wake_;
    enum class Stage { Idle, Queued, Running, Done } stage_ = Stage::Idle;
    std::vector<SceneTerm> terms_;
    double step_ = 1.0;
    Outcome outcome_;
    std::atomic<bool> cancel_{false};
    bool stop_ = false;
    std::thread thread_;  // last: started once everything above is initialised
};

}  // namespace hapticd::server
