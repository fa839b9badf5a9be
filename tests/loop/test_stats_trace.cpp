// SPDX-License-Identifier: Apache-2.0
// Loop statistics, the SPSC ring and the trace writer.
#include <gtest/gtest.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>
#include <thread>

#include <nlohmann/json.hpp>

#include "loop/spsc_ring.hpp"
#include "loop/stats.hpp"
#include "loop/trace.hpp"

namespace hapticd {
namespace {

TEST(LatencyStats, BucketsAreConsistent) {
    for (std::uint64_t v : {0ULL, 1ULL, 31ULL, 32ULL, 33ULL, 63ULL, 64ULL, 1000ULL, 123456ULL, 999999999ULL}) {
        const std::size_t b = LatencyStats::bucket_of(v);
        EXPECT_LE(LatencyStats::bucket_lower(b), v);
        EXPECT_GE(LatencyStats::bucket_upper(b), v);
        // relative width <= 1/32
        EXPECT_LE(LatencyStats::bucket_upper(b) - LatencyStats::bucket_lower(b), v / 32 + 1);
    }
}

TEST(LatencyStats, ExactMinMaxMeanAndBoundedPercentiles) {
    LatencyStats s;
    for (int i = 1; i <= 1000; ++i) s.record(i * 1000);  // 1 .. 1000 us
    EXPECT_EQ(s.count(), 1000U);
    EXPECT_EQ(s.min_ns(), 1000U);
    EXPECT_EQ(s.max_ns(), 1000000U);
    EXPECT_DOUBLE_EQ(s.mean_ns(), 500500.0);
    const double p99 = static_cast<double>(s.percentile_ns(0.99));
    EXPECT_GE(p99, 990000.0);
    EXPECT_LE(p99, 990000.0 * (1 + 1.0 / 32));
    EXPECT_EQ(s.percentile_ns(1.0), 1000000U);
    std::uint64_t total = 0;
    for (const auto& bin : s.coarse_histogram()) total += bin.count;
    EXPECT_EQ(total, 1000U);
    const auto j = s.to_json();
    EXPECT_EQ(j["count"], 1000);
    EXPECT_TRUE(j.contains("p99_9_us"));
}

TEST(SpscRing, TransfersInOrderAcrossThreads) {
    SpscRing<std::uint64_t> ring(64);
    constexpr std::uint64_t n = 50000;
    std::thread consumer([&] {
        std::uint64_t expected = 0;
        std::uint64_t v = 0;
        while (expected < n) {
            if (ring.try_pop(v)) {
                ASSERT_EQ(v, expected);
                ++expected;
            }
        }
    });
    for (std::uint64_t i = 0; i < n;) {
        if (ring.try_push(i)) ++i;
    }
    consumer.join();
}

// front() leaves the element in the ring: the producer must not overwrite it before pop(), even with the
// ring full. Each element carries its index twice; a slot rewritten under the reader shows a mismatch.
TEST(SpscRing, FrontStaysValidUntilPopAcrossThreads) {
    struct Pair {
        std::uint64_t a = 0, b = 0;
    };
    SpscRing<Pair> ring(64);
    constexpr std::uint64_t n = 20000;
    std::thread consumer([&] {
        std::uint64_t expected = 0;
        while (expected < n) {
            const Pair* p = ring.front();
            if (p == nullptr) continue;
            const std::uint64_t a = p->a;
            // Now and then give the producer time to fill the ring behind it (every time costs ~1 ms a
            // yield on a loaded 2-core machine).
            if ((expected & 63U) == 0) std::this_thread::yield();
            ASSERT_EQ(a, expected);
            ASSERT_EQ(p->b, expected);
            ring.pop();
            ++expected;
        }
    });
    for (std::uint64_t i = 0; i < n;) {
        if (ring.try_push(Pair{i, i})) ++i;
    }
    consumer.join();
    EXPECT_EQ(ring.front(), nullptr);
}

TEST(SpscRing, FullRingRefuses) {
    SpscRing<int> ring(4);
    for (int i = 0; i < 4; ++i) {
        EXPECT_FALSE(ring.full());
        EXPECT_TRUE(ring.try_push(i));
    }
    EXPECT_TRUE(ring.full());
    EXPECT_FALSE(ring.try_push(99));
    int v = 0;
    EXPECT_TRUE(ring.try_pop(v));
    EXPECT_EQ(v, 0);
    EXPECT_FALSE(ring.full());  // the consumer's pop is seen
    EXPECT_TRUE(ring.try_push(4));
    EXPECT_TRUE(ring.full());
}

std::string temp_path(const std::string& name) {
    return (std::filesystem::temp_directory_path() / ("hapticd_test_" + std::to_string(::getpid()) + "_" + name))
        .string();
}

TEST(TraceWriter, BlockingModeIsCompleteAndExact) {
    const std::string path = temp_path("blocking.csv");
    {
        TraceWriter w(path, 64, true);  // small ring: the producer has to wait
        for (std::uint64_t i = 0; i < 5000; ++i) {
            w.push({i, static_cast<double>(i) * 1e-3, 0.1 + static_cast<double>(i) / 3.0, -1.0 / 3.0, 1.0, 2.5});
        }
        EXPECT_TRUE(w.close());
        EXPECT_EQ(w.dropped(), 0U);
        EXPECT_EQ(w.written(), 5000U);
    }
    std::ifstream in(path);
    std::string line;
    std::getline(in, line);
    EXPECT_EQ(line + "\n", TraceWriter::header());
    std::uint64_t count = 0;
    while (std::getline(in, line)) {
        unsigned long long tick = 0;
        double t = 0, p = 0, f = 0, e = 0, l = 0;
        ASSERT_EQ(std::sscanf(line.c_str(), "%llu,%lf,%lf,%lf,%lf,%lf", &tick, &t, &p, &f, &e, &l), 6) << line;
        EXPECT_EQ(tick, count);
        EXPECT_EQ(p, 0.1 + static_cast<double>(count) / 3.0);  // %.17g round-trips
        EXPECT_EQ(f, -1.0 / 3.0);
        ++count;
    }
    EXPECT_EQ(count, 5000U);
    std::filesystem::remove(path);
}

TEST(TraceWriter, NonBlockingModeCountsDrops) {
    const std::string path = temp_path("drops.csv");
    TraceWriter w(path, 4, false);
    for (std::uint64_t i = 0; i < 100000; ++i) w.push({i, 0, 0, 0, 0, 0});
    EXPECT_TRUE(w.close());
    EXPECT_EQ(w.dropped() + w.written(), 100000U);
    std::filesystem::remove(path);
}

TEST(TraceWriter, UnwritablePathThrowsNamingIt) {
    try {
        TraceWriter w("/nonexistent-dir/x.csv", 8, false);
        FAIL();
    } catch (const std::runtime_error& e) {
        EXPECT_NE(std::string(e.what()).find("/nonexistent-dir/x.csv"), std::string::npos);
    }
}

}  // namespace
}  // namespace hapticd
