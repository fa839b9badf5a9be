// SPDX-License-Identifier: Apache-2.0
#include "server/mesh_store.hpp"

#include <exception>
#include <utility>

#include "mesh/triangle_mesh.hpp"

namespace hapticd::server {

namespace {

namespace cl = hapticd::client;

Refusal refusal(cl::ErrorCode code, std::string message) {
    Refusal r;
    r.code = code;
    r.message = std::move(message);
    return r;
}

std::string mib(std::size_t bytes) { return short_number(static_cast<double>(bytes) / (1024.0 * 1024.0)) + " MiB"; }

}  // namespace

const char* to_string(MeshState state) noexcept {
    switch (state) {
        case MeshState::Uploading:
            return "uploading";
        case MeshState::Building:
            return "building";
        case MeshState::Ready:
            return "ready";
        case MeshState::Failed:
            return "failed";
    }
    return "failed";
}

MeshStore::MeshStore(MeshStoreLimits limits) : limits_(limits), worker_([this] { work(); }) {}

MeshStore::~MeshStore() {
    {
        std::lock_guard<std::mutex> lock(mutex_);
        stop_ = true;
        jobs_.clear();
    }
    wake_.notify_all();
    worker_.join();
}

// The worker: one build at a time; whatever a build throws (bad_alloc) fails that mesh, never the thread.
void MeshStore::work() {
    std::unique_lock<std::mutex> lock(mutex_);
    while (true) {
        wake_.wait(lock, [this] { return stop_ || !jobs_.empty(); });
        if (stop_) return;
        Job job = std::move(jobs_.front());
        jobs_.pop_front();
        lock.unlock();
        Result result;
        result.id = job.id;
        try {
            const mesh::MeshLimits limits{job.max_vertices, job.max_triangles};
            if (const std::optional<std::string> why = mesh::mesh_error(job.data, job.mode, limits)) {
                result.error = std::string("the mesh (") + (job.mode == mesh::MeshMode::solid ? "solid" : "surface") +
                               ") is invalid: " + *why;
            } else {
                result.hierarchy = mesh::MeshHierarchy::build(std::move(job.data), job.mode);
            }
        } catch (const std::exception& e) {
            result.error = std::string("building the hierarchy failed: ") + e.what();
        } catch (...) {
            result.error = "building the hierarchy failed";
        }
        lock.lock();
        results_.push_back(std::move(result));
    }
}

const MeshStore::Entry* MeshStore::find(std::uint64_t session, std::uint32_t mesh) const {
    const auto it = entries_.find(mesh);
    if (it == entries_.end() || it->second.owner != session) return nullptr;
    return &it->second;
}

Refusal MeshStore::unknown(std::uint32_t mesh) const {
    return refusal(cl::ErrorCode::UnknownObject,
                   "mesh " + std::to_string(mesh) +
                       ": no such mesh in this session (never begun, deleted, timed out after " +
                       short_number(static_cast<double>(limits_.upload_timeout.count()) / 1000.0) +
                       " s without a chunk, failed, or another session's)");
}

void MeshStore::erase(std::map<std::uint32_t, Entry>::iterator it) {
    if (it->second.state == MeshState::Building) {  // the worker holds its data: freed when the build returns
        it->second.owner = 0;
        return;
    }
    total_bytes_ -= it->second.bytes;
    entries_.erase(it);
}

std::size_t MeshStore::session_bytes(std::uint64_t session) const {
    std::size_t n = 0;
    for (const auto& [id, e] : entries_) n += e.owner == session ? e.bytes : 0;
    return n;
}

std::size_t MeshStore::session_meshes(std::uint64_t session) const {
    std::size_t n = 0;
    for (const auto& [id, e] : entries_) n += e.owner == session ? 1 : 0;
    return n;
}

std::variant<std::uint32_t, Refusal> MeshStore::begin(std::uint64_t session, const MeshBeginRequest& r,
                                                      Clock::time_point now) {
    if (r.vertices < 3 || r.vertices > limits_.max_vertices) {
        return refusal(cl::ErrorCode::BadMessage, "mesh_begin.vertices = " + std::to_string(r.vertices) +
                                                      " is out of range; accepted: 3 .. " +
                                                      std::to_string(limits_.max_vertices));
    }
    if (r.triangles < 1 || r.triangles > limits_.max_triangles) {
        return refusal(cl::ErrorCode::BadMessage, "mesh_begin.triangles = " + std::to_string(r.triangles) +
                                                      " is out of range; accepted: 1 .. " +
                                                      std::to_string(limits_.max_triangles));
    }
    const std::size_t meshes = session_meshes(session);
    if (meshes >= limits_.meshes_per_session) {
        return refusal(cl::ErrorCode::SessionLimit, "mesh_begin: this session holds " + std::to_string(meshes) +
                                                        " meshes (uploading, building or built); accepted: at most " +
                                                        std::to_string(limits_.meshes_per_session) +
                                                        " per session (mesh_delete one first)");
    }
    const std::size_t bytes = upload_bytes(r.vertices, r.triangles);
    const std::size_t held = session_bytes(session);
    if (held + bytes > limits_.bytes_per_session) {
        return refusal(cl::ErrorCode::SessionLimit,
                       "mesh_begin: " + std::to_string(r.vertices) + " vertices and " + std::to_string(r.triangles) +
                           " triangles need " + mib(bytes) + "; this session holds " + mib(held) +
                           " of meshes; accepted: at most " + mib(limits_.bytes_per_session) + " per session");
    }
    if (total_bytes_ + bytes > limits_.bytes_total) {
        return refusal(cl::ErrorCode::Capacity, "mesh_begin: the daemon holds " + mib(total_bytes_) + " of meshes; " +
                                                    mib(bytes) + " more would exceed the " + mib(limits_.bytes_total) +
                                                    " of every session together; retry");
    }
    std::uint32_t id = next_id_;
    while (id == 0 || entries_.count(id) != 0) ++id;  // 2^32 ids: wraps, skips those in use
    next_id_ = id + 1;
    Entry e;
    e.owner = session;
    e.mode = r.solid ? mesh::MeshMode::solid : mesh::MeshMode::surface;
    e.vertices = static_cast<std::size_t>(r.vertices);
    e.triangles = static_cast<std::size_t>(r.triangles);
    e.bytes = bytes;
    e.last_activity = now;
    total_bytes_ += bytes;
    entries_.emplace(id, std::move(e));
    return id;
}

std::optional<Refusal> MeshStore::chunk(std::uint64_t session, const MeshChunkRequest& r, Clock::time_point now) {
    const auto it = entries_.find(r.mesh);
    if (it == entries_.end() || it->second.owner != session) return unknown(r.mesh);
    Entry& e = it->second;
    if (e.state != MeshState::Uploading) {
        return refusal(cl::ErrorCode::BadMessage, "mesh_chunk: mesh " + std::to_string(r.mesh) + " is " +
                                                      to_string(e.state) +
                                                      "; chunks are accepted only while uploading");
    }
    const char* what = r.triangles ? "triangles" : "vertices";
    const std::size_t have = r.triangles ? e.data.triangles.size() : e.data.vertices.size();
    const std::size_t total = r.triangles ? e.triangles : e.vertices;
    const std::size_t count = (r.triangles ? r.indices.size() : r.vertices.size()) / 3;
    if (r.first != have) {
        return refusal(cl::ErrorCode::BadMessage, "mesh_chunk.first = " + std::to_string(r.first) + " for mesh " +
                                                      std::to_string(r.mesh) + "'s " + what + "; expected " +
                                                      std::to_string(have) + " (chunks arrive in order)");
    }
    if (have + count > total) {
        return refusal(cl::ErrorCode::BadMessage, std::string("mesh_chunk.") + what + ": " + std::to_string(count) +
                                                      " more after " + std::to_string(have) + " exceed the " +
                                                      std::to_string(total) + " announced by mesh_begin");
    }
    if (r.triangles) {
        for (std::size_t i = 0; i < count; ++i) {
            e.data.triangles.push_back({r.indices[3 * i], r.indices[3 * i + 1], r.indices[3 * i + 2]});
        }
    } else {
        for (std::size_t i = 0; i < count; ++i) {
            e.data.vertices.emplace_back(r.vertices[3 * i], r.vertices[3 * i + 1], r.vertices[3 * i + 2]);
        }
    }
    e.last_activity = now;
    return std::nullopt;
}

std::optional<Refusal> MeshStore::end(std::uint64_t session, std::uint32_t mesh) {
    const auto it = entries_.find(mesh);
    if (it == entries_.end() || it->second.owner != session) return unknown(mesh);
    Entry& e = it->second;
    if (e.state != MeshState::Uploading) {
        return refusal(cl::ErrorCode::BadMessage,
                       "mesh_end: mesh " + std::to_string(mesh) + " is " + to_string(e.state) + ", not uploading");
    }
    if (e.data.vertices.size() != e.vertices || e.data.triangles.size() != e.triangles) {
        return refusal(cl::ErrorCode::BadMessage,
                       "mesh_end: mesh " + std::to_string(mesh) + " has " + std::to_string(e.data.vertices.size()) +
                           " of " + std::to_string(e.vertices) + " vertices and " +
                           std::to_string(e.data.triangles.size()) + " of " + std::to_string(e.triangles) +
                           " triangles; send the rest first (mesh_chunk)");
    }
    e.state = MeshState::Building;
    {
        std::lock_guard<std::mutex> lock(mutex_);
        jobs_.push_back(Job{mesh, std::move(e.data), e.mode, limits_.max_vertices, limits_.max_triangles});
    }
    e.data = mesh::TriangleMesh{};
    wake_.notify_one();
    return std::nullopt;
}

std::variant<MeshInfo, Refusal> MeshStore::status(std::uint64_t session, std::uint32_t mesh) const {
    const Entry* e = find(session, mesh);
    if (e == nullptr) return unknown(mesh);
    MeshInfo info;
    info.state = e->state;
    info.vertices = e->vertices;
    info.triangles = e->triangles;
    info.received_vertices = e->state == MeshState::Uploading ? e->data.vertices.size() : e->vertices;
    info.received_triangles = e->state == MeshState::Uploading ? e->data.triangles.size() : e->triangles;
    info.bytes = e->bytes;
    info.message = e->message;
    return info;
}

std::optional<Refusal> MeshStore::remove(std::uint64_t session, std::uint32_t mesh) {
    const auto it = entries_.find(mesh);
    if (it == entries_.end() || it->second.owner != session) return unknown(mesh);
    erase(it);
    return std::nullopt;
}

std::variant<MeshStore::Built, Refusal> MeshStore::built(std::uint64_t session, std::uint32_t mesh) const {
    const Entry* e = find(session, mesh);
    if (e == nullptr) return unknown(mesh);
    switch (e->state) {
        case MeshState::Ready:
            return Built{e->hierarchy, e->mode};
        case MeshState::Building:
            return refusal(cl::ErrorCode::Busy, "object.mesh: mesh " + std::to_string(mesh) +
                                                    " is still being built (mesh_status says when it is ready); retry");
        case MeshState::Uploading:
            return refusal(cl::ErrorCode::BadMessage, "object.mesh: mesh " + std::to_string(mesh) +
                                                          " is still uploading; finish it with mesh_end first");
        case MeshState::Failed:
            return refusal(cl::ErrorCode::BadMessage,
                           "object.mesh: mesh " + std::to_string(mesh) + " failed: " + e->message);
    }
    return unknown(mesh);
}

std::variant<const mesh::ShadingNormals*, Refusal> MeshStore::shading(std::uint64_t session, std::uint32_t mesh,
                                                                      double crease_angle_deg) {
    const auto it = entries_.find(mesh);
    if (it == entries_.end() || it->second.owner != session) return unknown(mesh);
    Entry& e = it->second;
    if (e.state != MeshState::Ready) return std::get<Refusal>(built(session, mesh));
    const mesh::MeshHierarchy& h = *e.hierarchy;
    if (const mesh::ShadingNormals* kept = h.kept_shading(crease_angle_deg)) return kept;
    const std::string field =
        "mesh.shading.crease_angle_deg = " + short_number(crease_angle_deg) + ": mesh " + std::to_string(mesh);
    if (h.shadings_kept() >= mesh::MeshHierarchy::kMaxShadings) {
        return refusal(cl::ErrorCode::Capacity, field + " already keeps the normals of " +
                                                    std::to_string(mesh::MeshHierarchy::kMaxShadings) +
                                                    " other crease angles; accepted: one of those");
    }
    const std::size_t bytes = h.new_shading_bytes();
    const std::string need = field + "'s corner normals for a new crease angle need " + mib(bytes) + " (" +
                             std::to_string(bytes) + " bytes, " + std::to_string(h.mesh().triangles.size()) +
                             " triangles)";
    const std::size_t held = session_bytes(session);
    if (held + bytes > limits_.bytes_per_session) {
        return refusal(cl::ErrorCode::SessionLimit,
                       need + "; this session holds " + mib(held) + " (" + std::to_string(held) +
                           " bytes) of meshes; accepted: at most " + mib(limits_.bytes_per_session) + " (" +
                           std::to_string(limits_.bytes_per_session) +
                           " bytes) per session (a crease angle the mesh already keeps, or mesh_delete a mesh first)");
    }
    if (total_bytes_ + bytes > limits_.bytes_total) {
        return refusal(cl::ErrorCode::Capacity,
                       need + "; the daemon holds " + mib(total_bytes_) + " (" + std::to_string(total_bytes_) +
                           " bytes) of meshes; that much more would exceed the " + mib(limits_.bytes_total) + " (" +
                           std::to_string(limits_.bytes_total) + " bytes) of every session together; retry");
    }
    const mesh::ShadingNormals* built_now = h.shading(crease_angle_deg);
    if (built_now == nullptr) return refusal(cl::ErrorCode::Capacity, field + ": its crease angles are taken; retry");
    const std::size_t added = built_now->memory_bytes();  // = bytes: each vector sized once to the triangle count
    e.bytes += added;
    total_bytes_ += added;
    return built_now;
}

void MeshStore::drop_session(std::uint64_t session) {
    for (auto it = entries_.begin(); it != entries_.end();) {
        const auto next = std::next(it);
        if (it->second.owner == session) erase(it);
        it = next;
    }
}

void MeshStore::expire(Clock::time_point now) {
    for (auto it = entries_.begin(); it != entries_.end();) {
        const auto next = std::next(it);
        if (it->second.state == MeshState::Uploading && now - it->second.last_activity > limits_.upload_timeout) {
            erase(it);
        }
        it = next;
    }
}

void MeshStore::collect() {
    std::deque<Result> done;
    {
        std::lock_guard<std::mutex> lock(mutex_);
        done.swap(results_);
    }
    for (Result& r : done) {
        const auto it = entries_.find(r.id);
        if (it == entries_.end()) continue;
        Entry& e = it->second;
        if (e.owner == 0) {  // dropped while it was built
            total_bytes_ -= e.bytes;
            entries_.erase(it);
            continue;
        }
        if (!r.hierarchy) {
            e.state = MeshState::Failed;
            e.message = r.error;
            continue;
        }
        // Once built, the mesh counts what its hierarchy holds (it keeps its own copy of the geometry).
        const std::size_t bytes = r.hierarchy->memory_bytes();
        const std::size_t others = session_bytes(e.owner) - e.bytes;
        const std::size_t rest = total_bytes_ - e.bytes;
        if (others + bytes > limits_.bytes_per_session || rest + bytes > limits_.bytes_total) {
            e.state = MeshState::Failed;
            e.message = "its hierarchy holds " + mib(bytes) + ", beyond the session's " +
                        mib(limits_.bytes_per_session) + " or every session's " + mib(limits_.bytes_total) +
                        " of meshes";
            continue;
        }
        total_bytes_ = rest + bytes;
        e.bytes = bytes;
        e.hierarchy = std::move(r.hierarchy);
        e.state = MeshState::Ready;
    }
}

}  // namespace hapticd::server
