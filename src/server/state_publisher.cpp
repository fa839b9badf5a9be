// SPDX-License-Identifier: Apache-2.0
#include "server/state_publisher.hpp"

#include <fcntl.h>
#include <pwd.h>
#include <sys/stat.h>
#include <sys/mman.h>
#include <unistd.h>

#include <array>
#include <atomic>
#include <bit>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <ctime>
#include <new>
#include <stdexcept>

#include "scene/scene_objects.hpp"

namespace hapticd {

namespace {

std::string user_text(uid_t uid) {
    std::string text = "uid " + std::to_string(uid);
    std::array<char, 1024> buffer{};
    passwd entry{};
    passwd* found = nullptr;
    if (::getpwuid_r(uid, &entry, buffer.data(), buffer.size(), &found) == 0 && found != nullptr) {
        text += std::string(" (") + found->pw_name + ")";
    }
    return text;
}

// The segment, new, mode 0640, with this process's effective uid as its owner (O_CREAT | O_EXCL: never one
// another user made). A segment of that name that exists already is replaced only when this euid owns it
// (a stale one of a daemon that died): /dev/shm is sticky, so no other user can unlink or rename a segment we
// own between the check and the unlink. One that belongs to another user is refused: it could be read or
// fed by its owner, and unlinking it (which root could) would hide whatever made it.
int create_segment(const std::string& name) {
    const int flags = O_CREAT | O_EXCL | O_RDWR | O_CLOEXEC | O_NOFOLLOW;
    int fd = ::shm_open(name.c_str(), flags, 0640);
    if (fd >= 0) return fd;
    if (errno != EEXIST) throw std::runtime_error("StatePublisher: shm_open('" + name + "'): " + std::strerror(errno));
    const std::string path = std::string(kShmDirectory) + name;
    struct stat st {};
    if (::lstat(path.c_str(), &st) != 0) {
        throw std::runtime_error("StatePublisher: --serve-shm '" + name + "': " + path +
                                 " exists but lstat failed: " + std::strerror(errno));
    }
    const uid_t self = ::geteuid();
    if (st.st_uid != self || !S_ISREG(st.st_mode)) {
        throw std::runtime_error(
            "--serve-shm '" + name + "': the state segment " + path + " exists and belongs to " + user_text(st.st_uid) +
            (S_ISREG(st.st_mode) ? "" : " (not a regular file)") + ", not to this daemon's user " + user_text(self) +
            "; accepted: no segment of that name, or a stale one this user owns (replaced). Remove it as its "
            "owner or as root (rm " +
            path + ") after finding who made it, or choose another --serve-shm name");
    }
    if (::shm_unlink(name.c_str()) != 0 && errno != ENOENT) {
        throw std::runtime_error("StatePublisher: shm_unlink('" + name +
                                 "') of this user's stale segment: " + std::strerror(errno));
    }
    fd = ::shm_open(name.c_str(), flags, 0640);
    if (fd < 0) {
        throw std::runtime_error("StatePublisher: shm_open('" + name + "') after removing this user's stale segment: " +
                                 std::strerror(errno) + " (another process created it meanwhile)");
    }
    return fd;
}

}  // namespace

StatePublisher::StatePublisher(const std::string& shm_name, std::size_t axes, double period_s, int gid)
    : name_(shm_name) {
    if (shm_name.size() < 2 || shm_name[0] != '/' || shm_name.find('/', 1) != std::string::npos ||
        shm_name.size() > 200) {
        throw std::runtime_error("StatePublisher: shm name '" + shm_name +
                                 "' is invalid; accepted: '/' followed by 1..199 characters without '/'");
    }
    const int fd = create_segment(shm_name);
    if (::ftruncate(fd, sizeof(StateLayout)) != 0) {
        const int e = errno;
        ::close(fd);
        ::shm_unlink(shm_name.c_str());
        throw std::runtime_error("StatePublisher: ftruncate('" + shm_name + "'): " + std::strerror(e));
    }
    if (gid >= 0 && ::fchown(fd, static_cast<uid_t>(-1), static_cast<gid_t>(gid)) != 0) {
        const int e = errno;
        ::close(fd);
        ::shm_unlink(shm_name.c_str());
        throw std::runtime_error("StatePublisher: fchown('" + shm_name + "', group " + std::to_string(gid) +
                                 "): " + std::strerror(e));
    }
    void* p = ::mmap(nullptr, sizeof(StateLayout), PROT_READ | PROT_WRITE, MAP_SHARED, fd, 0);
    const int e = errno;
    ::close(fd);
    if (p == MAP_FAILED) {
        ::shm_unlink(shm_name.c_str());
        throw std::runtime_error("StatePublisher: mmap('" + shm_name + "'): " + std::strerror(e));
    }
    std::memset(p, 0, sizeof(StateLayout));
    layout_ = new (p) StateLayout{};
    layout_->axes = static_cast<std::uint32_t>(axes);
    layout_->period_s = period_s;
    layout_->capacity = static_cast<std::uint32_t>(kStateObjectCapacity);
    layout_->size = sizeof(StateLayout);
    layout_->layout_version = kStateLayoutVersion;
    layout_->writer_pid = static_cast<std::int32_t>(::getpid());
    layout_->mesh_proxy_capacity = static_cast<std::uint32_t>(kStateMeshProxyCapacity);
    layout_->heartbeat_ns.store(0, std::memory_order_relaxed);
    layout_->fatal_signal.store(0, std::memory_order_relaxed);
    layout_->sequence.store(0, std::memory_order_relaxed);
    std::atomic_thread_fence(std::memory_order_release);
    layout_->magic = kStateMagic;  // last: a reader that sees the magic sees a complete header
}

StatePublisher::~StatePublisher() {
    if (layout_ != nullptr) {
        ::munmap(layout_, sizeof(StateLayout));
        ::shm_unlink(name_.c_str());
    }
}

namespace {

std::int64_t monotonic_ns() noexcept {
    timespec ts{};
    ::clock_gettime(CLOCK_MONOTONIC, &ts);  // vDSO on x86-64 and arm64: no system call
    return static_cast<std::int64_t>(ts.tv_sec) * 1000000000 + ts.tv_nsec;
}

// The fields are written by the loop and read by the server thread of the same process under the seqlock:
// relaxed atomic accesses (std::atomic_ref) make that well-defined (and visible to ThreadSanitizer);
// on x86-64 and arm64 they compile to plain loads and stores.
template <class T>
void put(T& field, T value) noexcept {
    std::atomic_ref<T>(field).store(value, std::memory_order_relaxed);
}
template <class T>
T get(const T& field) noexcept {
    return std::atomic_ref<T>(const_cast<T&>(field)).load(std::memory_order_relaxed);
}

}  // namespace

void StatePublisher::beat() noexcept {
    if (!fatal_.load(std::memory_order_acquire)) layout_->heartbeat_ns.store(monotonic_ns(), std::memory_order_release);
}

void StatePublisher::mark_fatal(StateFault fault, int signal_number) noexcept {
    fatal_.store(true, std::memory_order_seq_cst);
    StateLayout& l = *layout_;
    // A publication in progress on the loop's thread ends within microseconds; on this thread (the signal
    // interrupted it) it never ends: give up after ~2 ms and close the seqlock ourselves.
    const std::int64_t until = monotonic_ns() + 2000000;
    while ((l.sequence.load(std::memory_order_acquire) & 1U) != 0U && monotonic_ns() < until) {
    }
    const std::uint64_t s = l.sequence.load(std::memory_order_relaxed) | 1U;  // odd: writing
    l.sequence.store(s, std::memory_order_relaxed);
    std::atomic_thread_fence(std::memory_order_release);
    put(l.fault, static_cast<std::uint32_t>(fault));
    l.fatal_signal.store(static_cast<std::uint32_t>(signal_number), std::memory_order_relaxed);
    l.sequence.store(s + 1, std::memory_order_release);
}

// The first kStateMeshProxyCapacity mesh slots' proxies, in slot order (inside the seqlock of publish). A scene
// without meshes costs one pass over the (empty) mesh list and two stores; the entries a previous tick wrote beyond
// this tick's count are zeroed once.
void StatePublisher::publish_mesh_proxies(StateLayout& l, const SceneObjects& objects) noexcept {
    const std::uint64_t meshes = objects.mesh_slot_mask();
    std::uint32_t n = 0;
    for (std::uint64_t rest = meshes; rest != 0 && n < kStateMeshProxyCapacity; rest &= rest - 1) {
        const auto slot = static_cast<std::size_t>(std::countr_zero(rest));
        MeshProxyView v;
        if (!objects.mesh_proxy(slot, v)) continue;
        StateMeshProxy& e = l.mesh_proxy[n++];
        for (std::size_t a = 0; a < 3; ++a) {
            put(e.proxy[a], v.proxy[a]);
            for (std::size_t i = 0; i < 3; ++i) put(e.normal[i][a], static_cast<float>(v.normals[i][a]));
        }
        put(e.triangle, v.triangle);
        put(e.slot, static_cast<std::uint8_t>(slot));
        put(e.constraints, static_cast<std::uint8_t>(v.constraints));
        put(e.flags, static_cast<std::uint8_t>((v.sliding ? kMeshProxySliding : 0U) |
                                               (v.converged ? 0U : kMeshProxyUnconverged)));
        put(e.object_id, v.object_id);
    }
    for (std::uint32_t i = n; i < published_mesh_proxies_; ++i) {
        StateMeshProxy& e = l.mesh_proxy[i];
        for (std::size_t a = 0; a < 3; ++a) {
            put(e.proxy[a], 0.0);
            for (std::size_t k = 0; k < 3; ++k) put(e.normal[k][a], 0.0F);
        }
        put(e.triangle, std::uint32_t{0});
        put(e.slot, std::uint8_t{0});
        put(e.constraints, std::uint8_t{0});
        put(e.flags, std::uint8_t{0});
        put(e.object_id, std::uint32_t{0});
    }
    published_mesh_proxies_ = n;
    put(l.mesh_slot_mask, meshes);
    put(l.mesh_proxies, n);
}

void StatePublisher::publish(const StateTick& t, const SceneObjects* objects) noexcept {
    if (fatal_.load(std::memory_order_acquire)) return;  // the daemon is dying: mark_fatal's fault stays
    StateLayout& l = *layout_;
    const std::uint64_t s = l.sequence.load(std::memory_order_relaxed);
    l.sequence.store(s + 1, std::memory_order_relaxed);
    std::atomic_thread_fence(std::memory_order_release);
    put(l.tick, t.tick);
    put(l.time_s, t.time_s);
    for (std::size_t a = 0; a < 3; ++a) {
        put(l.position[a], t.position[a]);
        put(l.velocity[a], t.velocity[a]);
        put(l.force[a], t.force[a]);
    }
    put(l.overruns, t.overruns);
    put(l.wake_latency_ns, t.wake_latency_ns);
    put(l.fault, static_cast<std::uint32_t>(t.fault));
    put(l.config_contact_mask, t.config_contact_mask);
    if (objects != nullptr) {
        put(l.contact_mask, objects->contact_mask() &
                                objects->occupied_mask());  // no contact without an object (a slot freed this tick)
        put(l.last_commit_seq, objects->stats().last_commit_seq);
        // The slot table changes only with a commit or a ramp step: rewritten then, otherwise what the
        // segment holds is still this tick's (64 ids and ramps are most of a publication's cost).
        if (objects->slot_table_version() != published_slot_table_ || !slot_table_written_) {
            for (std::size_t i = 0; i < kStateObjectCapacity; ++i) {
                put(l.slot_object_id[i], objects->slot_object_id(i));
                put(l.slot_ramp[i], static_cast<std::uint8_t>(255.0 * objects->slot_ramp(i) +
                                                              0.5));  // ramp in [0, 1]: rounds, no lround call
            }
            put(l.objects, objects->occupied());
            published_slot_table_ = objects->slot_table_version();
            slot_table_written_ = true;
        }
        publish_mesh_proxies(l, *objects);
    }
    l.sequence.store(s + 2, std::memory_order_release);
    l.heartbeat_ns.store(monotonic_ns(), std::memory_order_release);
}

bool StatePublisher::read(StateLayout& out) const noexcept {
    const StateLayout& l = *layout_;
    // An odd sequence: the loop is inside a publication, where a loaded machine can preempt it for milliseconds.
    // Waited out up to the state's stale age (a loop that holds it longer has stalled), not counted as an attempt.
    const auto odd_limit_ns = static_cast<std::int64_t>(1e9 * state_stale_after_s(l.period_s));
    std::int64_t odd_since_ns = -1;
    for (int attempt = 0; attempt < 10000;) {
        const std::uint64_t s1 = l.sequence.load(std::memory_order_acquire);
        if ((s1 & 1U) != 0U) {
            const std::int64_t now = monotonic_ns();
            if (odd_since_ns < 0) {
                odd_since_ns = now;
            } else if (now - odd_since_ns > odd_limit_ns) {
                return false;
            }
            continue;
        }
        odd_since_ns = -1;
        ++attempt;
        out.tick = get(l.tick);
        out.time_s = get(l.time_s);
        for (std::size_t a = 0; a < 3; ++a) {
            out.position[a] = get(l.position[a]);
            out.velocity[a] = get(l.velocity[a]);
            out.force[a] = get(l.force[a]);
        }
        out.contact_mask = get(l.contact_mask);
        out.config_contact_mask = get(l.config_contact_mask);
        out.overruns = get(l.overruns);
        out.wake_latency_ns = get(l.wake_latency_ns);
        out.last_commit_seq = get(l.last_commit_seq);
        out.fault = get(l.fault);
        out.objects = get(l.objects);
        for (std::size_t i = 0; i < kStateObjectCapacity; ++i) out.slot_object_id[i] = get(l.slot_object_id[i]);
        out.mesh_slot_mask = get(l.mesh_slot_mask);
        out.mesh_proxies = get(l.mesh_proxies);
        for (std::uint32_t i = 0; i < out.mesh_proxies && i < kStateMeshProxyCapacity; ++i) {
            const StateMeshProxy& e = l.mesh_proxy[i];
            StateMeshProxy& o = out.mesh_proxy[i];
            for (std::size_t a = 0; a < 3; ++a) {
                o.proxy[a] = get(e.proxy[a]);
                for (std::size_t k = 0; k < 3; ++k) o.normal[k][a] = get(e.normal[k][a]);
            }
            o.triangle = get(e.triangle);
            o.slot = get(e.slot);
            o.constraints = get(e.constraints);
            o.flags = get(e.flags);
            o.object_id = get(e.object_id);
        }
        std::atomic_thread_fence(std::memory_order_acquire);
        if (l.sequence.load(std::memory_order_relaxed) == s1) return true;
    }
    return false;
}

}  // namespace hapticd
