// SPDX-License-Identifier: Apache-2.0
// --record and --replay (docs/recording.md). The force of a tick is a function of the positions read so far,
// the configuration (options, device profile, config file) and which batches the loop took from its rings at
// which tick; the recording holds the first and the last per tick and, in its header, what rebuilds the
// second: the command line, the working directory, and the paths and FNV-1a 64 hashes of the files read. The
// replay parses the recorded command line again, refuses when a file's hash differs, and runs the loop in
// lockstep on a PlaybackDevice (the recorded positions and device statuses, tick by tick) with a ReplayFeeder
// that hands the loop each recorded batch just before the apply_commits that took it. It compares every
// force written with the recorded one bit for bit.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "config/options.hpp"
#include "daemon/daemon.hpp"
#include "devices/device.hpp"
#include "daemon/recording_reader.hpp"
#include "scene/scene_objects.hpp"

namespace hapticd {

// FNV-1a 64 of a file's bytes as 16 hex digits; "" when it cannot be read.
[[nodiscard]] std::string file_fnv1a64(const std::string& path);

// The header's JSON object: format, version, chunk size, record layout (numpy-style: name, type, offset,
// count per field of each chunk kind), the hapticd version, argv (without argv[0]), cwd, the files with their
// hashes, axes, rate, lockstep, serve.
[[nodiscard]] nlohmann::json recording_header(int argc, const char* const* argv, const Options& options,
                                              const DeviceProfile& profile);

// Throws StartupError(ErrorKind::BadRecording) when the files the recording was made with differ from those this
// replay read (path or hash), or the recording cannot be rebuilt (--identify).
void check_replayable(const Recording& recording, const Options& options, const DeviceProfile& profile);

// The device of a replay: position and read status of tick i from the recording; write_force compares the
// force with the recorded one bit for bit (each axis's 64 bits) and returns the recorded write status.
class PlaybackDevice final : public Device {
  public:
    PlaybackDevice(const Recording& recording, const DeviceCapabilities& capabilities, std::string name);

    DeviceStatus open() override { return DeviceStatus::Ok; }
    DeviceStatus home() override { return DeviceStatus::Ok; }
    void close() noexcept override {}
    DeviceStatus read_position(AxisVector& position) noexcept override;
    DeviceStatus write_force(const AxisVector& force) noexcept override;
    [[nodiscard]] const DeviceCapabilities& capabilities() const noexcept override { return capabilities_; }
    [[nodiscard]] std::string_view name() const noexcept override { return name_; }
    [[nodiscard]] std::string last_error() const override { return "the recorded device status"; }

    struct Mismatch {
        std::uint64_t tick = 0;
        std::size_t axis = 0;
        double recorded = 0.0;
        double replayed = 0.0;
    };
    [[nodiscard]] std::uint64_t ticks_compared() const noexcept { return compared_; }
    [[nodiscard]] std::uint64_t mismatched_ticks() const noexcept { return mismatches_; }
    [[nodiscard]] const Mismatch& first_mismatch() const noexcept { return first_; }

  private:
    const Recording& recording_;
    DeviceCapabilities capabilities_;
    std::string name_;
    std::size_t next_ = 0;  // the tick read_position serves next
    std::uint64_t compared_ = 0;
    std::uint64_t mismatches_ = 0;
    Mismatch first_;
};

// Hands the loop the recorded batches (TickFeeder) and checks, as the loop takes them (CommitObserver), that
// it takes each at its recorded tick, from its recorded ring, in its recorded order. Within a tick a departure
// that the loop took after batches of the commit ring (the server pushed it while apply_commits ran) is
// reproduced by an apply_commits call for the batches before it; that call starts with a fresh
// commits_per_tick budget (docs/recording.md, "Limits").
class ReplayFeeder final : public TickFeeder, public CommitObserver {
  public:
    ReplayFeeder(const Recording& recording, SceneObjects& objects, CommitRing& ring, CommitRing& departures);

    void before_commits(std::uint64_t tick) noexcept override;
    void on_taken(const ObjectCommit& commit, CommitSource source) noexcept override;

    [[nodiscard]] std::uint64_t batches_taken() const noexcept { return taken_; }
    [[nodiscard]] bool mismatch() const noexcept { return mismatch_; }
    // The first batch taken otherwise than recorded (empty when none).
    [[nodiscard]] std::string mismatch_text() const;

  private:
    void push(CommitRing& ring, const RecordedBatch& b) noexcept;

    const Recording& recording_;
    SceneObjects& objects_;
    CommitRing& ring_;
    CommitRing& departures_;
    std::size_t next_push_ = 0;  // the next recorded batch to hand over
    std::size_t taken_ = 0;      // batches the loop took so far
    std::uint64_t tick_ = 0;
    bool mismatch_ = false;
    bool push_failed_ = false;
    std::uint64_t mismatch_tick_ = 0;
    std::uint64_t mismatch_seq_ = 0;
    CommitSource mismatch_source_ = CommitSource::Ring;
    std::size_t mismatch_index_ = 0;
    ObjectCommit scratch_;
};

// The smallest ring capacity that holds every batch of the recording's busiest tick.
[[nodiscard]] std::size_t replay_ring_capacity(const Recording& recording);

}  // namespace hapticd
