// SPDX-License-Identifier: Apache-2.0
#include "daemon/record_replay.hpp"

#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>

#include <hapticopt/version.hpp>

#include "daemon/exit_codes.hpp"
#include "daemon/recording_format.hpp"

namespace hapticd {

namespace {

using nlohmann::json;

json field(const char* name, const char* type, std::size_t offset, std::size_t count = 1) {
    return json::array({name, type, offset, count});
}

// The chunks' fields as numpy reads them (type: numpy's little-endian type codes), from the offsets the
// static_asserts of daemon/recording_format.hpp pin.
json layout() {
    using namespace recording;
    json l;
    l["tick"] = json::array(
        {field("kind", "<u4", offsetof(TickChunk, kind)), field("read_status", "u1", offsetof(TickChunk, read_status)),
         field("write_status", "u1", offsetof(TickChunk, write_status)),
         field("fault", "u1", offsetof(TickChunk, fault)), field("gain_row", "u1", offsetof(TickChunk, gain_row)),
         field("tick", "<u8", offsetof(TickChunk, tick)), field("time_s", "<f8", offsetof(TickChunk, time_s)),
         field("position", "<f8", offsetof(TickChunk, position), 3),
         field("velocity", "<f8", offsetof(TickChunk, velocity), 3),
         field("force", "<f8", offsetof(TickChunk, force), 3),
         field("contact_mask", "<u8", offsetof(TickChunk, contact_mask)),
         field("config_contact_mask", "<u8", offsetof(TickChunk, config_contact_mask)),
         field("wake_latency_ns", "<i8", offsetof(TickChunk, wake_latency_ns)),
         field("batches", "<u4", offsetof(TickChunk, batches))});
    l["batch"] = json::array(
        {field("kind", "<u4", offsetof(BatchChunk, kind)), field("source", "u1", offsetof(BatchChunk, source)),
         field("tick", "<u8", offsetof(BatchChunk, tick)), field("seq", "<u8", offsetof(BatchChunk, seq)),
         field("count", "<u4", offsetof(BatchChunk, count)), field("index", "<u4", offsetof(BatchChunk, index))});
    l["update_a"] = json::array(
        {field("kind", "<u4", offsetof(UpdateChunkA, kind)), field("slot", "u1", offsetof(UpdateChunkA, slot)),
         field("action", "u1", offsetof(UpdateChunkA, action)),
         field("object_kind", "u1", offsetof(UpdateChunkA, object_kind)),
         field("bilateral", "u1", offsetof(UpdateChunkA, bilateral)),
         field("constraint", "u1", offsetof(UpdateChunkA, constraint)), field("id", "<u4", offsetof(UpdateChunkA, id)),
         field("direction", "<f8", offsetof(UpdateChunkA, direction), 3),
         field("offset", "<f8", offsetof(UpdateChunkA, offset)),
         field("point", "<f8", offsetof(UpdateChunkA, point), 3),
         field("radius", "<f8", offsetof(UpdateChunkA, radius)),
         field("force", "<f8", offsetof(UpdateChunkA, force), 3), field("K", "<f8", offsetof(UpdateChunkA, K)),
         field("B", "<f8", offsetof(UpdateChunkA, B)),
         field("offset_rate", "<f8", offsetof(UpdateChunkA, offset_rate))});
    l["update_b"] = json::array({field("kind", "<u4", offsetof(UpdateChunkB, kind)),
                                 field("jacobian", "<f8", offsetof(UpdateChunkB, jacobian), 9),
                                 field("point_rate", "<f8", offsetof(UpdateChunkB, point_rate), 3)});
    l["end"] = json::array(
        {field("kind", "<u4", offsetof(EndChunk, kind)), field("complete", "<u4", offsetof(EndChunk, complete)),
         field("ticks", "<u8", offsetof(EndChunk, ticks)), field("batches", "<u8", offsetof(EndChunk, batches)),
         field("updates", "<u8", offsetof(EndChunk, updates)),
         field("dropped_ticks", "<u8", offsetof(EndChunk, dropped_ticks)),
         field("dropped_batches", "<u8", offsetof(EndChunk, dropped_batches)),
         field("checksum", "<u8", offsetof(EndChunk, checksum)), field("meshes", "<u8", offsetof(EndChunk, meshes))});
    l["update_c"] = json::array({field("kind", "<u4", offsetof(UpdateChunkC, kind)),
                                 field("mesh", "<u4", offsetof(UpdateChunkC, mesh)),
                                 field("orientation", "<f8", offsetof(UpdateChunkC, orientation), 4),
                                 field("static_friction", "<f8", offsetof(UpdateChunkC, static_friction)),
                                 field("dynamic_friction", "<f8", offsetof(UpdateChunkC, dynamic_friction)),
                                 field("shading", "<u4", offsetof(UpdateChunkC, shading)),
                                 field("crease_angle_deg", "<f8", offsetof(UpdateChunkC, crease_angle_deg))});
    l["mesh"] = json::array(
        {field("kind", "<u4", offsetof(MeshChunk, kind)), field("mode", "u1", offsetof(MeshChunk, mode)),
         field("mesh", "<u4", offsetof(MeshChunk, mesh)), field("vertices", "<u8", offsetof(MeshChunk, vertices)),
         field("triangles", "<u8", offsetof(MeshChunk, triangles))});
    l["mesh_vertices"] = json::array({field("kind", "<u4", offsetof(MeshVerticesChunk, kind)),
                                      field("count", "<u4", offsetof(MeshVerticesChunk, count)),
                                      field("xyz", "<f8", offsetof(MeshVerticesChunk, xyz), 3 * kVerticesPerChunk)});
    l["mesh_triangles"] =
        json::array({field("kind", "<u4", offsetof(MeshTrianglesChunk, kind)),
                     field("count", "<u4", offsetof(MeshTrianglesChunk, count)),
                     field("indices", "<u4", offsetof(MeshTrianglesChunk, indices), 3 * kTrianglesPerChunk)});
    return l;
}

json file_entry(const std::string& path) {
    if (path.empty()) return nullptr;
    return json{{"path", path}, {"fnv1a64", file_fnv1a64(path)}};
}

[[noreturn]] void refuse(const Recording& r, const std::string& what) {
    throw StartupError(ErrorKind::BadRecording, "recording '" + r.path + "': " + what);
}

void check_file(const Recording& r, const char* key, const char* what, const std::string& path_now) {
    const json& e = r.header.contains(key) ? r.header.at(key) : json(nullptr);
    const std::string recorded =
        e.is_object() && e.contains("path") && e["path"].is_string() ? e["path"].get<std::string>() : "";
    if (recorded != path_now) {
        refuse(r, std::string("it was made with ") + what + " '" + recorded + "', this replay reads '" + path_now +
                      "' (replay in the recording's environment)");
    }
    if (path_now.empty()) return;
    const std::string hash = e.contains("fnv1a64") && e["fnv1a64"].is_string() ? e["fnv1a64"].get<std::string>() : "";
    const std::string now = file_fnv1a64(path_now);
    if (hash != now) {
        refuse(r, std::string("the ") + what + " '" + path_now + "' changed since the recording (FNV-1a 64 " + hash +
                      ", now " + (now.empty() ? std::string("unreadable") : now) +
                      "): the replay would not render the same scene");
    }
}

}  // namespace

std::string file_fnv1a64(const std::string& path) {
    std::ifstream in(path, std::ios::binary);
    if (!in) return "";
    const std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    char text[17];
    std::snprintf(text, sizeof text, "%016llx",
                  static_cast<unsigned long long>(recording::fnv1a64(bytes.data(), bytes.size())));
    return text;
}

json recording_header(int argc, const char* const* argv, const Options& o, const DeviceProfile& profile) {
    json h;
    h["format"] = "hapticd-recording";
    h["version"] = recording::kFormatVersion;
    h["chunk_size"] = recording::kChunkSize;
    h["layout"] = layout();
    h["hapticd_version"] = HAPTICOPT_VERSION_STRING;
    json args = json::array();
    for (int i = 1; i < argc; ++i) args.push_back(argv[i]);
    h["argv"] = args;
    std::error_code ec;
    h["cwd"] = std::filesystem::current_path(ec).string();
    h["config_file"] = file_entry(o.config_path);
    h["device_profile"] = file_entry(profile.path);
    h["identification_file"] = file_entry(o.identification_file);
    h["axes"] = profile.axes;
    h["rate_hz"] = o.rate;
    h["lockstep"] = o.lockstep;
    h["serve"] = o.serve;
    return h;
}

void check_replayable(const Recording& r, const Options& o, const DeviceProfile& profile) {
    if (o.identify) {
        refuse(r,
               "it was made with --identify, whose tuning comes from measuring the device at start-up; replay cannot "
               "rebuild "
               "it (record with --identification-file instead)");
    }
    check_file(r, "config_file", "config file", o.config_path);
    check_file(r, "device_profile", "device profile", profile.path);
    check_file(r, "identification_file", "identification file", o.identification_file);
    const auto axes = r.header.value("axes", -1LL);
    if (axes != profile.axes)
        refuse(r,
               "the header's axes (" + std::to_string(axes) + ") is not the profile's " + std::to_string(profile.axes));
}

PlaybackDevice::PlaybackDevice(const Recording& recording, const DeviceCapabilities& capabilities, std::string name)
    : recording_(recording), capabilities_(capabilities), name_(std::move(name)) {}

DeviceStatus PlaybackDevice::read_position(AxisVector& position) noexcept {
    if (next_ >= recording_.ticks.size()) return DeviceStatus::Disconnected;
    const recording::TickChunk& t = recording_.ticks[next_];
    for (std::size_t a = 0; a < kMaxAxes; ++a) position[a] = t.position[a];
    return static_cast<DeviceStatus>(t.read_status);
}

DeviceStatus PlaybackDevice::write_force(const AxisVector& force) noexcept {
    if (next_ >= recording_.ticks.size()) return DeviceStatus::Disconnected;
    const recording::TickChunk& t = recording_.ticks[next_];
    bool differs = false;
    for (std::size_t a = 0; a < kMaxAxes; ++a) {
        if (std::memcmp(&force[a], &t.force[a], sizeof(double)) != 0) {
            if (!differs && mismatches_ == 0) first_ = Mismatch{t.tick, a, t.force[a], force[a]};
            differs = true;
        }
    }
    if (differs) ++mismatches_;
    ++compared_;
    ++next_;
    return static_cast<DeviceStatus>(t.write_status);
}

ReplayFeeder::ReplayFeeder(const Recording& recording, SceneObjects& objects, CommitRing& ring, CommitRing& departures)
    : recording_(recording), objects_(objects), ring_(ring), departures_(departures) {}

void ReplayFeeder::push(CommitRing& ring, const RecordedBatch& b) noexcept {
    scratch_.seq = b.seq;
    scratch_.count = static_cast<std::uint32_t>(b.updates.size());
    for (std::size_t i = 0; i < b.updates.size() && i < kSceneObjectCapacity; ++i) scratch_.updates[i] = b.updates[i];
    if (!ring.try_push(scratch_)) push_failed_ = true;  // the rings hold a tick's batches (replay_ring_capacity)
}

void ReplayFeeder::before_commits(std::uint64_t tick) noexcept {
    tick_ = tick;
    bool ring_batches_waiting = false;
    for (; next_push_ < recording_.batches.size() && recording_.batches[next_push_].tick == tick; ++next_push_) {
        const RecordedBatch& b = recording_.batches[next_push_];
        if (b.source == CommitSource::Ring) {
            push(ring_, b);
            ring_batches_waiting = true;
            continue;
        }
        // A departure (with the batches jumped ahead of it) taken after ring batches of the same tick: the loop
        // took those first, so they go through an apply_commits of their own.
        if (ring_batches_waiting) {
            objects_.apply_commits();
            ring_batches_waiting = false;
        }
        push(b.source == CommitSource::Departure ? departures_ : ring_, b);
    }
}

void ReplayFeeder::on_taken(const ObjectCommit& commit, CommitSource source) noexcept {
    const std::size_t i = taken_++;
    if (mismatch_) return;
    const bool expected = i < recording_.batches.size() && recording_.batches[i].tick == tick_ &&
                          recording_.batches[i].source == source && recording_.batches[i].seq == commit.seq;
    if (!expected || push_failed_) {
        mismatch_ = true;
        mismatch_tick_ = tick_;
        mismatch_seq_ = commit.seq;
        mismatch_source_ = source;
        mismatch_index_ = i;
    }
}

std::string ReplayFeeder::mismatch_text() const {
    if (!mismatch_) return "";
    static constexpr const char* kSource[] = {"the commit ring", "the departures ring",
                                              "the commit ring (jumped ahead of a departure)"};
    std::string s = "batch " + std::to_string(mismatch_index_) + " (seq " + std::to_string(mismatch_seq_) + ", from " +
                    kSource[static_cast<int>(mismatch_source_)] + ") was taken at tick " +
                    std::to_string(mismatch_tick_);
    if (push_failed_) return s + "; a replay ring was full";
    if (mismatch_index_ >= recording_.batches.size())
        return s + "; the recording has only " + std::to_string(recording_.batches.size()) + " batches";
    const RecordedBatch& b = recording_.batches[mismatch_index_];
    return s + "; recorded: seq " + std::to_string(b.seq) + " from " + kSource[static_cast<int>(b.source)] +
           " at tick " + std::to_string(b.tick);
}

std::size_t replay_ring_capacity(const Recording& recording) {
    std::size_t most = 0, run = 0;
    for (std::size_t i = 0; i < recording.batches.size(); ++i) {
        run = i > 0 && recording.batches[i].tick == recording.batches[i - 1].tick ? run + 1 : 1;
        most = std::max(most, run);
    }
    return most + 2;
}

}  // namespace hapticd
