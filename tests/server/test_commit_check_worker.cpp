// SPDX-License-Identifier: Apache-2.0
// server/commit_check_worker.hpp: a commit's scene check on the worker thread gives the verdict the same check gives
// on the calling thread (stable and refused scenes alike), one check at a time, a cancelled check dropped and the
// worker usable again, its destruction during a long check bounded; and check_engagement_patterns stops at `cancel`
// before its next verdict.
#include <atomic>
#include <chrono>
#include <thread>
#include <vector>

#include <gtest/gtest.h>

#include "server/commit_check_worker.hpp"
#include "tuning/engagement_patterns.hpp"

namespace hapticd {
namespace commit_check_worker_test {

// 0.30 kg on three axes, T = 1 ms, 2 ms of delay, the hand's mass range 0.25 .. 0.30 kg: the sampled coupled verdicts
// of sums whose gains do not commute.
GainCheckPlant plant() {
    GainCheckPlant p;
    p.mass = 0.30;
    p.period = 1e-3;
    p.time_delay = 0.002;
    p.mass_matrix = DeviceMass::isotropic_mass(0.30, 3);
    p.mass_range = std::make_pair(0.25, 0.30);
    return p;
}

// A unilateral wall along -x, a plane ramping in at 45 degrees to it (the two do not commute) and, with `bilateral`,
// both always engaged.
std::vector<SceneTerm> oblique_scene(double K_oblique, bool bilateral = false) {
    SceneTerm wall = plane_term({-1.0, 0.0, 0.0}, 180.0, 2.0);
    wall.conditional = !bilateral;
    wall.object_id = 1;
    const double r = 0.7071067811865476;
    SceneTerm oblique = plane_term({r, r, 0.0}, K_oblique, 1.0);
    oblique.conditional = !bilateral;
    oblique.role = SceneTerm::Role::In;
    oblique.object_id = 2;
    return {wall, oblique};
}

// The worker's verdict, waited for up to two minutes.
std::optional<server::CommitCheckWorker::Outcome> wait_for(server::CommitCheckWorker& worker) {
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::minutes(2);
    while (std::chrono::steady_clock::now() < deadline) {
        if (auto outcome = worker.take()) return outcome;
        std::this_thread::sleep_for(std::chrono::milliseconds(1));
    }
    return std::nullopt;
}

TEST(CommitCheckWorker, TheVerdictIsTheCheckOnTheCallingThread) {
    const GainChecker checker(plant());
    server::CommitCheckWorker worker(checker);
    // 100 N/m: stable in every scene; 1e6 N/m: refused (far outside the region at 0.25 kg, 2 ms).
    for (const double K : {100.0, 1e6}) {
        const std::vector<SceneTerm> terms = oblique_scene(K);
        const EngagementCheck here = check_engagement_patterns(checker, terms, 1.0 / 30.0);
        ASSERT_TRUE(worker.start(terms, 1.0 / 30.0));
        const std::optional<server::CommitCheckWorker::Outcome> there = wait_for(worker);
        ASSERT_TRUE(there) << "no verdict within two minutes";
        EXPECT_EQ(there->failure, nullptr);
        EXPECT_EQ(there->verdict.stable, here.stable) << K;
        EXPECT_EQ(there->verdict.checks, here.checks) << K;
        EXPECT_EQ(there->verdict.sampled, here.sampled) << K;
        EXPECT_EQ(there->verdict.why, here.why) << K;
        EXPECT_FALSE(there->verdict.cancelled);
        EXPECT_TRUE(worker.idle());
    }
    EXPECT_TRUE(check_engagement_patterns(checker, oblique_scene(100.0), 1.0 / 30.0).stable);
    EXPECT_FALSE(check_engagement_patterns(checker, oblique_scene(1e6), 1.0 / 30.0).stable);
}

TEST(CommitCheckWorker, OneCheckAtATimeAndACancelledOneIsDropped) {
    const GainChecker checker(plant());
    server::CommitCheckWorker worker(checker);
    EXPECT_TRUE(worker.idle());
    EXPECT_FALSE(worker.take());
    // 9999 ramp scenes of two always-engaged planes: long enough to be cancelled while queued or running.
    const std::vector<SceneTerm> many = oblique_scene(100.0, true);
    ASSERT_TRUE(worker.start(many, 1e-4));
    EXPECT_FALSE(worker.idle());
    EXPECT_FALSE(worker.start(many, 1e-4));  // one at a time
    worker.cancel();
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::minutes(2);
    while (!worker.idle() && std::chrono::steady_clock::now() < deadline)
        std::this_thread::sleep_for(std::chrono::milliseconds(1));
    ASSERT_TRUE(worker.idle()) << "the cancelled check did not stop within two minutes";
    EXPECT_FALSE(worker.take());  // its verdict is dropped
    // The worker takes the next check, and that one is not cancelled.
    ASSERT_TRUE(worker.start(oblique_scene(100.0), 1.0 / 30.0));
    const std::optional<server::CommitCheckWorker::Outcome> next = wait_for(worker);
    ASSERT_TRUE(next);
    EXPECT_TRUE(next->verdict.stable);
    EXPECT_FALSE(next->verdict.cancelled);
}

TEST(CommitCheckWorker, ItsDestructionDuringALongCheckEnds) {
    const GainChecker checker(plant());
    {
        server::CommitCheckWorker worker(checker);
        ASSERT_TRUE(worker.start(oblique_scene(100.0, true), 1e-4));
        std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }  // cancels and joins: the test's own timeout bounds it
    SUCCEED();
}

TEST(EngagementPatterns, ACancelledCheckStopsBeforeItsNextVerdict) {
    const GainChecker checker(plant());
    std::atomic<bool> cancel{true};
    const EngagementCheck stopped =
        check_engagement_patterns(checker, oblique_scene(100.0), 1.0 / 30.0, PatternLimit::Enforced, &cancel);
    EXPECT_TRUE(stopped.cancelled);
    EXPECT_FALSE(stopped.stable);
    EXPECT_EQ(stopped.checks, 0U);
    cancel = false;
    const EngagementCheck whole =
        check_engagement_patterns(checker, oblique_scene(100.0), 1.0 / 30.0, PatternLimit::Enforced, &cancel);
    EXPECT_FALSE(whole.cancelled);
    EXPECT_TRUE(whole.stable);
    EXPECT_GT(whole.checks, 30U);
}

}  // namespace commit_check_worker_test
}  // namespace hapticd
