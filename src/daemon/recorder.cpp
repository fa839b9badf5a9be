// SPDX-License-Identifier: Apache-2.0
#include "daemon/recorder.hpp"

#include <algorithm>
#include <bit>
#include <cerrno>
#include <chrono>
#include <cstring>
#include <stdexcept>
#include <vector>

namespace hapticd {

static_assert(std::endian::native == std::endian::little,
              "the recording format is little-endian (daemon/recording_format.hpp)");

Recorder::Recorder(const std::string& path, const std::string& header_json, std::size_t tick_capacity, bool blocking)
    : path_(path), ticks_(tick_capacity), batches_(kBatchCapacity), blocking_(blocking) {
    file_ = std::fopen(path.c_str(), "wb");
    if (file_ == nullptr) {
        throw std::runtime_error("record: cannot open '" + path + "' for writing: " + std::strerror(errno));
    }
    // Header: magic, version, size H (16 + the JSON, padded with spaces to a multiple of the chunk size).
    const std::size_t h =
        (16 + header_json.size() + recording::kChunkSize - 1) / recording::kChunkSize * recording::kChunkSize;
    std::vector<char> header(h, ' ');
    std::memcpy(header.data(), recording::kMagic, 8);
    const std::uint32_t version = recording::kFormatVersion;
    const auto size = static_cast<std::uint32_t>(h);
    std::memcpy(header.data() + 8, &version, 4);
    std::memcpy(header.data() + 12, &size, 4);
    std::memcpy(header.data() + 16, header_json.data(), header_json.size());
    if (std::fwrite(header.data(), 1, header.size(), file_) != header.size()) write_error_ = true;
    checksum_ = recording::fnv1a64(nullptr, 0);
    thread_ = std::thread([this] { run(); });
}

Recorder::~Recorder() { close(); }

void Recorder::on_taken(const ObjectCommit& commit, CommitSource source) noexcept {
    scratch_.tick = tick_;
    scratch_.index = index_++;
    scratch_.source = source;
    scratch_.commit = commit;
    if (batches_.try_push(scratch_)) return;
    if (!blocking_) {
        dropped_batches_.fetch_add(1, std::memory_order_relaxed);
        return;
    }
    while (!batches_.try_push(scratch_)) std::this_thread::yield();
}

void Recorder::push_tick(recording::TickChunk& chunk) noexcept {
    chunk.batches = index_;
    if (ticks_.try_push(chunk)) return;
    if (!blocking_) {
        dropped_ticks_.fetch_add(1, std::memory_order_relaxed);
        return;
    }
    while (!ticks_.try_push(chunk)) std::this_thread::yield();
}

void Recorder::on_mesh(std::uint32_t mesh_id, const std::shared_ptr<const mesh::MeshHierarchy>& hierarchy) {
    if (!hierarchy || !announced_.insert(mesh_id).second) return;
    std::lock_guard<std::mutex> lock(meshes_mutex_);
    pending_.push_back(PendingMesh{mesh_id, hierarchy});
}

// The mesh record: its head, then its vertices 5 a chunk and its triangles 10 a chunk, exactly as uploaded
// (the hierarchy keeps the mesh it was built from: MeshHierarchy::mesh()).
void Recorder::write_mesh(const PendingMesh& m) noexcept {
    const mesh::TriangleMesh& data = m.hierarchy->mesh();
    recording::MeshChunk head;
    head.mode = m.hierarchy->mode() == mesh::MeshMode::solid ? 1 : 0;
    head.mesh = m.id;
    head.vertices = data.vertices.size();
    head.triangles = data.triangles.size();
    write_chunk(&head);
    for (std::size_t first = 0; first < data.vertices.size(); first += recording::kVerticesPerChunk) {
        recording::MeshVerticesChunk c;
        c.count = static_cast<std::uint32_t>(
            std::min<std::size_t>(recording::kVerticesPerChunk, data.vertices.size() - first));
        for (std::uint32_t i = 0; i < c.count; ++i) {
            for (int k = 0; k < 3; ++k) c.xyz[3 * i + k] = data.vertices[first + i][k];
        }
        write_chunk(&c);
    }
    for (std::size_t first = 0; first < data.triangles.size(); first += recording::kTrianglesPerChunk) {
        recording::MeshTrianglesChunk c;
        c.count = static_cast<std::uint32_t>(
            std::min<std::size_t>(recording::kTrianglesPerChunk, data.triangles.size() - first));
        for (std::uint32_t i = 0; i < c.count; ++i) {
            for (std::size_t k = 0; k < 3; ++k) c.indices[3 * i + k] = data.triangles[first + i][k];
        }
        write_chunk(&c);
    }
    meshes_written_.fetch_add(1, std::memory_order_relaxed);
}

void Recorder::write_meshes() noexcept {
    {
        std::lock_guard<std::mutex> lock(meshes_mutex_);
        if (pending_.empty()) return;
        taken_.swap(pending_);
    }
    try {
        for (const PendingMesh& m : taken_) {
            write_mesh(m);
            written_.insert(m.id);
        }
    } catch (...) {  // bad_alloc of the set: the recording cannot name that mesh
        write_error_.store(true, std::memory_order_relaxed);
    }
    taken_.clear();  // the hierarchies are the server's again
}

void Recorder::write_chunk(const void* chunk) noexcept {
    checksum_ = recording::fnv1a64(chunk, recording::kChunkSize, checksum_);
    if (std::fwrite(chunk, 1, recording::kChunkSize, file_) != recording::kChunkSize) {
        write_error_.store(true, std::memory_order_relaxed);
    }
}

void Recorder::write_batch(const BatchEntry& b) noexcept {
    // A mesh a batch renders was queued before the batch was pushed (Server: on_mesh, then the ring): its record
    // goes first.
    for (std::uint32_t i = 0; i < b.commit.count && i < kSceneObjectCapacity; ++i) {
        const ObjectParams& p = b.commit.updates[i].params;
        if (p.mesh == nullptr || written_.count(p.mesh_id) != 0) continue;
        write_meshes();
        if (written_.count(p.mesh_id) == 0) missing_mesh_ = true;  // the replay could not render it: incomplete
    }
    recording::BatchChunk head;
    head.source = static_cast<std::uint8_t>(b.source);
    head.tick = b.tick;
    head.seq = b.commit.seq;
    head.count = b.commit.count;
    head.index = b.index;
    write_chunk(&head);
    for (std::uint32_t i = 0; i < b.commit.count && i < kSceneObjectCapacity; ++i) {
        const SlotUpdate& u = b.commit.updates[i];
        const ObjectParams& p = u.params;
        recording::UpdateChunkA a;
        a.slot = u.slot;
        a.action = static_cast<std::uint8_t>(u.action);
        a.object_kind = static_cast<std::uint8_t>(p.kind);
        a.bilateral = p.bilateral ? 1 : 0;
        a.constraint = static_cast<std::uint8_t>(p.constraint);
        a.id = p.id;
        for (std::size_t k = 0; k < 3; ++k) {
            a.direction[k] = p.direction[k];
            a.point[k] = p.point[k];
            a.force[k] = p.force[k];
        }
        a.offset = p.offset;
        a.radius = p.radius;
        a.K = p.K;
        a.B = p.B;
        a.offset_rate = p.offset_rate;
        recording::UpdateChunkB bb;
        for (std::size_t r = 0; r < 3; ++r) {
            for (std::size_t c = 0; c < 3; ++c) bb.jacobian[3 * r + c] = p.jacobian[r][c];
            bb.point_rate[r] = p.point_rate[r];
        }
        recording::UpdateChunkC cc;
        cc.mesh = p.mesh != nullptr ? p.mesh_id : 0;
        for (std::size_t k = 0; k < 4; ++k) cc.orientation[k] = p.orientation[k];
        cc.static_friction = p.static_friction;
        cc.dynamic_friction = p.dynamic_friction;
        if (p.shading != nullptr) {
            cc.shading = 1;
            cc.crease_angle_deg = p.crease_angle_deg;
        }
        write_chunk(&a);
        write_chunk(&bb);
        write_chunk(&cc);
        ++updates_;
    }
    batches_written_.fetch_add(1, std::memory_order_relaxed);
}

// Each tick chunk after the batches its tick took: a tick's batches are pushed before its tick record, so once
// the tick record is visible here, so are they.
std::size_t Recorder::drain() noexcept {
    recording::TickChunk t;
    std::size_t n = 0;
    while (ticks_.try_pop(t)) {
        for (const BatchEntry* b = batches_.front(); b != nullptr && b->tick <= t.tick; b = batches_.front()) {
            write_batch(*b);
            batches_.pop();
            ++n;
        }
        write_chunk(&t);
        ticks_written_.fetch_add(1, std::memory_order_relaxed);
        ++n;
    }
    return n;
}

void Recorder::run() noexcept {
    while (!stop_.load(std::memory_order_acquire)) {
        write_meshes();
        if (drain() == 0) std::this_thread::sleep_for(std::chrono::milliseconds(2));
    }
    drain();  // everything pushed before stop_ was set (a mesh a batch names is written before that batch)
    // Batches of a tick whose record was dropped or never pushed (none in blocking mode).
    for (const BatchEntry* b = batches_.front(); b != nullptr; b = batches_.front()) {
        write_batch(*b);
        batches_.pop();
    }
}

bool Recorder::close() noexcept {
    if (closed_) return !write_error();
    closed_ = true;
    stop_.store(true, std::memory_order_release);
    if (thread_.joinable()) thread_.join();
    if (file_ != nullptr) {
        recording::EndChunk end;
        end.ticks = ticks_written();
        end.batches = batches_written();
        end.updates = updates_;
        end.dropped_ticks = dropped_ticks();
        end.dropped_batches = dropped_batches();
        end.checksum = checksum_;
        end.meshes = meshes_written();
        end.complete = end.dropped_ticks == 0 && end.dropped_batches == 0 && !write_error() && !missing_mesh_ ? 1U : 0U;
        if (std::fwrite(&end, 1, sizeof end, file_) != sizeof end) write_error_ = true;
        if (std::fflush(file_) != 0) write_error_ = true;
        if (std::fclose(file_) != 0) write_error_ = true;
        file_ = nullptr;
    }
    return !write_error();
}

}  // namespace hapticd
