// SPDX-License-Identifier: Apache-2.0
// libFuzzer target: the recording reader (src/daemon/recording_reader.*, docs/recording.md) on arbitrary bytes.
// The end chunk's checksum is resealed first when the bytes have the shape of a recording (16 bytes, a header size
// within them, whole chunks after it), so that mutations reach the chunk parser instead of stopping at the
// checksum. Invariants: no crash, no exception but RecordingError (whose message names the file); an accepted
// recording has ticks 0, 1, 2, ... matching the end record's counts, and every update of a mesh object that names
// a mesh points to that mesh's hierarchy, whose mesh is within the protocol's limits.
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <string>
#include <vector>

#include "daemon/recording_reader.hpp"

namespace {

void check(bool ok) {
    if (!ok) std::abort();
}

void reseal(std::vector<char>& bytes) {
    using namespace hapticd::recording;
    if (bytes.size() < 16 + kChunkSize) return;
    std::uint32_t h = 0;
    std::memcpy(&h, bytes.data() + 12, 4);
    if (h < kChunkSize || h % kChunkSize != 0 || h + kChunkSize > bytes.size() || (bytes.size() - h) % kChunkSize != 0)
        return;
    const std::size_t end_at = bytes.size() - kChunkSize;
    const std::uint64_t sum = fnv1a64(bytes.data() + h, end_at - h);
    std::memcpy(bytes.data() + end_at + offsetof(EndChunk, checksum), &sum, sizeof sum);
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    std::vector<char> bytes(reinterpret_cast<const char*>(data), reinterpret_cast<const char*>(data) + size);
    reseal(bytes);
    try {
        const hapticd::Recording r = hapticd::parse_recording("fuzz.rec", bytes);
        check(!r.ticks.empty() && r.ticks.size() == r.end.ticks && r.batches.size() == r.end.batches);
        check(r.meshes.size() == r.end.meshes);
        for (std::size_t i = 0; i < r.ticks.size(); ++i) check(r.ticks[i].tick == i);
        for (const auto& [id, h] : r.meshes) {
            check(id != 0 && h != nullptr && h->mesh().vertices.size() <= 200000 &&
                  h->mesh().triangles.size() <= 200000);
        }
        for (const auto& b : r.batches) {
            for (const auto& u : b.updates) {
                if (u.params.mesh == nullptr) continue;
                const auto found = r.meshes.find(u.params.mesh_id);
                check(found != r.meshes.end() && found->second.get() == u.params.mesh);
            }
        }
    } catch (const hapticd::RecordingError& e) {
        check(std::string(e.what()).rfind("recording 'fuzz.rec': ", 0) == 0);
    }
    return 0;
}
