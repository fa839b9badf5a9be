// SPDX-License-Identifier: Apache-2.0
// Reads and checks a recording (daemon/recording_format.hpp, docs/recording.md) for --replay. Every defect is a
// RecordingError whose message names the file and what is wrong: unreadable, too short, wrong magic, unknown
// version, a header that is not a JSON object, a size that is not header + whole chunks (truncated), no end
// chunk (cut off), an unknown chunk kind, a batch without its updates, ticks out of order, counts or the
// checksum not those of the end chunk (corrupt), or an incomplete recording (records dropped); in version 2 a
// mesh record that is cut off, counts beyond the protocol's limits, holds what mesh_error refuses (a non-finite
// coordinate, an index out of range, ...) or repeats an id, and an update naming a mesh no record before it holds.
// Each mesh record is validated with mesh::mesh_error and built with mesh::MeshHierarchy::build, as the server's
// mesh worker does (server/mesh_store.cpp), so the replay renders the same hierarchy.
#pragma once

#include <cstdint>
#include <map>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "daemon/recording_format.hpp"
#include "mesh/mesh_hierarchy.hpp"
#include "scene/scene_objects.hpp"

namespace hapticd {

class RecordingError : public std::runtime_error {
  public:
    using std::runtime_error::runtime_error;
};

struct RecordedBatch {
    std::uint64_t tick = 0;
    std::uint32_t index = 0;
    CommitSource source = CommitSource::Ring;
    std::uint64_t seq = 0;
    std::vector<SlotUpdate> updates;
};

struct Recording {
    std::string path;
    std::uint32_t version = 0;
    nlohmann::json header;                    // the header's JSON object
    std::vector<recording::TickChunk> ticks;  // in order, tick numbers 0, 1, 2, ...
    std::vector<RecordedBatch> batches;       // in the order the loop took them
    // The mesh records (version 2), by id: the updates' ObjectParams::mesh point into these.
    std::map<std::uint32_t, std::shared_ptr<const mesh::MeshHierarchy>> meshes;
    recording::EndChunk end;
};

// Throws RecordingError (message: "recording '<path>': <what is wrong>").
[[nodiscard]] Recording read_recording(const std::string& path);
// The same checks on a file's bytes already read (`path` names it in the messages; tests/fuzz/fuzz_recording.cpp).
[[nodiscard]] Recording parse_recording(const std::string& path, const std::vector<char>& bytes);

}  // namespace hapticd
