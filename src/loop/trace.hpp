// SPDX-License-Identifier: Apache-2.0
// Per-tick trace: the loop pushes records into a preallocated lock-free SPSC ring; a writer thread
// drains it into a CSV file. In real-time mode a full ring drops the record (counted and reported);
// in blocking mode (used with --lockstep, where nothing is real-time) the producer waits instead, so the
// trace is complete. close() (also run by the destructor) drains everything and flushes the file.
#pragma once

#include <atomic>
#include <cstdint>
#include <cstdio>
#include <string>
#include <thread>

#include "loop/spsc_ring.hpp"

namespace hapticd {

struct TraceRecord {
    std::uint64_t tick = 0;
    double time_s = 0.0;
    double position_m = 0.0;
    double wall_force_N = 0.0;      // force applied to the device during this tick's period
    double external_force_N = 0.0;  // NaN when the device cannot know it
    double wake_latency_us = 0.0;
};

class TraceWriter {
  public:
    // Opens `path` for writing (throws std::runtime_error naming the path on failure) and starts the
    // writer thread.
    TraceWriter(const std::string& path, std::size_t capacity, bool blocking);
    TraceWriter(const TraceWriter&) = delete;
    TraceWriter& operator=(const TraceWriter&) = delete;
    ~TraceWriter();

    // Real-time side.
    void push(const TraceRecord& record) noexcept {
        if (ring_.try_push(record)) {
            return;
        }
        if (!blocking_) {
            dropped_.fetch_add(1, std::memory_order_relaxed);
            return;
        }
        while (!ring_.try_push(record)) {
            std::this_thread::yield();
        }
    }

    // Stops the writer after draining, flushes and closes. Idempotent. Returns false on a write error.
    bool close() noexcept;

    [[nodiscard]] std::uint64_t dropped() const noexcept { return dropped_.load(std::memory_order_relaxed); }
    [[nodiscard]] std::uint64_t written() const noexcept { return written_.load(std::memory_order_relaxed); }
    [[nodiscard]] bool write_error() const noexcept { return write_error_.load(std::memory_order_relaxed); }
    [[nodiscard]] const std::string& path() const noexcept { return path_; }

    static const char* header() noexcept;

  private:
    void run() noexcept;
    std::size_t drain() noexcept;

    std::string path_;
    SpscRing<TraceRecord> ring_;
    bool blocking_;
    std::FILE* file_ = nullptr;
    std::atomic<bool> stop_{false};
    std::atomic<std::uint64_t> dropped_{0};
    std::atomic<std::uint64_t> written_{0};
    std::atomic<bool> write_error_{false};
    std::thread thread_;
    bool closed_ = false;
};

}  // namespace hapticd
