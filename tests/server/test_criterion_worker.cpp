// SPDX-License-Identifier: Apache-2.0
// server/criterion_worker.hpp: a criterion's first tuning on the worker thread while the server thread keeps using
// the checker (under TSan: no data race between the tuning and the checker's other verdicts), the gains the same as a
// tuning on the calling thread, and a failed tuning cached with its error.
#include <chrono>
#include <stdexcept>
#include <string>
#include <thread>

#include <gtest/gtest.h>

#include "server/criterion_worker.hpp"
#include "tuning/object_checks.hpp"

namespace hapticd {
namespace criterion_worker_test {

// The shipped Falcon profile's loop (config/devices/falcon.toml): 0.30 kg, 6 ms, window:15, its plant set.
GainCheckPlant falcon() {
    GainCheckPlant p;
    p.mass = 0.30;
    p.period = 1e-3;
    p.time_delay = 0.006;
    p.velocity.kind = hapticopt::VelocityEstimatorKind::window;
    p.velocity.window = 15;
    p.mass_range = std::make_pair(0.22, 0.30);
    p.mass_margin = 0.1;
    return p;
}

TEST(CriterionWorker, TunesOffTheCallingThreadWhileTheCheckerIsUsed) {
    GainChecker checker(falcon());
    EXPECT_FALSE(checker.criterion_ready(hapticopt::Criterion::CE1_OV));
    int verdicts = 0;
    {
        server::CriterionWorker worker(checker);
        worker.request(hapticopt::Criterion::CE1_OV);
        worker.request(hapticopt::Criterion::CE1_OV);  // queued once
        const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(120);
        while (!checker.criterion_ready(hapticopt::Criterion::CE1_OV) && std::chrono::steady_clock::now() < deadline) {
            // What the server thread does meanwhile: other objects' verdicts.
            EXPECT_TRUE(checker.check_object(100.0, 5.0, {0.30}).stable);
            ++verdicts;
        }
        ASSERT_TRUE(checker.criterion_ready(hapticopt::Criterion::CE1_OV));
    }
    GainChecker direct(falcon());
    const CriterionGains on_worker = checker.criterion_gains(hapticopt::Criterion::CE1_OV, 0.30);
    const CriterionGains here = direct.criterion_gains(hapticopt::Criterion::CE1_OV, 0.30);
    EXPECT_EQ(on_worker.K, here.K);
    EXPECT_EQ(on_worker.B, here.B);
    std::printf("[ worker ] %d verdicts on the calling thread during CE1+OV's tuning: K %.6g N/m, B %.6g N s/m\n",
                verdicts, on_worker.K, on_worker.B);
}

TEST(CriterionWorker, AFailedTuningIsCachedWithItsError) {
    GainCheckPlant p = falcon();
    p.force_noise_budget = 1e-9;  // no stable gains meet it
    p.position_resolution = 4.85e-5;
    GainChecker checker(p);
    checker.prepare_criterion(hapticopt::Criterion::CE2);  // never throws
    ASSERT_TRUE(checker.criterion_ready(hapticopt::Criterion::CE2));
    for (int i = 0; i < 2; ++i) {
        try {
            (void)checker.criterion_gains(hapticopt::Criterion::CE2, 0.30);
            ADD_FAILURE() << "an unmeetable budget gave gains";
        } catch (const std::invalid_argument& e) {
            EXPECT_NE(std::string(e.what()).find("force_noise_budget"), std::string::npos) << e.what();
        }
    }
}

}  // namespace criterion_worker_test
}  // namespace hapticd
