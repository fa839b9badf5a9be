// SPDX-License-Identifier: Apache-2.0
#include "server/commit_check_worker.hpp"

#include <new>
#include <utility>

namespace hapticd::server {

CommitCheckWorker::CommitCheckWorker(const GainChecker& checker) : checker_(checker), thread_([this] { run(); }) {}

CommitCheckWorker::~CommitCheckWorker() {
    {
        std::lock_guard<std::mutex> lock(mutex_);
        stop_ = true;
        cancel_.store(true, std::memory_order_relaxed);
    }
    wake_.notify_one();
    thread_.join();
}

bool CommitCheckWorker::start(std::vector<SceneTerm> terms, double step) {
    {
        std::lock_guard<std::mutex> lock(mutex_);
        if (stage_ != Stage::Idle) return false;
        terms_ = std::move(terms);
        step_ = step;
        cancel_.store(false, std::memory_order_relaxed);
        stage_ = Stage::Queued;
    }
    wake_.notify_one();
    return true;
}

bool CommitCheckWorker::idle() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return stage_ == Stage::Idle;
}

std::optional<CommitCheckWorker::Outcome> CommitCheckWorker::take() {
    std::lock_guard<std::mutex> lock(mutex_);
    if (stage_ != Stage::Done) return std::nullopt;
    stage_ = Stage::Idle;
    if (cancel_.load(std::memory_order_relaxed)) return std::nullopt;
    return std::move(outcome_);
}

void CommitCheckWorker::cancel() {
    std::lock_guard<std::mutex> lock(mutex_);
    if (stage_ == Stage::Idle) return;
    cancel_.store(true, std::memory_order_relaxed);
    if (stage_ != Stage::Running) stage_ = Stage::Idle;  // queued: never starts; done: its verdict dropped
}

// The check runs outside the lock; whatever it throws (bad_alloc) is its outcome's failure, never the thread's end.
void CommitCheckWorker::run() {
    std::unique_lock<std::mutex> lock(mutex_);
    for (;;) {
        wake_.wait(lock, [this] { return stop_ || stage_ == Stage::Queued; });
        if (stop_) return;
        stage_ = Stage::Running;
        const std::vector<SceneTerm> terms = std::move(terms_);
        const double step = step_;
        lock.unlock();
        Outcome outcome;
        try {
            outcome.verdict = check_engagement_patterns(checker_, terms, step, PatternLimit::Enforced, &cancel_);
        } catch (const std::bad_alloc&) {
            outcome.failure = "out of memory (std::bad_alloc)";
        } catch (...) {
            outcome.failure = "an exception";
        }
        if (outcome.failure != nullptr) outcome.verdict.stable = false;
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
