// SPDX-License-Identifier: Apache-2.0
// The scene checks off the server thread: a commit's (every ramp scene and engagement pattern of the batch) and a
// departure's plan (server/departure_plan.hpp). On the Falcon's plant set a batch of oblique planes renders ramp
// scenes whose coupled verdicts take seconds (docs/benchmarks.md), and so does their ramp-out when the client leaves;
// on the server thread no other session would be answered, no state message sent and no departure noticed meanwhile.
// The server stages the work on its own thread (server/commit_transaction.hpp: operations, summed stiffness; the
// departing and staying objects), hands it here, and takes the verdict on a later pass. One check at a time: each is
// made on the scene the one before leaves, so the server holds the next until this worker is idle.
#pragma once

#include <atomic>
#include <condition_variable>
#include <mutex>
#include <optional>
#include <thread>
#include <vector>

#include "server/departure_plan.hpp"
#include "tuning/engagement_patterns.hpp"

namespace hapticd::server {

class SceneCheckWorker {
  public:
    struct Outcome {
        EngagementCheck verdict;                 // a commit's check
        std::optional<DeparturePlan> departure;  // a departure's plan (set for a departure without failure)
        const char* failure = nullptr;           // the check threw and has no verdict: what it threw (a literal)
    };

    explicit SceneCheckWorker(const GainChecker& checker);
    ~SceneCheckWorker();  // cancels the check in progress and waits for it (at most one verdict)
    SceneCheckWorker(const SceneCheckWorker&) = delete;
    SceneCheckWorker& operator=(const SceneCheckWorker&) = delete;

    // Starts check_engagement_patterns(checker, terms, step) (PatternLimit::Enforced). False, and nothing started,
    // unless idle(). Server thread.
    bool start(std::vector<SceneTerm> terms, double step);
    // Starts plan_departure(checker, fixed, leaving, staying, step). False, and nothing started, unless idle().
    bool start_departure(std::vector<SceneTerm> fixed, std::vector<DepartureObject> leaving,
                         std::vector<DepartureObject> staying, double step);
    // No check started whose verdict has not been taken or whose cancellation has not ended.
    [[nodiscard]] bool idle() const;
    // The verdict of the check started, once it is done (the worker is idle again); nothing while it runs, when
    // none was started, or when it was cancelled.
    std::optional<Outcome> take();
    // The check in progress stops before its next verdict and its verdict is dropped; idle() once it has stopped.
    void cancel();

  private:
    struct Job {
        std::vector<SceneTerm> terms;  // a commit's scene, or a departure's fixed terms
        std::vector<DepartureObject> leaving, staying;
        bool departure = false;
        double step = 1.0;
    };
    bool queue(Job job);
    void run();
    Outcome check(const Job& job);

    const GainChecker& checker_;
    mutable std::mutex mutex_;
    std::condition_variable wake_;
    enum class Stage { Idle, Queued, Running, Done } stage_ = Stage::Idle;
    Job job_;
    Outcome outcome_;
    std::atomic<bool> cancel_{false};
    bool stop_ = false;
    std::thread thread_;  // last: started once everything above is initialised
};

}  // namespace hapticd::server
