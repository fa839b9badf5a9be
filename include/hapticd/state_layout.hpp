// SPDX-License-Identifier: Apache-2.0
// The shared-memory state of hapticd (docs/protocol.md, section 6): one struct written once per tick by
// the loop under a seqlock, read by any process without a system call. Layout version 2; the offsets are
// part of the protocol and checked by static_asserts below. The mesh proxies (bytes 600..1119) use bytes that
// were reserved and zero: a reader of version 2 that does not know them reads every other field as before, and a
// reader that knows them learns from the header's mesh_proxy_capacity whether the writer publishes them (0: a
// daemon that does not; its segment holds zeros there).
// Liveness (docs/protocol.md, section 6): the loop stores CLOCK_MONOTONIC into heartbeat_ns after every
// tick; a reader calls the state stale when it is older than state_stale_after_s(period_s), and a fault of
// StateFault::FatalSignal / StateFault::Terminate says the daemon died (the segment is left for the readers to see).
#pragma once

#include <atomic>
#include <cstddef>
#include <cstdint>

namespace hapticd {

// Why the loop stopped rendering: StateLayout::fault, the daemon's run result and the `fault` of the protocol's
// state and status messages. The numbers are part of the protocol (docs/protocol.md, section 6).
enum class StateFault : std::uint32_t {
    None = 0,
    Device = 1,       // the device reported an error
    NonFinite = 2,    // non-finite position or force
    Watchdog = 3,     // too many consecutive overruns, or a stall
    FatalSignal = 4,  // SIGSEGV, SIGBUS, SIGFPE, SIGILL or SIGABRT ended the daemon
    Terminate = 5,    // std::terminate ended the daemon
};

// The protocol's name of a fault: "none", "device", "non_finite", "watchdog", "fatal_signal", "terminate";
// "unknown" for a number beyond them.
constexpr const char* to_string(StateFault fault) noexcept {
    switch (fault) {
        case StateFault::None:
            return "none";
        case StateFault::Device:
            return "device";
        case StateFault::NonFinite:
            return "non_finite";
        case StateFault::Watchdog:
            return "watchdog";
        case StateFault::FatalSignal:
            return "fatal_signal";
        case StateFault::Terminate:
            return "terminate";
    }
    return "unknown";
}

// A number of StateLayout::fault is one of StateFault's.
constexpr bool is_state_fault(std::uint32_t number) noexcept {
    return number <= static_cast<std::uint32_t>(StateFault::Terminate);
}

// How old the heartbeat may be before a reader calls the state stale: 10 periods, at least 50 ms. A live
// loop has published 10 times by then; a loop that has not published for 50 ms has stopped rendering for
// 50 ticks at 1 kHz (the handle is not held), and 50 ms is 5 frames of a 100 Hz display.
inline constexpr double state_stale_after_s(double period_s) noexcept {
    return 10.0 * period_s > 0.05 ? 10.0 * period_s : 0.05;
}

inline constexpr std::uint32_t kStateMagic = 0x54535048U;  // "HPST" in little-endian bytes
inline constexpr std::uint32_t kStateLayoutVersion = 2;
inline constexpr std::size_t kStateObjectCapacity = 64;
// Mesh proxies the state holds each tick: those of the first 7 slots, in slot order, whose object is a mesh.
inline constexpr std::size_t kStateMeshProxyCapacity = 7;

// StateMeshProxy::flags.
inline constexpr std::uint8_t kMeshProxySliding = 1U;      // friction: the proxy slid in the last step
inline constexpr std::uint8_t kMeshProxyUnconverged = 2U;  // the last step ran out of sweeps or planes (it goes on)

// One mesh object's god-object proxy as the loop rendered it this tick (src/mesh/god_object_proxy.hpp,
// docs/mesh-rendering.md), in the device's frame: what CHAI3D's finger proxy (the proxy position and up to three
// collision events, each a triangle and a normal) and OpenHaptics HL (HL_PROXY_POSITION, HL_PROXY_TOUCH_NORMAL,
// HL_PROXY_IS_TOUCHING) show. The force the object renders is K (proxy - handle) - B P v (its ramp's weights).
struct StateMeshProxy {
    double proxy[3];           // m: on or outside the surface (1 um in front of its faces, kSurfaceOffset)
    float normal[3][3];        // unit outward normals of the active constraints (the first `constraints`; 0 beyond)
    std::uint32_t triangle;    // one active face, its index in the client's mesh; 0xFFFFFFFF when free
    std::uint8_t slot;         // the scene slot (0..63)
    std::uint8_t constraints;  // active faces, 0..3; > 0: in contact (the slot's contact_mask bit is set)
    std::uint8_t flags;        // kMeshProxySliding | kMeshProxyUnconverged
    std::uint8_t reserved;     // 0
    std::uint32_t object_id;   // the mesh object: the slot's, or a mesh fading out of the slot
};
static_assert(sizeof(StateMeshProxy) == 72 && offsetof(StateMeshProxy, normal) == 24 &&
              offsetof(StateMeshProxy, triangle) == 60 && offsetof(StateMeshProxy, slot) == 64 &&
              offsetof(StateMeshProxy, constraints) == 65 && offsetof(StateMeshProxy, flags) == 66 &&
              offsetof(StateMeshProxy, object_id) == 68);

struct StateLayout {
    // Header, written once before the loop starts.
    std::uint32_t magic;
    std::uint32_t layout_version;
    std::uint32_t size;
    std::uint32_t axes;
    double period_s;
    std::uint32_t capacity;
    std::uint32_t header_padding;
    std::int32_t writer_pid;            // the daemon's process id
    std::uint32_t mesh_proxy_capacity;  // kStateMeshProxyCapacity; 0: the writer publishes no mesh proxies
    std::uint8_t header_reserved[24];
    // Seqlock sequence: odd while the loop writes the fields below.
    alignas(64) std::atomic<std::uint64_t> sequence;
    std::uint8_t sequence_padding[56];
    // Fields, written every tick.
    alignas(64) std::uint64_t tick;
    double time_s;
    double position[3];
    double velocity[3];
    double force[3];
    std::uint64_t contact_mask;
    std::uint64_t overruns;
    std::int64_t wake_latency_ns;
    std::uint64_t last_commit_seq;  // every batch up to this commit_seq is applied
    std::uint32_t fault;            // a StateFault
    std::uint32_t objects;          // occupied slots
    std::uint32_t slot_object_id[kStateObjectCapacity];
    std::uint8_t slot_ramp[kStateObjectCapacity];  // ramp factor x 255
    // Outside the seqlock (one atomic word each).
    std::atomic<std::int64_t> heartbeat_ns;   // CLOCK_MONOTONIC of the writer's last tick, ns; 0: none yet
    std::atomic<std::uint32_t> fatal_signal;  // the signal that ended the daemon (fault 4 or 5), else 0
    std::uint32_t liveness_padding;
    // Under the seqlock, written every tick: the daemon's config walls in contact, bit i for the wall with
    // object id i + 1 (as `list` numbers them; the first 64), set while the handle is behind its surface.
    std::uint64_t config_contact_mask;
    // Under the seqlock, written every tick: the mesh objects' proxies. mesh_slot_mask: bit s set when slot s is
    // occupied and renders a mesh (its object, or the mesh fading out of it while another kind ramps in); the first
    // kStateMeshProxyCapacity of them in slot order have their proxy in mesh_proxy[0 .. mesh_proxies - 1] (the
    // entries beyond are zero). popcount(mesh_slot_mask) > mesh_proxies: the meshes beyond the limit are not shown.
    std::uint64_t mesh_slot_mask;
    std::uint32_t mesh_proxies;  // entries written, 0 .. kStateMeshProxyCapacity
    std::uint32_t mesh_padding;
    StateMeshProxy mesh_proxy[kStateMeshProxyCapacity];
    std::uint8_t reserved[32];
};

static_assert(std::atomic<std::uint64_t>::is_always_lock_free, "the seqlock needs a lock-free 64-bit atomic");
static_assert(offsetof(StateLayout, period_s) == 16);
static_assert(offsetof(StateLayout, capacity) == 24);
static_assert(offsetof(StateLayout, sequence) == 64);
static_assert(offsetof(StateLayout, tick) == 128);
static_assert(offsetof(StateLayout, time_s) == 136);
static_assert(offsetof(StateLayout, position) == 144);
static_assert(offsetof(StateLayout, velocity) == 168);
static_assert(offsetof(StateLayout, force) == 192);
static_assert(offsetof(StateLayout, contact_mask) == 216);
static_assert(offsetof(StateLayout, overruns) == 224);
static_assert(offsetof(StateLayout, wake_latency_ns) == 232);
static_assert(offsetof(StateLayout, last_commit_seq) == 240);
static_assert(offsetof(StateLayout, fault) == 248);
static_assert(offsetof(StateLayout, objects) == 252);
static_assert(offsetof(StateLayout, slot_object_id) == 256);
static_assert(offsetof(StateLayout, slot_ramp) == 512);
static_assert(offsetof(StateLayout, writer_pid) == 32);
static_assert(offsetof(StateLayout, heartbeat_ns) == 576);
static_assert(offsetof(StateLayout, fatal_signal) == 584);
static_assert(offsetof(StateLayout, config_contact_mask) == 592);
static_assert(offsetof(StateLayout, mesh_proxy_capacity) == 36);
static_assert(offsetof(StateLayout, mesh_slot_mask) == 600);
static_assert(offsetof(StateLayout, mesh_proxies) == 608);
static_assert(offsetof(StateLayout, mesh_proxy) == 616);
static_assert(offsetof(StateLayout, reserved) == 1120);
static_assert(std::atomic<std::int64_t>::is_always_lock_free && std::atomic<std::uint32_t>::is_always_lock_free,
              "the liveness words are written from a signal handler");
static_assert(sizeof(StateLayout) == 1152);

}  // namespace hapticd
