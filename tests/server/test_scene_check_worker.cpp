// SPDX-License-Identifier: Apache-2.0
// server/scene_check_worker.hpp: a commit's scene check and a departure's plan on the worker thread give the verdict
// and the plan the same calls give on the calling thread (stable and refused scenes alike), one check at a time, a
// cancelled check dropped and the worker usable again, its destruction during a long check bounded; and
// check_engagement_patterns and plan_departure stop at `cancel` before their next verdict.
#include <atomic>
#include <chrono>
#include <thread>
#include <vector>

#include <gtest/gtest.h>

#include "server/scene_check_worker.hpp"
#include "tuning/engagement_patterns.hpp"

namespace hapticd {
namespace scene_check_worker_test {

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
std::optional<server::SceneCheckWorker::Outcome> wait_for(server::SceneCheckWorker& worker) {
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::minutes(2);
    while (std::chrono::steady_clock::now() < deadline) {
        if (auto outcome = worker.take()) return outcome;
        std::this_thread::sleep_for(std::chrono::milliseconds(1));
    }
    return std::nullopt;
}

TEST(SceneCheckWorker, TheVerdictIsTheCheckOnTheCallingThread) {
    const GainChecker checker(plant());
    server::SceneCheckWorker worker(checker);
    // 100 N/m: stable in every scene; 1e6 N/m: refused (far outside the region at 0.25 kg, 2 ms).
    for (const double K : {100.0, 1e6}) {
        const std::vector<SceneTerm> terms = oblique_scene(K);
        const EngagementCheck here = check_engagement_patterns(checker, terms, 1.0 / 30.0);
        ASSERT_TRUE(worker.start(terms, 1.0 / 30.0));
        const std::optional<server::SceneCheckWorker::Outcome> there = wait_for(worker);
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

// The oblique plane of oblique_scene leaves (object 2 of session 7) beside the wall (a config wall): stable at 100 N/m,
// so it alone ramps out; the worker's plan is the calling thread's.
TEST(SceneCheckWorker, ADeparturesPlanIsTheRuleOnTheCallingThread) {
    const GainChecker checker(plant());
    server::SceneCheckWorker worker(checker);
    const std::vector<SceneTerm> scene = oblique_scene(100.0);
    const std::vector<SceneTerm> fixed{scene[0]};
    const std::vector<DepartureObject> leaving{DepartureObject{5, 7, scene[1]}};
    const DeparturePlan here = plan_departure(checker, fixed, leaving, {}, 1.0 / 30.0);
    ASSERT_TRUE(worker.start_departure(fixed, leaving, {}, 1.0 / 30.0));
    EXPECT_FALSE(worker.start(scene, 1.0 / 30.0));  // one at a time, whatever its kind
    const std::optional<server::SceneCheckWorker::Outcome> there = wait_for(worker);
    ASSERT_TRUE(there) << "no plan within two minutes";
    EXPECT_EQ(there->failure, nullptr);
    ASSERT_TRUE(there->departure);
    EXPECT_EQ(there->departure->out, here.out);
    EXPECT_EQ(there->departure->out, std::vector<std::size_t>{5});
    EXPECT_TRUE(there->departure->further.empty());
    EXPECT_EQ(there->departure->cut, here.cut);
    EXPECT_FALSE(there->departure->cut);
    EXPECT_FALSE(there->departure->cancelled);
    EXPECT_TRUE(worker.idle());

    std::atomic<bool> cancel{true};
    const DeparturePlan stopped = plan_departure(checker, fixed, leaving, {}, 1.0 / 30.0, &cancel);
    EXPECT_TRUE(stopped.cancelled);
}

TEST(SceneCheckWorker, OneCheckAtATimeAndACancelledOneIsDropped) {
    const GainChecker checker(plant());
    server::SceneCheckWorker worker(checker);
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
    const std::optional<server::SceneCheckWorker::Outcome> next = wait_for(worker);
    ASSERT_TRUE(next);
    EXPECT_TRUE(next->verdict.stable);
    EXPECT_FALSE(next->verdict.cancelled);
}

TEST(SceneCheckWorker, ItsDestructionDuringALongCheckEnds) {
    const GainChecker checker(plant());
    {
        server::SceneCheckWorker worker(checker);
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

}  // namespace scene_check_worker_test
}  // namespace hapticd
