// SPDX-License-Identifier: Apache-2.0
// Timing statistics of the loop (wake latency, compute time) in preallocated storage: min, mean and max
// exactly, percentiles from a log-linear histogram (32 sub-buckets per power of two: values below 32 ns
// exact, above within 1/32 = 3 %; a percentile is reported as the upper edge of its bucket, capped by
// the exact max). record() is real-time safe.
#pragma once

#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include <nlohmann/json_fwd.hpp>

namespace hapticd {

class LatencyStats {
  public:
    static constexpr unsigned kSubBits = 5;
    static constexpr std::uint64_t kSub = 1ULL << kSubBits;
    static constexpr unsigned kMaxExponent = 40;  // values >= 2^40 ns (18 min) land in the top bucket
    static constexpr std::size_t kBuckets = kSub + kSub * (kMaxExponent - kSubBits + 1);

    void record(std::int64_t ns) noexcept {
        const std::uint64_t v = ns < 0 ? 0U : static_cast<std::uint64_t>(ns);
        ++count_;
        sum_ += static_cast<double>(v);
        min_ = v < min_ ? v : min_;
        max_ = v > max_ ? v : max_;
        ++buckets_[bucket_of(v)];
    }

    [[nodiscard]] std::uint64_t count() const noexcept { return count_; }
    [[nodiscard]] std::uint64_t min_ns() const noexcept { return count_ ? min_ : 0; }
    [[nodiscard]] std::uint64_t max_ns() const noexcept { return max_; }
    [[nodiscard]] double mean_ns() const noexcept { return count_ ? sum_ / static_cast<double>(count_) : 0.0; }
    // q in [0, 1]; 0 when empty.
    [[nodiscard]] std::uint64_t percentile_ns(double q) const noexcept;

    struct Bin {
        double upper_us;  // +inf for the last
        std::uint64_t count;
    };
    // Coarse 1-2-5 histogram in microseconds, for printing and JSON.
    [[nodiscard]] std::vector<Bin> coarse_histogram() const;

    [[nodiscard]] std::string summary_line() const;  // "min .. mean .. p99 .. p99.9 .. max .. (us)"
    [[nodiscard]] nlohmann::json to_json() const;

    static std::size_t bucket_of(std::uint64_t v) noexcept;
    static std::uint64_t bucket_upper(std::size_t bucket) noexcept;  // largest value in the bucket
    static std::uint64_t bucket_lower(std::size_t bucket) noexcept;

  private:
    std::array<std::uint64_t, kBuckets> buckets_{};
    std::uint64_t count_ = 0;
    double sum_ = 0.0;
    std::uint64_t min_ = UINT64_MAX;
    std::uint64_t max_ = 0;
};

}  // namespace hapticd
