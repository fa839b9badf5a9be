// SPDX-License-Identifier: Apache-2.0
#include "server/criterion_worker.hpp"

#include <algorithm>

namespace hapticd::server {

CriterionWorker::CriterionWorker(GainChecker& checker) : checker_(checker), thread_([this] { run(); }) {}

CriterionWorker::~CriterionWorker() {
    {
        std::lock_guard<std::mutex> lock(mutex_);
        stop_ = true;
    }
    wake_.notify_one();
    thread_.join();
}

void CriterionWorker::request(hapticopt::Criterion criterion) {
    if (checker_.criterion_ready(criterion)) return;
    {
        std::lock_guard<std::mutex> lock(mutex_);
        if (std::find(queue_.begin(), queue_.end(), criterion) != queue_.end()) return;
        queue_.push_back(criterion);
    }
    wake_.notify_one();
}

void CriterionWorker::run() {
    std::unique_lock<std::mutex> lock(mutex_);
    for (;;) {
        wake_.wait(lock, [this] { return stop_ || !queue_.empty(); });
        if (stop_) return;
        const hapticopt::Criterion criterion = queue_.front();
        lock.unlock();
        checker_.prepare_criterion(criterion);  // noexcept: an error is cached for the request to report
        lock.lock();
        queue_.pop_front();
    }
}

}  // namespace hapticd::server
