// SPDX-License-Identifier: Apache-2.0
#include "loop/stats.hpp"

#include <bit>
#include <cmath>
#include <cstdio>
#include <limits>

#include <nlohmann/json.hpp>

namespace hapticd {

std::size_t LatencyStats::bucket_of(std::uint64_t v) noexcept {
    if (v < kSub) {
        return static_cast<std::size_t>(v);
    }
    unsigned e = static_cast<unsigned>(std::bit_width(v)) - 1U;  // floor(log2 v) >= kSubBits
    if (e > kMaxExponent) {
        return kBuckets - 1;
    }
    const std::uint64_t sub = (v >> (e - kSubBits)) - kSub;  // 0 .. kSub-1
    return static_cast<std::size_t>(kSub + (e - kSubBits) * kSub + sub);
}

std::uint64_t LatencyStats::bucket_lower(std::size_t bucket) noexcept {
    if (bucket < kSub) {
        return bucket;
    }
    const std::uint64_t e = (bucket - kSub) / kSub + kSubBits;
    const std::uint64_t sub = (bucket - kSub) % kSub;
    return (kSub + sub) << (e - kSubBits);
}

std::uint64_t LatencyStats::bucket_upper(std::size_t bucket) noexcept {
    if (bucket + 1 >= kBuckets) {
        return std::numeric_limits<std::uint64_t>::max();
    }
    return bucket_lower(bucket + 1) - 1;
}

std::uint64_t LatencyStats::percentile_ns(double q) const noexcept {
    if (count_ == 0) {
        return 0;
    }
    const double want = std::ceil(q * static_cast<double>(count_));
    const std::uint64_t rank = want < 1.0 ? 1U : static_cast<std::uint64_t>(want);
    std::uint64_t seen = 0;
    for (std::size_t b = 0; b < kBuckets; ++b) {
        seen += buckets_[b];
        if (seen >= rank) {
            const std::uint64_t upper = bucket_upper(b);
            return upper < max_ ? upper : max_;
        }
    }
    return max_;
}

std::vector<LatencyStats::Bin> LatencyStats::coarse_histogram() const {
    std::vector<Bin> bins;
    for (double decade = 1.0; decade <= 1e4; decade *= 10.0) {
        for (double m : {1.0, 2.0, 5.0}) {
            bins.push_back({m * decade, 0});
        }
    }
    bins.push_back({std::numeric_limits<double>::infinity(), 0});
    for (std::size_t b = 0; b < kBuckets; ++b) {
        if (buckets_[b] == 0) continue;
        const double lower_us = static_cast<double>(bucket_lower(b)) * 1e-3;
        for (auto& bin : bins) {
            if (lower_us < bin.upper_us) {
                bin.count += buckets_[b];
                break;
            }
        }
    }
    return bins;
}

std::string LatencyStats::summary_line() const {
    char buf[256];
    std::snprintf(buf, sizeof buf, "n %llu  min %.3f  mean %.3f  p99 %.3f  p99.9 %.3f  max %.3f us",
                  static_cast<unsigned long long>(count_), static_cast<double>(min_ns()) * 1e-3, mean_ns() * 1e-3,
                  static_cast<double>(percentile_ns(0.99)) * 1e-3, static_cast<double>(percentile_ns(0.999)) * 1e-3,
                  static_cast<double>(max_ns()) * 1e-3);
    return buf;
}

nlohmann::json LatencyStats::to_json() const {
    nlohmann::json j;
    j["count"] = count_;
    j["min_us"] = static_cast<double>(min_ns()) * 1e-3;
    j["mean_us"] = mean_ns() * 1e-3;
    j["p99_us"] = static_cast<double>(percentile_ns(0.99)) * 1e-3;
    j["p99_9_us"] = static_cast<double>(percentile_ns(0.999)) * 1e-3;
    j["max_us"] = static_cast<double>(max_ns()) * 1e-3;
    nlohmann::json hist = nlohmann::json::array();
    for (const auto& bin : coarse_histogram()) {
        nlohmann::json h;
        h["upper_us"] = std::isinf(bin.upper_us) ? nlohmann::json(nullptr) : nlohmann::json(bin.upper_us);
        h["count"] = bin.count;
        hist.push_back(h);
    }
    j["histogram"] = hist;
    return j;
}

}  // namespace hapticd
