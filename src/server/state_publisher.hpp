// SPDX-License-Identifier: Apache-2.0
// The loop's side of the shared-memory state (docs/protocol.md, section 6; layout
// include/hapticd/state_layout.hpp): created (shm_open O_CREAT | O_EXCL, mode 0640, the socket's group) before
// the loop starts, written once per tick under a seqlock, unlinked at shut-down. A segment of the same name that
// exists already is replaced only when the daemon's effective uid owns it, refused otherwise (never opened).
// Writer protocol: sequence <- s + 1 (odd, relaxed store) ; release fence ; fields ; sequence <- s + 2
// (release store). publish() does not allocate, lock, throw or make a system call. With the fields it writes the
// mesh objects' proxies (SceneObjects::mesh_proxy) of the first kStateMeshProxyCapacity mesh slots.
#pragma once

#include <atomic>
#include <cstdint>
#include <string>

#include "common/axis_vector.hpp"
#include "hapticd/state_layout.hpp"

namespace hapticd {

class SceneObjects;

// Where POSIX shared memory segments are on Linux (glibc's shm_open: /dev/shm/<name without the '/'>).
inline constexpr const char* kShmDirectory = "/dev/shm";

struct StateTick {
    std::uint64_t tick = 0;
    double time_s = 0.0;
    AxisVector position{};
    AxisVector velocity{};
    AxisVector force{};
    std::uint64_t overruns = 0;
    std::int64_t wake_latency_ns = 0;
    StateFault fault = StateFault::None;
    std::uint64_t config_contact_mask = 0;  // Scene::contact_mask(): the config walls in contact
};

class StatePublisher {
  public:
    // Throws std::runtime_error naming the shm name and errno on failure, or --serve-shm, the segment's path and its
    // owner when another user owns a segment of that name. gid < 0: keep the group.
    StatePublisher(const std::string& shm_name, std::size_t axes, double period_s, int gid);
    ~StatePublisher();
    StatePublisher(const StatePublisher&) = delete;
    StatePublisher& operator=(const StatePublisher&) = delete;

    void publish(const StateTick& tick, const SceneObjects* objects) noexcept;

    // The heartbeat alone (CLOCK_MONOTONIC now), for the time before the loop's first tick (a daemon
    // waiting for its first commit is alive). Only while the loop does not publish.
    void beat() noexcept;

    // From a fatal-signal handler or std::terminate (daemon/fatal_signal.hpp); async-signal-safe: stops
    // further publication, waits at most ~2 ms for a publication in progress on another thread, then
    // writes `fault` and the signal under the seqlock. The heartbeat stops with it.
    void mark_fatal(StateFault fault, int signal_number) noexcept;

    // For the server thread: a consistent copy of the last tick (seqlock read), waiting out a publication in
    // progress up to the state's stale age. False (the loop stalled inside a publication, or 10 000 copies in a
    // row overlapped one): `out` then holds fields of two consecutive ticks, not one.
    bool read(StateLayout& out) const noexcept;

    [[nodiscard]] const std::string& name() const noexcept { return name_; }

  private:
    std::string name_;
    StateLayout* layout_ = nullptr;
    void publish_mesh_proxies(StateLayout& l, const SceneObjects& objects) noexcept;

    std::uint64_t published_slot_table_ = 0;  // SceneObjects::slot_table_version() last written
    bool slot_table_written_ = false;
    std::uint32_t published_mesh_proxies_ = 0;  // mesh proxy entries the last publication wrote
    std::atomic<bool> fatal_{false};
};

}  // namespace hapticd
