// SPDX-License-Identifier: Apache-2.0
#include "server/scene_check_worker.hpp"

#include <new>
#include <utility>

namespace hapticd::server {

SceneCheckWorker::SceneCheckWorker(const GainChecker& checker) : checker_(checker), thread_([this] { run(); }) {}

SceneCheckWorker::~SceneCheckWorker() {
    {
        std::lock_guard<std::mutex> lock(mutex_);
        stop_ = true;
        cancel_.store(true, std::memory_order_relaxed);
    }
    wake_.notify_one();
    thread_.join();
}

bool SceneCheckWorker::start(std::vector<SceneTerm> terms, double step) {
    return queue(Job{std::move(terms), {}, {}, false, step});
}

bool SceneCheckWorker::start_departure(std::vector<SceneTerm> fixed, std::vector<DepartureObject> leaving,
                                       std::vector<DepartureObject> staying, double step) {
    return queue(Job{std::move(fixed), std::move(leaving), std::move(staying), true, step});
}

bool SceneCheckWorker::queue(Job job) {
    {
        std::lock_guard<std::mutex> lock(mutex_);
        if (stage_ != Stage::Idle) return false;
        job_ = std::move(job);
        cancel_.store(false, std::memory_order_relaxed);
        stage_ = Stage::Queued;
    }
    wake_.notify_one();
    return true;
}

bool SceneCheckWorker::idle() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return stage_ == Stage::Idle;
}

std::optional<SceneCheckWorker::Outcome> SceneCheckWorker::take() {
    std::lock_guard<std::mutex> lock(mutex_);
    if (stage_ != Stage::Done) return std::nullopt;
    stage_ = Stage::Idle;
    if (cancel_.load(std::memory_order_relaxed)) return std::nullopt;
    return std::move(outcome_);
}

void SceneCheckWorker::cancel() {
    std::lock_guard<std::mutex> lock(mutex_);
    if (stage_ == Stage::Idle) return;
    cancel_.store(true, std::memory_order_relaxed);
    if (stage_ != Stage::Running) stage_ = Stage::Idle;  // queued: never starts; done: its verdict dropped
}

// The check runs outside the lock; whatever it throws (bad_alloc) is its outcome's failure, never the thread's end.
SceneCheckWorker::Outcome SceneCheckWorker::check(const Job& job) {
    Outcome outcome;
    try {
        if (job.departure) {
            outcome.departure = plan_departure(checker_, job.terms, job.leaving, job.staying, job.step, &cancel_);
        } else {
            outcome.verdict =
                check_engagement_patterns(checker_, job.terms, job.step, PatternLimit::Enforced, &cancel_);
        }
    } catch (const std::bad_alloc&) {
        outcome.failure = "out of memory (std::bad_alloc)";
    } catch (...) {
        outcome.failure = "an exception";
    }
    if (outcome.failure != nullptr) {
        outcome.verdict.stable = false;
        outcome.departure.reset();
    }
    return outcome;
}

void SceneCheckWorker::run() {
    std::unique_lock<std::mutex> lock(mutex_);
    for (;;) {
        wake_.wait(lock, [this] { return stop_ || stage_ == Stage::Queued; });
        if (stop_) return;
        stage_ = Stage::Running;
        const Job job = std::move(job_);
        lock.unlock();
        Outcome outcome = check(job);
        lock.lock();
        outcome_ = std::move(outcome);
        if (cancel_.load(std::memory_order_relaxed)) {
            stage_ = Stage::Idle;  // cancelled while it ran: nobody takes it
        } else {
            stage_ = Stage::Done;
        }
    }
}

}  // namespace hapticd::server
