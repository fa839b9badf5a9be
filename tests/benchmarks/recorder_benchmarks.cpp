// SPDX-License-Identifier: Apache-2.0
// The real-time side of --record (daemon/recorder.hpp), in real-time mode (non-blocking), its writer thread
// writing to a file in the temporary directory meanwhile:
//  * BM_RecorderPushTick: one tick chunk (128 bytes) into the tick ring, what every recorded tick adds.
//  * BM_RecorderTakeBatch: begin_tick, then one batch of one update taken (on_taken: the copy of its one
//    update into the batch ring), then its tick chunk: a tick in which a client's move is applied.
// Fewer iterations than the rings hold (50000 of 65536 ticks; 250 of 256 batches): the figures are those of the
// push that succeeds, the path of a complete recording, not of the drop. Counter dropped: records a full ring
// refused (0 expected; a non-zero count says the figure is not that of the successful push).
#include <benchmark/benchmark.h>

#include <filesystem>
#include <string>

#include "daemon/recorder.hpp"

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

}  // namespace
