// SPDX-License-Identifier: Apache-2.0
// The reader side of the state seqlock (docs/protocol.md, section 6).
#include <fcntl.h>
#include <sys/mman.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <cstring>
#include <ctime>

#include "hapticd/client.hpp"

namespace hapticd::client {

StateReader StateReader::open(const std::string& shm_name) {
    const int fd = ::shm_open(shm_name.c_str(), O_RDONLY, 0);
    if (fd < 0) {
        throw Error(ErrorCode::Transport, "StateReader::open: shm_open('" + shm_name + "'): " + std::strerror(errno) +
                                              " (is hapticd running with --serve?)");
    }
    void* p = ::mmap(nullptr, sizeof(StateLayout), PROT_READ, MAP_SHARED, fd, 0);
    const int e = errno;
    ::close(fd);
    if (p == MAP_FAILED)
        throw Error(ErrorCode::Transport, "StateReader::open: mmap('" + shm_name + "'): " + std::strerror(e));
    const auto* layout = static_cast<const StateLayout*>(p);
    if (layout->magic != kStateMagic || layout->layout_version != kStateLayoutVersion ||
        layout->size != sizeof(StateLayout)) {
        const std::uint32_t version = layout->layout_version;
        ::munmap(p, sizeof(StateLayout));
        throw Error(ErrorCode::Transport,
                    "StateReader::open: '" + shm_name + "' is not a hapticd state of layout version " +
                        std::to_string(kStateLayoutVersion) + " (found version " + std::to_string(version) + ")");
    }
    return StateReader(layout);
}

StateReader::StateReader(StateReader&& other) noexcept : layout_(other.layout_) { other.layout_ = nullptr; }

StateReader& StateReader::operator=(StateReader&& other) noexcept {
    if (this != &other) {
        if (layout_ != nullptr) ::munmap(const_cast<StateLayout*>(layout_), sizeof(StateLayout));
        layout_ = other.layout_;
        other.layout_ = nullptr;
    }
    return *this;
}

StateReader::~StateReader() {
    if (layout_ != nullptr) ::munmap(const_cast<StateLayout*>(layout_), sizeof(StateLayout));
}

std::size_t StateReader::axes() const noexcept { return layout_->axes; }
double StateReader::period_s() const noexcept { return layout_->period_s; }
double StateReader::stale_after_s() const noexcept { return state_stale_after_s(layout_->period_s); }
long StateReader::writer_pid() const noexcept { return layout_->writer_pid; }
std::size_t StateReader::mesh_proxy_capacity() const noexcept {
    return layout_->mesh_proxy_capacity < kStateMeshProxyCapacity ? layout_->mesh_proxy_capacity
                                                                  : kStateMeshProxyCapacity;
}

namespace {

std::int64_t monotonic_now_ns() noexcept {
    timespec ts{};
    ::clock_gettime(CLOCK_MONOTONIC, &ts);
    return static_cast<std::int64_t>(ts.tv_sec) * 1000000000 + ts.tv_nsec;
}

}  // namespace

bool StateReader::read(StateSample& out, int max_attempts) const noexcept {
    const StateLayout& l = *layout_;
    // An odd sequence: the writer is inside a publication. The loop's thread can be preempted there for
    // milliseconds on a loaded machine; the reader waits for it up to the stale age (a writer that holds the
    // sequence odd longer has stalled or died mid-write) without counting an attempt.
    const auto odd_limit_ns = static_cast<std::int64_t>(1e9 * stale_after_s());
    std::int64_t odd_since_ns = -1;
    for (int attempt = 0; attempt < max_attempts;) {
        const std::uint64_t s1 = l.sequence.load(std::memory_order_acquire);
        if ((s1 & 1U) != 0U) {
            const std::int64_t now = monotonic_now_ns();
            if (odd_since_ns < 0) {
                odd_since_ns = now;
            } else if (now - odd_since_ns > odd_limit_ns) {
                return false;
            }
            continue;
        }
        odd_since_ns = -1;
        ++attempt;
        out.tick = l.tick;
        out.time_s = l.time_s;
        for (std::size_t i = 0; i < 3; ++i) {
            out.position[i] = l.position[i];
            out.velocity[i] = l.velocity[i];
            out.force[i] = l.force[i];
        }
        out.contact_mask = l.contact_mask;
        out.config_contact_mask = l.config_contact_mask;
        out.overruns = l.overruns;
        out.wake_latency_ns = l.wake_latency_ns;
        out.last_commit_seq = l.last_commit_seq;
        out.fault = l.fault;
        out.objects = l.objects;
        std::memcpy(out.slot_object_id.data(), l.slot_object_id, sizeof(l.slot_object_id));
        out.mesh_slot_mask = l.mesh_slot_mask;
        const std::uint32_t proxies = l.mesh_proxies;
        out.mesh_proxies = proxies < kStateMeshProxyCapacity ? proxies : kStateMeshProxyCapacity;
        for (std::uint32_t i = 0; i < out.mesh_proxies; ++i) {
            const StateMeshProxy& e = l.mesh_proxy[i];
            MeshProxySample& o = out.mesh_proxy[i];
            o.object_id = e.object_id;
            o.slot = e.slot;
            for (std::size_t a = 0; a < 3; ++a) {
                o.proxy[a] = e.proxy[a];
                for (std::size_t k = 0; k < 3; ++k) o.normals[k][a] = e.normal[k][a];
            }
            o.constraints = e.constraints;
            o.triangle = e.triangle;
            o.sliding = (e.flags & kMeshProxySliding) != 0U;
            o.converged = (e.flags & kMeshProxyUnconverged) == 0U;
        }
        std::atomic_thread_fence(std::memory_order_acquire);
        if (l.sequence.load(std::memory_order_relaxed) == s1) {
            const std::int64_t beat = l.heartbeat_ns.load(std::memory_order_acquire);
            const std::int64_t now = monotonic_now_ns();
            out.heartbeat_age_s = beat == 0 ? -1.0 : 1e-9 * static_cast<double>(now - beat);
            out.stale = beat == 0 || out.heartbeat_age_s > stale_after_s() ||
                        out.fault == static_cast<std::uint32_t>(StateFault::FatalSignal) ||
                        out.fault == static_cast<std::uint32_t>(StateFault::Terminate);
            out.fatal_signal = l.fatal_signal.load(std::memory_order_relaxed);
            return true;
        }
    }
    return false;
}

}  // namespace hapticd::client
