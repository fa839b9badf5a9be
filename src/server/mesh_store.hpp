// SPDX-License-Identifier: Apache-2.0
// The sessions' triangle meshes (docs/protocol.md, section 4a): uploads assembled from in-order chunks, then validated
// (mesh/triangle_mesh.hpp: mesh_error) and their hierarchies built on a worker thread of their own (never on the loop
// thread, nor the server thread: 100 000 triangles take ~0.1 s to validate and ~0.3 s to build), and the per-session
// and daemon-wide limits: meshes per session, bytes per session and in all (reserved from the announced counts at
// mesh_begin), an upload's silence. Everything but the worker runs on the server thread; the worker takes one job at a
// time from a queue under a mutex (the server thread only, never the loop). A mesh object's ServerSlot keeps its
// hierarchy alive (shared_ptr) for as long as the loop may render it, so dropping a mesh here never frees what the loop
// reads.
#pragma once

#include <chrono>
#include <condition_variable>
#include <cstddef>
#include <cstdint>
#include <deque>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <variant>

#include "mesh/mesh_hierarchy.hpp"
#include "server/message_decoder.hpp"
#include "server/object_resolution.hpp"
#include "server/sessions.hpp"

namespace hapticd::server {

// docs/protocol.md, section 4a ("Limits").
struct MeshStoreLimits {
    std::size_t max_vertices = 200000;
    std::size_t max_triangles = 200000;
    std::size_t meshes_per_session = 8;
    std::size_t bytes_per_session = std::size_t{64} << 20;
    std::size_t bytes_total = std::size_t{256} << 20;
    std::chrono::milliseconds upload_timeout{10000};
};

// Bytes an upload reserves: its vertices and triangles as the server holds them while they arrive.
[[nodiscard]] constexpr std::size_t upload_bytes(std::uint64_t vertices, std::uint64_t triangles) noexcept {
    return static_cast<std::size_t>(24 * vertices + 12 * triangles);
}

enum class MeshState : std::uint8_t { Uploading, Building, Ready, Failed };
[[nodiscard]] const char* to_string(MeshState state) noexcept;

struct MeshInfo {
    MeshState state = MeshState::Uploading;
    std::size_t vertices = 0, triangles = 0;                    // announced at mesh_begin
    std::size_t received_vertices = 0, received_triangles = 0;  // so far
    std::size_t bytes = 0;                                      // counted against the limits
    std::string message;                                        // Failed: why
};

class MeshStore {
  public:
    explicit MeshStore(MeshStoreLimits limits = {});
    ~MeshStore();  // stops the worker (a build in progress finishes first)
    MeshStore(const MeshStore&) = delete;
    MeshStore& operator=(const MeshStore&) = delete;

    // A new upload of `session` (bad_message: counts out of range; session_limit: meshes or bytes of the session;
    // capacity: bytes of every session): its id.
    [[nodiscard]] std::variant<std::uint32_t, Refusal> begin(std::uint64_t session, const MeshBeginRequest& request,
                                                             Clock::time_point now);
    // Appends a chunk in order (bad_message: `first` not the count so far, or beyond the announced count;
    // unknown_object: no such upload of this session, or it is no longer uploading).
    [[nodiscard]] std::optional<Refusal> chunk(std::uint64_t session, const MeshChunkRequest& request,
                                               Clock::time_point now);
    // Every count reached: queued to the worker (state Building), which validates it (an invalid mesh is Failed,
    // with the reason) and builds its hierarchy (Ready). Otherwise bad_message naming what is missing.
    [[nodiscard]] std::optional<Refusal> end(std::uint64_t session, std::uint32_t mesh);
    [[nodiscard]] std::variant<MeshInfo, Refusal> status(std::uint64_t session, std::uint32_t mesh) const;
    // Dropped now (its hierarchy stays alive while an object renders it: the slots hold it).
    [[nodiscard]] std::optional<Refusal> remove(std::uint64_t session, std::uint32_t mesh);
    // For an `add`: the built hierarchy and its mode, or the refusal (unknown_object; busy while it builds;
    // bad_message while it uploads or when it failed).
    struct Built {
        std::shared_ptr<const mesh::MeshHierarchy> hierarchy;
        mesh::MeshMode mode = mesh::MeshMode::surface;
    };
    [[nodiscard]] std::variant<Built, Refusal> built(std::uint64_t session, std::uint32_t mesh) const;
    // Force shading: built mesh `mesh`'s corner normals for crease angle `crease_angle_deg`
    // (MeshHierarchy::shading), counted in the mesh's bytes (status, session_bytes, total_bytes) until the mesh is
    // dropped. An angle the mesh keeps costs nothing. A new one is refused before it is built when its table
    // (MeshHierarchy::new_shading_bytes) would take the session's meshes beyond bytes_per_session (session_limit)
    // or every session's beyond bytes_total (capacity), and when the mesh keeps kMaxShadings angles (capacity);
    // unknown_object and the refusals of built() as for an `add`. Builds the table here, on the server thread
    // (O(n), ~16 ms for 100 000 triangles), never on the loop's. Throws std::bad_alloc only.
    [[nodiscard]] std::variant<const mesh::ShadingNormals*, Refusal> shading(std::uint64_t session, std::uint32_t mesh,
                                                                             double crease_angle_deg);

    void drop_session(std::uint64_t session);  // every mesh and upload of the session
    void expire(Clock::time_point now);        // drops uploads silent for longer than upload_timeout
    void collect();                            // takes the worker's finished builds (Ready or Failed)

    [[nodiscard]] std::size_t session_bytes(std::uint64_t session) const;
    [[nodiscard]] std::size_t session_meshes(std::uint64_t session) const;
    [[nodiscard]] std::size_t total_bytes() const noexcept { return total_bytes_; }
    [[nodiscard]] std::size_t meshes() const noexcept { return entries_.size(); }
    [[nodiscard]] const MeshStoreLimits& limits() const noexcept { return limits_; }

  private:
    struct Entry {
        std::uint64_t owner = 0;  // 0: its session dropped it while it builds (freed when the build returns)
        MeshState state = MeshState::Uploading;
        mesh::MeshMode mode = mesh::MeshMode::surface;
        std::size_t vertices = 0, triangles = 0;
        mesh::TriangleMesh data;  // while uploading
        std::shared_ptr<const mesh::MeshHierarchy> hierarchy;
        std::size_t bytes = 0;
        Clock::time_point last_activity{};
        std::string message;
    };
    struct Job {
        std::uint32_t id = 0;
        mesh::TriangleMesh data;
        mesh::MeshMode mode = mesh::MeshMode::surface;
        std::size_t max_vertices = 0, max_triangles = 0;
    };
    struct Result {
        std::uint32_t id = 0;
        std::shared_ptr<const mesh::MeshHierarchy> hierarchy;
        std::string error;
    };
    [[nodiscard]] const Entry* find(std::uint64_t session, std::uint32_t mesh) const;
    [[nodiscard]] Refusal unknown(std::uint32_t mesh) const;
    void erase(std::map<std::uint32_t, Entry>::iterator it);
    void work();

    MeshStoreLimits limits_;
    std::map<std::uint32_t, Entry> entries_;
    std::uint32_t next_id_ = 1;
    std::size_t total_bytes_ = 0;

    std::mutex mutex_;  // jobs_, results_, stop_ (server thread <-> worker)
    std::condition_variable wake_;
    std::deque<Job> jobs_;
    std::deque<Result> results_;
    bool stop_ = false;
    std::thread worker_;
};

}  // namespace hapticd::server
