// SPDX-License-Identifier: Apache-2.0
// The shared-memory state of hapticd (docs/protocol.md, section 6): one struct written once per tick by
// the loop under a seqlock, read by any process without a system call. Layout version 1; the offsets are
// part of the protocol and checked by static_asserts below.
#pragma once

#include <atomic>
#include <cstddef>
#include <cstdint>

namespace hapticd {

inline constexpr std::uint32_t kStateMagic = 0x54535048U;  // "HPST" in little-endian bytes
inline constexpr std::uint32_t kStateLayoutVersion = 1;
inline constexpr std::size_t kStateObjectCapacity = 64;

struct StateLayout {
    // Header, written once before the loop starts.
    std::uint32_t magic;
    std::uint32_t layout_version;
    std::uint32_t size;
    std::uint32_t axes;
    double period_s;
    std::uint32_t capacity;
    std::uint32_t header_padding;
    std::uint8_t header_reserved[32];
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
    std::uint32_t fault;    // 0 none, 1 device, 2 non-finite, 3 watchdog
    std::uint32_t objects;  // occupied slots
    std::uint32_t slot_object_id[kStateObjectCapacity];
    std::uint8_t slot_ramp[kStateObjectCapacity];  // ramp factor x 255
    std::uint8_t reserved[576];
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
static_assert(sizeof(StateLayout) == 1152);

}  // namespace hapticd
