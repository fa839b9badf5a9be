// SPDX-License-Identifier: Apache-2.0
// Benchmarks of the client interface (docs/clients.md, "Measured"), each beside its baseline in the same run:
//  * BM_CommandToForceLatency: a real `hapticd --serve` at 1 kHz (SCHED_FIFO when permitted) and a client
//    that moves a plane it presses on (modify of the offset only) and then spins on the shared-memory state
//    until the tick that applied the batch is published (last_commit_seq >= the commit's seq). Per commit:
//    from before the request is sent to that tick being visible; p50/p99/max over HAPTICD_LATENCY_COMMITS
//    commits (default 10000), the commit's own reply round trip, and (1000 x) that of a status request,
//    which the server answers without the commit's checks. Baseline in the same run: a bare
//    SOCK_SEQPACKET ping-pong (socketpair + echo thread) with a message of the commit's size.
//    Goal: within one loop period plus the ping-pong time. Run twice: the daemon's loop sleeping
//    until each deadline, and with --spin-us 300 (docs/hapticd.md). Also reported: the loop's worst
//    wake-up lateness seen in the state stream during the commits, and period + that + the worst ping-pong
//    (machine_bound_max_us): the worst a commit should take on this machine if the daemon's server added no
//    stall of its own.
//  * BM_TickOneWall / BM_Tick64Objects/S / BM_TickRatio64VsOneWall/S: the loop's compute for one tick
//    without sleeping: today's tick (simulated plant, one wall, delay ring; as daemon_tick.cpp) against the
//    same tick plus 64 client objects with their ramps, saturation, the force-rate limit and the state
//    publication, for six scenes S (TickScene below: linear objects in contact, planes out of contact,
//    unilateral planes pressed 1 mm deep — the worst case —, fields, a proxy moved by a commit every tick,
//    and unilateral planes pressed 5 mm deep).
//    The ratio benchmark alternates blocks of 1000 ticks of each so that both see the same machine load.
//    Goal: <= 2x. BM_TickObjects/N: the worst-case tick with N = 0, 1, 8, 64 objects (fixed cost, cost per object).
//  * BM_TickPartPublishMeshes/N: the state publication with N = 0, 1, 7, 9 mesh objects pressed into a face, the
//    mesh proxies' part of it (the first 7 published); N = 0 is its baseline in the same run.
//  * BM_StateRead*: StateReader::read (the C++ client's seqlock read of one tick) with no writer, with a
//    writer at 1 kHz (the loop), and with a writer rewriting back to back (lockstep; reads then retry).
//    Goal: <= 200 ns. The read includes the liveness check (one clock_gettime(CLOCK_MONOTONIC) against the
//    writer's heartbeat); BM_ClockGettimeMonotonic, that call alone, is its baseline in the same run.
#include <benchmark/benchmark.h>

#include <time.h>
#include <signal.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <string>
#include <thread>
#include <vector>

#include "common/process.hpp"
#include "common/test_paths.hpp"
#include "common/unix_socket.hpp"
#include "devices/sim_device.hpp"
#include "hapticd/client.hpp"
#include "loop/realtime_loop.hpp"
#include "loop/realtime_setup.hpp"
#include "loop/stats.hpp"
#include "mesh/mesh_hierarchy.hpp"
#include "mesh/procedural_meshes.hpp"
#include "scene/delay_ring.hpp"
#include "scene/scene.hpp"
#include "scene/scene_objects.hpp"
#include "server/contact_events.hpp"
#include "server/state_publisher.hpp"

namespace {

using namespace hapticd;
namespace hc = hapticd::client;

void report(benchmark::State& state, const std::string& prefix, const LatencyStats& s) {
    state.counters[prefix + "_p50_us"] = static_cast<double>(s.percentile_ns(0.50)) * 1e-3;
    state.counters[prefix + "_p99_us"] = static_cast<double>(s.percentile_ns(0.99)) * 1e-3;
    state.counters[prefix + "_p999_us"] = static_cast<double>(s.percentile_ns(0.999)) * 1e-3;
    state.counters[prefix + "_max_us"] = static_cast<double>(s.max_ns()) * 1e-3;
    state.counters[prefix + "_mean_us"] = s.mean_ns() * 1e-3;
}

// ---------------------------------------------------------------------------------------------------------
// Command-to-force latency against a real daemon.

// hapticd --serve (tests/common/process.hpp), ready once a connect succeeds; stopped with SIGTERM.
class DaemonProcess {
  public:
    DaemonProcess(const std::string& socket, const std::string& shm, long spin_us)
        : process_(HAPTICD_BINARY,
                   {"--config",
                    "",
                    "--serve",
                    "--serve-socket",
                    socket,
                    "--serve-shm",
                    shm,
                    "--spin-us",
                    std::to_string(spin_us),
                    "--wall",
                    "axis=0 position=0.05 direction=+1",
                    "--stiffness",
                    "100",
                    "--damping",
                    "1",
                    "--scenario",
                    "hold",
                    "--hold-distance",
                    "0.055",
                    "--hold-force",
                    "2",
                    "--watchdog-overruns",
                    "1000000",
                    "--watchdog-stall-periods",
                    "1000000",
                    "--quiet"},
                   "bench_daemon", "", hapticd::test::scratch_dir("hapticd_bench")) {
        ready_ = process_.pid() > 0 && hapticd::test::wait_for_socket(socket, std::chrono::seconds(20));
    }
    ~DaemonProcess() {
        process_.signal(SIGTERM);
        process_.wait();
    }
    [[nodiscard]] bool started() const { return ready_; }

  private:
    hapticd::test::Process process_;
    bool ready_ = false;
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
        DaemonProcess daemon(socket, shm, static_cast<long>(state.range(0)));
        if (!daemon.started()) {
            state.SkipWithError("hapticd did not start");
            return;
        }
        LatencyStats to_force;
        LatencyStats reply;
        LatencyStats status_reply;
        std::uint64_t period_ns = 0;
        std::int64_t loop_wake_max_ns = 0;  // the daemon's own worst wake-up lateness seen in the state stream
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
                for (;;) {
                    if (reader.read(s)) {
                        loop_wake_max_ns = std::max(loop_wake_max_ns, s.wake_latency_ns);
                        if (s.last_commit_seq >= seq) break;
                    }
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
        state.counters["goal_us"] =
            static_cast<double>(period_ns) * 1e-3 + static_cast<double>(pingpong.percentile_ns(0.5)) * 1e-3;
        // The worst a commit should take here if the server added no stall of its own: one period, the
        // loop's worst wake-up in the same run, and the worst bare ping-pong (the socket's own stalls).
        state.counters["loop_wake_max_us"] = static_cast<double>(loop_wake_max_ns) * 1e-3;
        state.counters["machine_bound_max_us"] = static_cast<double>(period_ns) * 1e-3 +
                                                 static_cast<double>(loop_wake_max_ns) * 1e-3 +
                                                 static_cast<double>(pingpong.max_ns()) * 1e-3;
    }
    state.counters["client_fifo"] = rt.fifo ? 1.0 : 0.0;
    std::filesystem::remove_all(dir);
}
// Arg: the daemon's --spin-us (0: the loop sleeps until each deadline; 300: it busy-waits the last 300 us,
// so the kernel's wake-up latency no longer delays the tick that applies the commit).
BENCHMARK(BM_CommandToForceLatency)->Arg(0)->Arg(300)->Iterations(1)->Unit(benchmark::kMillisecond)->UseRealTime();

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

// The scenes of 64 (or N) client objects the tick is measured with (scene_objects.hpp, "How a tick is
// computed"): the normals of the planes go around the z axis, so their forces cancel at the origin and the
// simulated handle stays within a fraction of a millimetre of it.
enum class TickScene : int {
    BilateralPlanes = 0,    // in contact, 5 mm inside: linear, summed in closed form
    UnilateralOutside = 1,  // 2 mm out of contact: beyond the safe radius, skipped
    UnilateralInside =
        2,             // all pressed 1 mm deep, within the clamp's reach: each evaluated every tick (the worst case)
    FieldsInside = 3,  // the handle inside 64 fields of 1 cm radius: linear, summed
    BilateralOneMoving = 4,  // 64 bilateral planes, one of them moved by a commit every tick (re-summed each tick)
    UnilateralDeep = 5,      // all pressed 5 mm deep: summed while the motion test proves their clamps idle
    BilateralOneGliding =
        6,  // 64 bilateral planes, one moved every 5 ticks with the daemon's interpolation (a move each tick)
};
const char* to_string(TickScene s) {
    switch (s) {
        case TickScene::BilateralPlanes:
            return "bilateral_planes_in_contact";
        case TickScene::UnilateralOutside:
            return "unilateral_planes_out_of_contact";
        case TickScene::UnilateralInside:
            return "unilateral_planes_all_pressed";
        case TickScene::FieldsInside:
            return "fields_handle_inside";
        case TickScene::BilateralOneMoving:
            return "bilateral_planes_one_moved_every_tick";
        case TickScene::UnilateralDeep:
            return "unilateral_planes_all_pressed_5mm";
        case TickScene::BilateralOneGliding:
            return "bilateral_planes_one_interpolated_200Hz";
    }
    return "?";
}

ObjectParams tick_scene_object(TickScene scene, std::size_t i) {
    ObjectParams o;
    o.id = static_cast<std::uint32_t>(i + 1);
    const double a = 2.0 * M_PI * static_cast<double>(i) / static_cast<double>(kSceneObjectCapacity);
    o.direction = {std::cos(a), std::sin(a), 0.0};
    o.K = 10.0;
    o.B = 0.1;
    switch (scene) {
        case TickScene::BilateralPlanes:
        case TickScene::BilateralOneMoving:
        case TickScene::BilateralOneGliding:
            o.kind = ObjectKind::Plane;
            o.bilateral = true;
            o.offset = 0.005;
            break;
        case TickScene::UnilateralOutside:
            o.kind = ObjectKind::Plane;
            o.offset = -0.002;
            break;
        case TickScene::UnilateralInside:
            o.kind = ObjectKind::Plane;
            o.offset = 0.001;
            break;
        case TickScene::UnilateralDeep:
            o.kind = ObjectKind::Plane;
            o.offset = 0.005;
            break;
        case TickScene::FieldsInside:
            o.kind = ObjectKind::Field;
            o.radius = 0.01;
            for (std::size_t r = 0; r < 3; ++r) o.jacobian[r][r] = -10.0;
            break;
    }
    return o;
}

// The same plus N client objects, the state publication and the contact detection, as Daemon::tick does
// with --serve (the contact ring is left undrained: in a steady scene nothing is pushed).
struct ObjectsTick {
    OneWallTick base;
    CommitRing ring{4};
    SceneObjects objects;
    StatePublisher publisher;
    ContactRing contact_ring{kContactRingCapacity};
    ContactDetector contacts{contact_ring};
    TickScene scene;
    std::uint64_t ticks = 0;
    ObjectCommit move{};
    StateTick record{};
    static SceneObjectsConfig objects_config(TickScene scene_kind) {
        SceneObjectsConfig c;
        c.axes = 3;
        if (scene_kind == TickScene::BilateralOneGliding) c.move_interval_max = 0.05;  // the daemon's default
        return c;
    }
    ObjectsTick(const std::string& shm, TickScene scene_kind, std::size_t count = kSceneObjectCapacity)
        : objects(objects_config(scene_kind), ring), publisher(shm, 3, 1e-3, -1), scene(scene_kind) {
        ObjectCommit commit;
        commit.seq = 1;
        commit.count = static_cast<std::uint32_t>(count);
        for (std::size_t i = 0; i < count; ++i) {
            SlotUpdate& u = commit.updates[i];
            u.slot = static_cast<std::uint8_t>(i);
            u.action = SlotUpdate::Action::Set;
            u.params = tick_scene_object(scene, i);
        }
        ring.try_push(commit);
        objects.apply_commits();
        move.count = 1;
        move.updates[0].slot = 0;
        move.updates[0].action = SlotUpdate::Action::Move;
        move.updates[0].params = tick_scene_object(scene, 0);
        // Past the 30 ms ramps: the steady state is measured.
        for (int i = 0; i < 100; ++i) tick();
    }
    double tick() noexcept {
        if (scene == TickScene::BilateralOneMoving) {  // a client moving its proxy every tick
            move.seq = ticks + 2;
            move.updates[0].params.offset = 0.005 + 1e-6 * static_cast<double>(ticks % 100);
            ring.try_push(move);
        }
        if (scene == TickScene::BilateralOneGliding && ticks % 5 == 0) {  // a client at 200 Hz, rendered by the hold
            move.seq = ticks + 2;
            move.updates[0].params.offset = 0.005 + 1e-6 * static_cast<double>(ticks % 100);
            ring.try_push(move);
        }
        // The sample is read into the published record itself (no copy of it; Daemon::tick copies it once),
        // a member reused from tick to tick as Daemon::tick does.
        StateTick& st = record;
        AxisVector f{};
        base.device.read_position(st.position);
        objects.apply_commits();
        base.scene.evaluate(st.position, f);
        objects.add_forces(st.position, f);
        st.force = base.delay.push_pop(f);
        base.device.write_force(st.force);
        st.tick = ticks++;
        st.velocity = objects.velocity();
        publisher.publish(st, &objects);
        contacts.detect(st, &objects);
        return st.position[0];
    }
};

std::string bench_shm(const char* what) {
    return "/hapticd-bench-" + std::string(what) + "-" + std::to_string(::getpid());
}

void BM_TickOneWall(benchmark::State& state) {
    OneWallTick rig;
    for (auto _ : state) benchmark::DoNotOptimize(rig.tick());
}
BENCHMARK(BM_TickOneWall);

void BM_Tick64Objects(benchmark::State& state) {
    const auto scene = static_cast<TickScene>(state.range(0));
    ObjectsTick rig(bench_shm("tick64"), scene);
    const std::uint64_t c0 = rig.objects.classifications();
    const std::uint64_t s0 = rig.objects.pressed_summed(), b0 = rig.objects.pressed_fallbacks();
    std::uint64_t n = 0;
    double lo = 1e9, hi = -1e9;
    for (auto _ : state) {
        const double x = rig.tick();
        benchmark::DoNotOptimize(x);
        lo = std::min(lo, x);
        hi = std::max(hi, x);
        ++n;
    }
    state.counters["x_range_mm"] = (hi - lo) * 1e3;
    state.counters["pressed_summed_per_tick"] =
        static_cast<double>(rig.objects.pressed_summed() - s0) / static_cast<double>(n);
    state.counters["pressed_one_by_one_per_tick"] =
        static_cast<double>(rig.objects.pressed_fallbacks() - b0) / static_cast<double>(n);
    state.SetLabel(to_string(scene));
    state.counters["objects"] = static_cast<double>(rig.objects.occupied());
    state.counters["contacts"] = static_cast<double>(__builtin_popcountll(rig.objects.contact_mask()));
    state.counters["classified_per_tick"] =
        static_cast<double>(rig.objects.classifications() - c0) / static_cast<double>(n);
}
BENCHMARK(BM_Tick64Objects)->DenseRange(0, 5);

// Where the time goes: the --serve tick with 0 (the fixed cost: commit poll, rate limit, publication), 1, 8
// and 64 objects (unilateral planes, all pressed: each evaluated every tick).
void BM_TickObjects(benchmark::State& state) {
    ObjectsTick rig(bench_shm("tickn"), TickScene::UnilateralInside, static_cast<std::size_t>(state.range(0)));
    for (auto _ : state) benchmark::DoNotOptimize(rig.tick());
    state.counters["objects"] = static_cast<double>(rig.objects.occupied());
}
BENCHMARK(BM_TickObjects)->Arg(0)->Arg(1)->Arg(8)->Arg(64);

// The parts of the worst-case 64-object tick alone: SceneObjects::add_forces, StatePublisher::publish.
void BM_TickPartAddForces64(benchmark::State& state) {
    ObjectsTick rig(bench_shm("partforces"), TickScene::UnilateralInside);
    AxisVector p{0.0005, 0.0, 0.0};
    for (auto _ : state) {
        AxisVector f{};
        rig.objects.add_forces(p, f);
        benchmark::DoNotOptimize(f);
    }
}
BENCHMARK(BM_TickPartAddForces64);
void BM_TickPartPublish64(benchmark::State& state) {
    ObjectsTick rig(bench_shm("partpublish"), TickScene::UnilateralInside);
    StateTick st;
    for (auto _ : state) {
        ++st.tick;
        rig.publisher.publish(st, &rig.objects);
    }
}
BENCHMARK(BM_TickPartPublish64);
// StatePublisher::publish with N mesh objects, each pressed 0.5 mm into a face (one active constraint): the
// proxies' part of the publication (SceneObjects::mesh_slot_mask, mesh_proxy: the proxy and normals taken to the
// device frame; the first 7 written). N = 0 is the same publication without meshes, its baseline in the same run.
void BM_TickPartPublishMeshes(benchmark::State& state) {
    const auto count = static_cast<std::size_t>(state.range(0));
    CommitRing ring{4};
    SceneObjectsConfig c;
    c.axes = 3;
    SceneObjects objects(c, ring);
    StatePublisher publisher(bench_shm("partmeshes"), 3, 1e-3, -1);
    const auto cube = mesh::MeshHierarchy::build(mesh::box(Eigen::Vector3d(0.01, 0.01, 0.01)), mesh::MeshMode::solid);
    ObjectCommit commit;
    commit.seq = 1;
    commit.count = static_cast<std::uint32_t>(count);
    for (std::size_t i = 0; i < count; ++i) {
        SlotUpdate& u = commit.updates[i];
        u.slot = static_cast<std::uint8_t>(i);
        u.action = SlotUpdate::Action::Set;
        u.params.id = static_cast<std::uint32_t>(i + 1);
        u.params.kind = ObjectKind::Mesh;
        u.params.mesh = cube.get();
        u.params.mesh_id = 1;
        u.params.point = {-0.0095, 0.0, 0.0};  // its +x face at x = 0.5 mm
        u.params.K = 10.0;
        u.params.B = 0.1;
    }
    ring.try_push(commit);
    objects.apply_commits();
    StateTick st;
    for (int i = 0; i <= 100; ++i) {  // from 1 mm outside to 0.5 mm inside, then past the 30 ms ramps
        st.position = {std::max(0.0, 0.0015 - 1.5e-4 * i), 0.0, 0.0};
        AxisVector f{};
        objects.add_forces(st.position, f);
        publisher.publish(st, &objects);
    }
    for (auto _ : state) {
        ++st.tick;
        publisher.publish(st, &objects);
    }
    StateLayout out{};
    publisher.read(out);
    state.counters["meshes"] = static_cast<double>(__builtin_popcountll(out.mesh_slot_mask));
    state.counters["proxies"] = static_cast<double>(out.mesh_proxies);
    state.counters["in_contact"] = static_cast<double>(__builtin_popcountll(out.contact_mask));
}
BENCHMARK(BM_TickPartPublishMeshes)->Arg(0)->Arg(1)->Arg(7)->Arg(9);
// ContactDetector::detect with 64 objects in contact and no transition (every tick of a steady scene), and
// with 64 transitions per tick (the config mask toggling all 64 walls: 64 records pushed, then popped here so
// the ring never fills; the pops are in the time).
void BM_TickPartContacts64(benchmark::State& state) {
    ObjectsTick rig(bench_shm("partcontacts"), TickScene::UnilateralInside);
    const bool toggling = state.range(0) != 0;
    StateTick st = rig.record;
    ContactRecord r;
    while (rig.contact_ring.try_pop(r)) {
    }  // the begins of the rig's ramp-in
    std::uint64_t pushed = 0;
    for (auto _ : state) {
        ++st.tick;
        if (toggling) st.config_contact_mask = ~st.config_contact_mask;
        rig.contacts.detect(st, &rig.objects);
        while (rig.contact_ring.try_pop(r)) ++pushed;
    }
    state.SetLabel(toggling ? "64 transitions per tick" : "64 in contact, steady");
    state.counters["contacts"] =
        static_cast<double>(__builtin_popcountll(rig.objects.contact_mask() & rig.objects.occupied_mask()));
    state.counters["records_per_tick"] = static_cast<double>(pushed) / static_cast<double>(state.iterations());
    state.counters["lost"] = static_cast<double>(rig.contacts.lost());
}
BENCHMARK(BM_TickPartContacts64)->Arg(0)->Arg(1);

// The goal's measurement: blocks of 1000 ticks of today's one-wall tick and of the 64-object tick, alternated
// so that both see the same machine load; per scene.
void BM_TickRatio64VsOneWall(benchmark::State& state) {
    const auto scene = static_cast<TickScene>(state.range(0));
    OneWallTick one;
    ObjectsTick many(bench_shm("ratio"), scene);
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
    state.SetLabel(to_string(scene));
    state.counters["one_wall_ns"] = one_ns / static_cast<double>(blocks * kBlock);
    state.counters["objects64_ns"] = many_ns / static_cast<double>(blocks * kBlock);
    state.counters["ratio"] = many_ns / one_ns;
}
BENCHMARK(BM_TickRatio64VsOneWall)->DenseRange(0, 6)->MinTime(1.0);

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
void BM_ClockGettimeMonotonic(benchmark::State& state) {
    timespec ts{};
    for (auto _ : state) {
        ::clock_gettime(CLOCK_MONOTONIC, &ts);
        benchmark::DoNotOptimize(ts);
    }
}
BENCHMARK(BM_ClockGettimeMonotonic);
BENCHMARK(BM_StateReadNoWriter);
BENCHMARK(BM_StateReadWriter1kHz);
BENCHMARK(BM_StateReadWriterBackToBack);

}  // namespace

BENCHMARK_MAIN();
