// SPDX-License-Identifier: Apache-2.0
// --record FILE (docs/recording.md): every tick's state and every batch the loop takes from its rings, in one
// file (layout: daemon/recording_format.hpp). Like the trace (loop/trace.hpp): the loop pushes into two
// preallocated lock-free SPSC rings (ticks; batches, each a copy of its `count` updates) and a writer thread
// drains them into the file, each tick's batches before the tick. In real-time mode a full ring drops the
// record (counted; the end chunk then marks the recording incomplete and --replay refuses it); in blocking mode
// (--lockstep) the loop waits instead. close() (also run by the destructor) drains, writes the end chunk, closes.
// Meshes: the server tells the recorder (on_mesh, on the server thread: a lock and an allocation there, none on
// the loop thread) of each hierarchy before it pushes the first batch that renders it; the writer thread writes
// the mesh's vertices and triangles (mesh records) before the first batch record that names it, then lets the
// hierarchy go.
#pragma once

#include <atomic>
#include <cstdint>
#include <cstdio>
#include <deque>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <unordered_set>

#include "daemon/recording_format.hpp"
#include "loop/spsc_ring.hpp"
#include "scene/scene_objects.hpp"

namespace hapticd {

class Recorder final : public CommitObserver, public MeshObserver {
  public:
    // Opens `path` for writing and writes the header (header_json: the JSON object of the header; throws
    // std::runtime_error naming the path on failure), then starts the writer thread. tick_capacity: the tick
    // ring's records; the batch ring holds kBatchCapacity batches.
    Recorder(const std::string& path, const std::string& header_json, std::size_t tick_capacity, bool blocking);
    Recorder(const Recorder&) = delete;
    Recorder& operator=(const Recorder&) = delete;
    ~Recorder();

    static constexpr std::size_t kBatchCapacity = 256;

    // Real-time side, on the loop thread: begin_tick before the tick's apply_commits, push_tick at its end.
    void begin_tick(std::uint64_t tick) noexcept {
        tick_ = tick;
        index_ = 0;
    }
    void on_taken(const ObjectCommit& commit, CommitSource source) noexcept override;
    void push_tick(recording::TickChunk& chunk) noexcept;

    // Server thread: `hierarchy` (the server's mesh `mesh_id`) is about to be rendered; queued for the writer
    // the first time only.
    void on_mesh(std::uint32_t mesh_id, const std::shared_ptr<const mesh::MeshHierarchy>& hierarchy) override;

    // Stops the writer after draining, writes the end chunk, closes. Idempotent. Returns false on a write error.
    bool close() noexcept;

    [[nodiscard]] std::uint64_t dropped_ticks() const noexcept {
        return dropped_ticks_.load(std::memory_order_relaxed);
    }
    [[nodiscard]] std::uint64_t dropped_batches() const noexcept {
        return dropped_batches_.load(std::memory_order_relaxed);
    }
    [[nodiscard]] std::uint64_t ticks_written() const noexcept {
        return ticks_written_.load(std::memory_order_relaxed);
    }
    [[nodiscard]] std::uint64_t batches_written() const noexcept {
        return batches_written_.load(std::memory_order_relaxed);
    }
    [[nodiscard]] std::uint64_t meshes_written() const noexcept {
        return meshes_written_.load(std::memory_order_relaxed);
    }
    [[nodiscard]] bool write_error() const noexcept { return write_error_.load(std::memory_order_relaxed); }
    [[nodiscard]] const std::string& path() const noexcept { return path_; }

  private:
    struct BatchEntry {
        std::uint64_t tick = 0;
        std::uint32_t index = 0;
        CommitSource source = CommitSource::Ring;
        ObjectCommit commit;  // copying one copies its `count` updates only
    };

    void run() noexcept;
    std::size_t drain() noexcept;
    void write_chunk(const void* chunk) noexcept;
    void write_batch(const BatchEntry& b) noexcept;
    void write_meshes() noexcept;  // the queued meshes (writer thread)
    struct PendingMesh {
        std::uint32_t id = 0;
        std::shared_ptr<const mesh::MeshHierarchy> hierarchy;
    };
    void write_mesh(const PendingMesh& m) noexcept;

    std::string path_;
    SpscRing<recording::TickChunk> ticks_;
    SpscRing<BatchEntry> batches_;
    bool blocking_;
    std::uint64_t tick_ = 0;   // loop thread
    std::uint32_t index_ = 0;  // loop thread: batches taken in this tick
    BatchEntry scratch_;       // loop thread: filled, then copied into the ring (no 14 KB zeroing per batch)
    std::FILE* file_ = nullptr;
    std::uint64_t checksum_ = 0;  // writer thread
    std::uint64_t updates_ = 0;   // writer thread
    std::atomic<bool> stop_{false};
    std::atomic<std::uint64_t> dropped_ticks_{0};
    std::atomic<std::uint64_t> dropped_batches_{0};
    std::atomic<std::uint64_t> ticks_written_{0};
    std::atomic<std::uint64_t> batches_written_{0};
    std::atomic<bool> write_error_{false};
    std::atomic<std::uint64_t> meshes_written_{0};
    std::unordered_set<std::uint32_t> announced_;  // server thread: the meshes queued so far
    std::mutex meshes_mutex_;                      // pending_ (server thread -> writer thread)
    std::deque<PendingMesh> pending_;
    std::deque<PendingMesh> taken_;              // writer thread: pending_ swapped out
    std::unordered_set<std::uint32_t> written_;  // writer thread: the meshes in the file
    bool missing_mesh_ = false;                  // writer thread: a batch named a mesh never queued
    std::thread thread_;
    bool closed_ = false;
};

}  // namespace hapticd
