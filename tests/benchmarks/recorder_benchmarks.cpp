// SPDX-License-Identifier: Apache-2.0
// The real-time side of --record (daemon/recorder.hpp), in real-time mode (non-blocking), its writer thread
// writing to a file in the temporary directory meanwhile:
//  * BM_RecorderPushTick: one tick chunk (128 bytes) into the tick ring, what every recorded tick adds.
//  * BM_RecorderTakeBatch: begin_tick, then one batch of one update taken (on_taken: the copy of its one
//    update into the batch ring), then its tick chunk: a tick in which a client's move is applied.
//  * BM_RecorderWriteMesh: the writer thread's mesh record of a 100 000-triangle solid (the 400 x 125 torus of
//    scripts/measure-mesh-upload.py: 50 000 vertices), from on_mesh (the server thread's part: a set insert and a
//    queue push under the lock) until the writer counts it written: 20 001 chunks, 2 560 128 bytes, hashed and
//    written. Includes the writer's idle poll (up to 2 ms). Not on the loop thread.
// Fewer iterations than the rings hold (50000 of 65536 ticks; 250 of 256 batches): the figures are those of the
// push that succeeds, the path of a complete recording, not of the drop. Counter dropped: records a full ring
// refused (0 expected; a non-zero count says the figure is not that of the successful push).
#include <benchmark/benchmark.h>

#include <chrono>
#include <filesystem>
#include <string>
#include <thread>

#include "daemon/recorder.hpp"
#include "mesh/procedural_meshes.hpp"

namespace {

using namespace hapticd;

std::string scratch_file(const char* name) { return (std::filesystem::temp_directory_path() / name).string(); }

void BM_RecorderPushTick(benchmark::State& state) {
    Recorder recorder(scratch_file("hapticd_bench_push_tick.rec"), "{}", 1U << 16U, false);
    recording::TickChunk chunk;
    std::uint64_t tick = 0;
    for (auto _ : state) {
        recorder.begin_tick(tick);
        chunk.tick = tick++;
        recorder.push_tick(chunk);
        benchmark::ClobberMemory();
    }
    recorder.close();
    state.counters["dropped"] = static_cast<double>(recorder.dropped_ticks());
    state.counters["written"] = static_cast<double>(recorder.ticks_written());
    std::filesystem::remove(recorder.path());
}
BENCHMARK(BM_RecorderPushTick)->Iterations(50000);

void BM_RecorderTakeBatch(benchmark::State& state) {
    Recorder recorder(scratch_file("hapticd_bench_take_batch.rec"), "{}", 1U << 16U, false);
    ObjectCommit commit;
    commit.count = 1;
    commit.updates[0].action = SlotUpdate::Action::Move;
    commit.updates[0].params.offset = 0.001;
    recording::TickChunk chunk;
    std::uint64_t tick = 0;
    for (auto _ : state) {
        recorder.begin_tick(tick);
        commit.seq = tick;
        recorder.on_taken(commit, CommitSource::Ring);
        chunk.tick = tick++;
        recorder.push_tick(chunk);
        benchmark::ClobberMemory();
    }
    recorder.close();
    state.counters["dropped"] = static_cast<double>(recorder.dropped_ticks() + recorder.dropped_batches());
    state.counters["written"] = static_cast<double>(recorder.ticks_written() + recorder.batches_written());
    std::filesystem::remove(recorder.path());
}
BENCHMARK(BM_RecorderTakeBatch)->Iterations(250);

void BM_RecorderWriteMesh(benchmark::State& state) {
    const auto hierarchy = mesh::MeshHierarchy::build(mesh::torus(0.03, 0.01, 400, 125), mesh::MeshMode::solid);
    std::uint32_t id = 0;
    for (auto _ : state) {
        Recorder recorder(scratch_file("hapticd_bench_write_mesh.rec"), "{}", 1024, false);
        const auto start = std::chrono::steady_clock::now();
        recorder.on_mesh(++id, hierarchy);
        while (recorder.meshes_written() == 0) std::this_thread::yield();
        state.SetIterationTime(std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count());
        recorder.close();
        std::filesystem::remove(recorder.path());
    }
    state.counters["triangles"] = static_cast<double>(hierarchy->mesh().triangles.size());
}
BENCHMARK(BM_RecorderWriteMesh)->UseManualTime()->Unit(benchmark::kMillisecond)->Iterations(20);

}  // namespace
