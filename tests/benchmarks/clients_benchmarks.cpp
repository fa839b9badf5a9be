// Benchmarks of the client interface (docs/clients.md, "Measured"), each beside its baseline in the same run:
//  * BM_CommandToForceLatency: a real `hapticd --serve` at 1 kHz (SCHED_FIFO when permitted) and a client
//    that moves a plane it presses on (modify of the offset only) and then spins on the shared-memory state
//    until the tick that applied the batch is published (last_commit_seq >= the commit's seq). Per commit:
//    from before the request is sent to that tick being visible; p50/p99/max over HAPTICD_LATENCY_COMMITS
//    commits (default 10000), the commit's own reply round trip, and (1000 x) that of a status request,
//    which the server answers without the commit's checks. Baseline in the same run: a bare
//    SOCK_SEQPACKET ping-pong (socketpair + echo thread) with a message of the commit's size.
//    Goal of issue 14: within one loop period plus the ping-pong time.
//  * BM_TickOneWall / BM_Tick64Objects / BM_TickRatio64VsOneWall: the loop's compute for one tick without
//    sleeping: today's tick (simulated plant, one wall, delay ring; as daemon_tick.cpp) against the same
//    tick plus 64 client objects (64 bilateral planes, all in contact so none is skipped: the worst case)
//    with their ramps, saturation, the force-rate limit and the state publication. The ratio benchmark
//    alternates blocks of 1000 ticks of each so that both see the same machine load. Goal: <= 2x.
//    BM_TickObjects/N: the same tick with N = 0, 1, 8, 64 objects (the fixed cost and the cost per object).
//  * BM_StateRead*: StateReader::read (the C++ client's seqlock read of one tick) with no writer, with a
//    writer at 1 kHz (the loop), and with a writer rewriting back to back (lockstep; reads then retry).
//    Goal: <= 200 ns.
#include <benchmark/benchmark.h>

#include <fcntl.h>
#include <signal.h>
#include <spawn.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <string>
#include <thread>
#include <vector>

#include "devices/sim_device.hpp"
#include "hapticd/client.hpp"
#include "loop/realtime_loop.hpp"
#include "loop/realtime_setup.hpp"
#include "loop/stats.hpp"
#include "scene/delay_ring.hpp"
#include "scene/scene.hpp"
#include "scene/scene_objects.hpp"
#include "server/state_publisher.hpp"

extern char** environ;

namespace {

using namespace hapticd;
namespace hc = hapticd::client;

void report(benchmark::State& state, const std::string& prefix, const LatencyStats& s) {
    state.counters[prefix + "_p50_us"] = static_cast<double>(s.percentile_ns(0.50)) * 1e-3;
    state.counters[prefix + "_p99_us"] = static_cast<double>(s.percentile_ns(0.99)) * 1e-3;
    state.counters[prefix + "_max_us"] = static_cast<double>(s.max_ns()) * 1e-3;
    state.counters[prefix + "_mean_us"] = s.mean_ns() * 1e-3;
}

// ---------------------------------------------------------------------------------------------------------
// Command-to-force latency against a real daemon.

class DaemonProcess {
public:
    DaemonProcess(const std::string& socket, const std::string& shm) {
        std::vector<std::string> args{HAPTICD_BINARY, "--config", "", "--serve", "--serve-socket", socket, "--serve-shm", shm,
                                      "--wall", "axis=0 position=0.05 direction=+1", "--stiffness", "100", "--damping", "1",
                                      "--scenario", "hold", "--hold-distance", "0.06", "--hold-force", "2",
                                      "--watchdog-overruns", "1000000", "--watchdog-stall-periods", "1000000", "--quiet"};
        std::vector<char*> argv;
        for (auto& a : args) argv.push_back(a.data());
        argv.push_back(nullptr);
        posix_spawn_file_actions_t fa;
        posix_spawn_file_actions_init(&fa);
        posix_spawn_file_actions_addopen(&fa, 1, "/dev/null", O_WRONLY, 0);
        if (posix_spawn(&pid_, HAPTICD_BINARY, &fa, nullptr, argv.data(), environ) != 0) pid_ = -1;
        posix_spawn_file_actions_destroy(&fa);
        const auto end = std::chrono::steady_clock::now() + std::chrono::seconds(20);
        while (pid_ > 0 && std::chrono::steady_clock::now() < end) {  // until a connect succeeds (bind precedes listen)
            try {
                hc::ConnectOptions co;
                co.socket_path = socket;
                hc::Client::connect(co).bye();
                break;
            } catch (const hc::Error&) {
                std::this_thread::sleep_for(std::chrono::milliseconds(5));
            }
        }
    }
    ~DaemonProcess() {
        if (pid_ > 0) {
            ::kill(pid_, SIGTERM);
            int st = 0;
            ::waitpid(pid_, &st, 0);
        }
    }
    [[nodiscard]] bool started() const { return pid_ > 0; }

private:
    pid_t pid_ = -1;
};

std::size_t commits_from_env() {
    const char* s = std::getenv("HAPTICD_LATENCY_COMMITS");
    const long n = s != nullptr ? std::atol(s) : 10000;
    return n > 0 ? static_cast<std::size_t>(n) : 10000;
}

void BM_CommandToForceLatency(benchmark::State& state) {
    const std::size_t commits = commits_from_env();
    const auto dir = std::filesystem::temp_directory_path() / ("hapticd_bench_" + std::to_string(::getpid()));
    std::filesystem::create_directories(dir);
    const std::string socket = (dir / "bench.sock").string();
    const std::string shm = "/hapticd-bench-" + std::to_string(::getpid());
    const RealtimeReport rt = apply_realtime({70, true, -1});  // the client below the loop's priority 80
    for (auto _ : state) {
        // Baseline: bare SOCK_SEQPACKET ping-pong of a message the size of one commit.
        LatencyStats pingpong;
        {
            int sv[2];
            if (::socketpair(AF_UNIX, SOCK_SEQPACKET, 0, sv) != 0) {
                state.SkipWithError("socketpair failed");
                return;
            }
            std::thread echo([fd = sv[1]] {
                char buf[70000];
                for (;;) {
                    const ssize_t n = ::recv(fd, buf, sizeof buf, 0);
                    if (n <= 0) return;
                    ::send(fd, buf, static_cast<std::size_t>(n), MSG_NOSIGNAL);
                }
            });
            const std::string message(
                R"({"type":"commit","id":12345,"ops":[{"op":"modify","object_id":2,"object":{"kind":"plane","normal":[-1.0,0.0,0.0],"offset":0.0051,"mode":"bilateral","gains":{"K":1000.0,"B":5.0}}}]})");
            char buf[70000];
            for (std::size_t i = 0; i < commits; ++i) {
                const auto t0 = RealtimeLoop::now_ns();
                ::send(sv[0], message.data(), message.size(), MSG_NOSIGNAL);
                ::recv(sv[0], buf, sizeof buf, 0);
                pingpong.record(RealtimeLoop::now_ns() - t0);
            }
            ::shutdown(sv[0], SHUT_RDWR);
            echo.join();
            ::close(sv[0]);
            ::close(sv[1]);
        }
        // The daemon.
        DaemonProcess daemon(socket, shm);
        if (!daemon.started()) {
            state.SkipWithError("hapticd did not start");
            return;
        }
        LatencyStats to_force;
        LatencyStats reply;
        LatencyStats status_reply;
        std::uint64_t period_ns = 0;
        try {
            hc::ConnectOptions co;
            co.socket_path = socket;
            co.client_name = "latency-benchmark";
            hc::Client client = hc::Client::connect(co);
            const hc::StateReader reader = hc::StateReader::open(client.welcome().state_shm);
            period_ns = static_cast<std::uint64_t>(std::llround(reader.period_s() * 1e9));
            hc::Plane plane{{-1.0, 0.0, 0.0}, 0.005, true, hc::Gains::explicit_gains(1000.0, 5.0)};
            const std::uint32_t id = client.commit(hc::Batch().add(plane)).object_ids.front();
            // A request without checks (status) for comparison with the commit's reply.
            for (std::size_t i = 0; i < 1000; ++i) {
                const auto t0 = RealtimeLoop::now_ns();
                client.status();
                status_reply.record(RealtimeLoop::now_ns() - t0);
            }
            hc::StateSample s;
            for (std::size_t i = 0; i < commits; ++i) {
                plane.offset = (i % 2 == 0) ? 0.0051 : 0.005;  // 0.1 mm steps: a 0.1 N change of the force
                const auto t0 = RealtimeLoop::now_ns();
                const std::uint64_t seq = client.commit(hc::Batch().modify(id, plane)).commit_seq;
                reply.record(RealtimeLoop::now_ns() - t0);
                while (!(reader.read(s) && s.last_commit_seq >= seq)) {
                }
                to_force.record(RealtimeLoop::now_ns() - t0);
            }
            client.bye();
        } catch (const hc::Error& e) {
            state.SkipWithError(e.what());
            return;
        }
        report(state, "to_force", to_force);
        report(state, "reply", reply);
        report(state, "status", status_reply);
        report(state, "pingpong", pingpong);
        state.counters["commits"] = static_cast<double>(to_force.count());
        state.counters["goal_us"] = static_cast<double>(period_ns) * 1e-3 + static_cast<double>(pingpong.percentile_ns(0.5)) * 1e-3;
    }
    state.counters["client_fifo"] = rt.fifo ? 1.0 : 0.0;
    std::filesystem::remove_all(dir);
}
BENCHMARK(BM_CommandToForceLatency)->Iterations(1)->Unit(benchmark::kMillisecond)->UseRealTime();

// ---------------------------------------------------------------------------------------------------------
// Tick compute: one wall against one wall + 64 objects.

SimDeviceConfig sim_config() {
    SimDeviceConfig c;
    c.capabilities.axes = 3;
    c.capabilities.max_force = 10.0;
    c.plant = {0.3, 6.0, 300.0};
    c.period = 1e-3;
    c.scenario.kind = Scenario::Step;
    return c;
}

Scene one_wall_scene() {
    std::vector<VirtualWall> walls;
    walls.emplace_back(WallGeometry{0, 0.0, 1.0, WallMode::Bilateral}, 18000.0, 110.0, 1e-3);  // as daemon_tick.cpp
    return Scene(std::move(walls), 3, 10.0);
}

// Today's tick (daemon_tick.cpp's TickRig on 3 axes).
struct OneWallTick {
    SimDevice device{sim_config()};
    Scene scene{one_wall_scene()};
    DelayRing<AxisVector> delay{4};
    OneWallTick() { device.open(); }
    double tick() noexcept {
        AxisVector p{};
        AxisVector f{};
        device.read_position(p);
        scene.evaluate(p, f);
        device.write_force(delay.push_pop(f));
        return p[0];
    }
};

// The same plus 64 client objects and the state publication, as Daemon::tick does with --serve.
struct ObjectsTick {
    OneWallTick base;
    CommitRing ring{4};
    SceneObjects objects;
    StatePublisher publisher;
    std::uint64_t ticks = 0;
    static SceneObjectsConfig objects_config() {
        SceneObjectsConfig c;
        c.axes = 3;
        c.max_force = 10.0;
        c.max_force_rate = 1e4;
        return c;
    }
    explicit ObjectsTick(const std::string& shm, std::size_t count = kSceneObjectCapacity)
        : objects(objects_config(), ring), publisher(shm, 3, 1e-3, -1) {
        ObjectCommit commit;
        commit.seq = 1;
        commit.count = static_cast<std::uint32_t>(count);
        for (std::size_t i = 0; i < count; ++i) {
            SlotUpdate& u = commit.updates[i];
            u.slot = static_cast<std::uint8_t>(i);
            u.action = SlotUpdate::Action::Set;
            u.params.id = static_cast<std::uint32_t>(i + 1);
            u.params.kind = ObjectKind::Plane;
            u.params.bilateral = true;  // always in contact: every plane computes its force
            const double a = 2.0 * M_PI * static_cast<double>(i) / static_cast<double>(kSceneObjectCapacity);
            u.params.direction = {std::cos(a), std::sin(a), 0.0};  // 64 normals around the z axis
            u.params.offset = 0.001;
            u.params.K = 10.0;
            u.params.B = 0.1;
        }
        ring.try_push(commit);
        objects.apply_commits();
    }
    double tick() noexcept {
        AxisVector p{};
        AxisVector f{};
        base.device.read_position(p);
        objects.apply_commits();
        base.scene.evaluate(p, f);
        objects.add_forces(p, f);
        const AxisVector applied = base.delay.push_pop(f);
        base.device.write_force(applied);
        StateTick st;
        st.tick = ticks++;
        st.position = p;
        st.velocity = objects.velocity();
        st.force = applied;
        publisher.publish(st, &objects);
        return p[0];
    }
};

std::string bench_shm(const char* what) { return "/hapticd-bench-" + std::string(what) + "-" + std::to_string(::getpid()); }

void BM_TickOneWall(benchmark::State& state) {
    OneWallTick rig;
    for (auto _ : state) benchmark::DoNotOptimize(rig.tick());
}
BENCHMARK(BM_TickOneWall);

void BM_Tick64Objects(benchmark::State& state) {
    ObjectsTick rig(bench_shm("tick64"));
    for (auto _ : state) benchmark::DoNotOptimize(rig.tick());
    state.counters["objects"] = static_cast<double>(rig.objects.occupied());
}
BENCHMARK(BM_Tick64Objects);

// Where the time goes: the --serve tick with 0 (the fixed cost: commit poll, rate limit, publication), 1, 8
// and 64 objects.
void BM_TickObjects(benchmark::State& state) {
    ObjectsTick rig(bench_shm("tickn"), static_cast<std::size_t>(state.range(0)));
    for (auto _ : state) benchmark::DoNotOptimize(rig.tick());
    state.counters["objects"] = static_cast<double>(rig.objects.occupied());
}
BENCHMARK(BM_TickObjects)->Arg(0)->Arg(1)->Arg(8)->Arg(64);

// The parts of the 64-object tick alone: SceneObjects::add_forces, StatePublisher::publish.
void BM_TickPartAddForces64(benchmark::State& state) {
    ObjectsTick rig(bench_shm("partforces"));
    AxisVector p{0.0005, 0.0, 0.0};
    for (auto _ : state) {
        AxisVector f{};
        rig.objects.add_forces(p, f);
        benchmark::DoNotOptimize(f);
    }
}
BENCHMARK(BM_TickPartAddForces64);
void BM_TickPartPublish64(benchmark::State& state) {
    ObjectsTick rig(bench_shm("partpublish"));
    StateTick st;
    for (auto _ : state) {
        ++st.tick;
        rig.publisher.publish(st, &rig.objects);
    }
}
BENCHMARK(BM_TickPartPublish64);

void BM_TickRatio64VsOneWall(benchmark::State& state) {
    OneWallTick one;
    ObjectsTick many(bench_shm("ratio"));
    constexpr int kBlock = 1000;
    double one_ns = 0.0, many_ns = 0.0;
    std::uint64_t blocks = 0;
    for (auto _ : state) {
        auto t0 = RealtimeLoop::now_ns();
        for (int i = 0; i < kBlock; ++i) benchmark::DoNotOptimize(one.tick());
        auto t1 = RealtimeLoop::now_ns();
        for (int i = 0; i < kBlock; ++i) benchmark::DoNotOptimize(many.tick());
        auto t2 = RealtimeLoop::now_ns();
        one_ns += static_cast<double>(t1 - t0);
        many_ns += static_cast<double>(t2 - t1);
        ++blocks;
    }
    state.counters["one_wall_ns"] = one_ns / static_cast<double>(blocks * kBlock);
    state.counters["objects64_ns"] = many_ns / static_cast<double>(blocks * kBlock);
    state.counters["ratio"] = many_ns / one_ns;
}
BENCHMARK(BM_TickRatio64VsOneWall)->MinTime(2.0);

// ---------------------------------------------------------------------------------------------------------
// State read cost.

void state_read(benchmark::State& state, int writer_mode) {  // 0: none, 1: 1 kHz, 2: back to back
    const std::string name = bench_shm(writer_mode == 0 ? "read0" : writer_mode == 1 ? "read1k" : "readbb");
    StatePublisher publisher(name, 3, 1e-3, -1);
    StateTick st;
    publisher.publish(st, nullptr);
    std::atomic<bool> stop{false};
    std::thread writer;
    if (writer_mode != 0) {
        writer = std::thread([&] {
            std::int64_t deadline = RealtimeLoop::now_ns();
            while (!stop.load(std::memory_order_relaxed)) {
                ++st.tick;
                st.position[0] = static_cast<double>(st.tick) * 1e-6;
                publisher.publish(st, nullptr);
                if (writer_mode == 1) {
                    deadline += 1'000'000;
                    RealtimeLoop::sleep_until(deadline);
                }
            }
        });
    }
    const hc::StateReader reader = hc::StateReader::open(name);
    hc::StateSample s;
    std::uint64_t failed = 0;
    for (auto _ : state) {
        if (!reader.read(s, 1000)) ++failed;
        benchmark::DoNotOptimize(s);
    }
    stop = true;
    if (writer.joinable()) writer.join();
    state.counters["failed_reads"] = static_cast<double>(failed);
}
void BM_StateReadNoWriter(benchmark::State& state) { state_read(state, 0); }
void BM_StateReadWriter1kHz(benchmark::State& state) { state_read(state, 1); }
void BM_StateReadWriterBackToBack(benchmark::State& state) { state_read(state, 2); }
BENCHMARK(BM_StateReadNoWriter);
BENCHMARK(BM_StateReadWriter1kHz);
BENCHMARK(BM_StateReadWriterBackToBack);

}  // namespace

BENCHMARK_MAIN();
