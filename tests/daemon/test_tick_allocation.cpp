// SPDX-License-Identifier: Apache-2.0
// The tick allocates nothing (docs/architecture.md, "The real-time path"): this executable replaces the global
// operator new and delete with counting ones (tests/common/counting_allocator.hpp), and counts the calls made on the
// loop's thread while Daemon::run() runs 4000 ticks of a busy scene in lockstep (the tick driven back to back on the
// test's own thread: no timing, no real-time thread). The scene: three config walls (unilateral on x and z, bilateral
// on y); client objects of every kind (unilateral and bilateral planes, springs to a point and to a line, a field) and
// a mesh (an icosphere rendered through its god-object proxy, moved and turned every 10 ticks) planned by the server's
// own commit transaction (server/commit_transaction.hpp, plan_commit) and handed to the loop through its rings at given
// ticks, as --replay does (TickFeeder); moves every 5 ticks (first-order holds), a change of gains (a cross-fade), a
// removal (a ramp-out) and a departure (the departures ring); the handle on a Lissajous path through walls and objects;
// a delay buffer, passivity control, the force limiter, the shared-memory state with contact events, the recorder and
// the trace. A single allocation or release inside the counted ticks fails the test, naming the counts.
#include <gtest/gtest.h>

#include <unistd.h>

#include <atomic>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <new>
#include <numbers>
#include <string>
#include <utility>
#include <variant>
#include <vector>

#include "common/counting_allocator.hpp"
#include "daemon/daemon.hpp"
#include "daemon/recorder.hpp"
#include "mesh/procedural_meshes.hpp"
#include "loop/trace.hpp"
#include "scene/passivity_controller.hpp"
#include "scene/scene.hpp"
#include "scene/scene_objects.hpp"
#include "server/commit_transaction.hpp"
#include "server/contact_events.hpp"
#include "server/state_publisher.hpp"

namespace hapticd {
namespace {

namespace cl = hapticd::client;
using server::CommitOperation;

constexpr double kT = 1e-3;
constexpr std::uint64_t kTicks = 4000;

// The handle on a Lissajous path (a few mm on each axis): in and out of the walls and the objects.
class PathDevice final : public Device {
  public:
    PathDevice() {
        caps_.axes = 3;
        caps_.max_force = 10.0;
    }
    DeviceStatus open() override { return DeviceStatus::Ok; }
    DeviceStatus home() override { return DeviceStatus::Ok; }
    void close() noexcept override {}
    DeviceStatus read_position(AxisVector& p) noexcept override {
        const double t = static_cast<double>(reads_++) * kT;
        constexpr double w = 2.0 * std::numbers::pi;
        p = {0.004 * std::sin(w * 0.7 * t), 0.003 * std::sin(w * 1.1 * t + 0.5), 0.005 * std::sin(w * 0.5 * t)};
        return DeviceStatus::Ok;
    }
    DeviceStatus write_force(const AxisVector& f) noexcept override {
        for (double v : f) largest_ = std::fabs(v) > largest_ ? std::fabs(v) : largest_;
        ++writes_;
        return DeviceStatus::Ok;
    }
    DeviceStatus read_external_force(AxisVector& f) noexcept override {
        f = AxisVector{};
        return DeviceStatus::Ok;
    }
    const DeviceCapabilities& capabilities() const noexcept override { return caps_; }
    std::string_view name() const noexcept override { return "path"; }
    std::string last_error() const override { return ""; }

    std::uint64_t writes_ = 0;
    double largest_ = 0.0;

  private:
    std::uint64_t reads_ = 0;
    DeviceCapabilities caps_;
};

// Hands the loop each planned batch at its tick, into the commit ring or the departures ring (as --replay does).
class BatchFeeder final : public TickFeeder {
  public:
    BatchFeeder(CommitRing& ring, CommitRing& departures) : ring_(ring), departures_(departures) {}
    void at(std::uint64_t tick, const ObjectCommit& c, bool departure = false) {
        batches_.push_back(Timed{tick, departure, c});
    }
    void before_commits(std::uint64_t tick) noexcept override {
        while (next_ < batches_.size() && batches_[next_].tick == tick) {
            const Timed& b = batches_[next_++];
            pushed_ += (b.departure ? departures_ : ring_).try_push(b.commit) ? 1U : 0U;
        }
    }
    [[nodiscard]] std::size_t size() const { return batches_.size(); }
    [[nodiscard]] std::size_t pushed() const { return pushed_; }

  private:
    struct Timed {
        std::uint64_t tick;
        bool departure;
        ObjectCommit commit;
    };
    CommitRing& ring_;
    CommitRing& departures_;
    std::vector<Timed> batches_;  // in tick order
    std::size_t next_ = 0;
    std::size_t pushed_ = 0;
};

struct WallDef {
    std::size_t axis;
    double position, direction;
    bool bilateral;
    double K, B;
};
constexpr WallDef kWalls[] = {
    {0, 0.002, 1.0, false, 1500.0, 10.0}, {1, 0.0, 1.0, true, 400.0, 2.0}, {2, -0.003, -1.0, false, 1500.0, 10.0}};

// The server's side: the device as the server sees it, its checker and resolver, the slot table its commits
// build up (tests/server/test_commit_transaction.cpp's rig).
struct ServerSide {
    ServerSide() : config(make_config()), checker(make_plant()), resolver(config, checker) {}
    static ServerConfig make_config() {
        ServerConfig c;
        c.axes = 3;
        c.period = kT;
        c.delay = 3 * kT;  // the delay buffer's 2 samples and the tick's own
        c.mass = 0.3;
        c.max_force = 10.0;
        c.ramp_time = 0.03;
        c.workspace_min = {-0.06, -0.06, -0.06};
        c.workspace_max = {0.06, 0.06, 0.06};
        for (const WallDef& w : kWalls) {
            c.config_walls.push_back(ConfigWallInfo{w.axis, w.position, w.direction, w.bilateral, w.K, w.B});
        }
        return c;
    }
    static GainCheckPlant make_plant() {
        GainCheckPlant p;
        p.mass = 0.3;
        p.period = kT;
        p.time_delay = 3 * kT;
        p.mass_matrix = DeviceMass::isotropic_mass(0.3, 3);
        return p;
    }
    // Plans the batch (fails the test on a refusal) and adopts it, as the server does once it is in the ring.
    ObjectCommit commit(std::vector<CommitOperation> ops, std::vector<std::uint32_t>* ids = nullptr) {
        const server::MeshLookup lookup = [this](std::uint32_t) {
            // The hierarchy's own tables (no mesh store: nothing counts their bytes here).
            return server::MeshLookupResult{
                mesh, std::nullopt,
                [this](double crease) -> std::variant<const mesh::ShadingNormals*, server::Refusal> {
                    return mesh->shading(crease);
                }};
        };
        server::CommitOutcome o = server::plan_commit(server::CommitContext{config, checker, resolver, &lookup}, slots,
                                                      1, next_id, server::CommitRequest{std::move(ops)});
        if (const auto* r = std::get_if<server::CommitRefusal>(&o)) {
            ADD_FAILURE() << r->refusal.message;
            return {};
        }
        server::CommitPlan plan = std::get<server::CommitPlan>(std::move(o));
        slots = plan.slots;
        next_id = plan.next_object_id;
        if (ids != nullptr) *ids = plan.new_ids;
        plan.batch.seq = next_seq++;
        return plan.batch;
    }

    ServerConfig config;
    GainChecker checker;
    server::ObjectResolver resolver;
    server::SlotTable slots{};
    std::uint32_t next_id = 1 + std::size(kWalls);
    std::uint64_t next_seq = 1;
    // The session's one mesh (mesh id 1): an icosphere of 3 mm, built here as the server's worker would.
    std::shared_ptr<const mesh::MeshHierarchy> mesh =
        mesh::MeshHierarchy::build(mesh::icosphere(0.003, 2), mesh::MeshMode::solid);
};

CommitOperation add(const cl::ObjectDescription& d) { return CommitOperation{CommitOperation::Kind::Add, 0, d}; }
CommitOperation modify(std::uint32_t id, const cl::ObjectDescription& d) {
    return CommitOperation{CommitOperation::Kind::Modify, id, d};
}
CommitOperation remove(std::uint32_t id) { return CommitOperation{CommitOperation::Kind::Remove, id, std::nullopt}; }
CommitOperation clear() { return CommitOperation{CommitOperation::Kind::Clear, 0, std::nullopt}; }

cl::Plane plane(const cl::Vec3& n, double offset, bool bilateral, double K, double B) {
    return cl::Plane{.normal = n, .offset = offset, .bilateral = bilateral, .gains = cl::Gains::explicit_gains(K, B)};
}
cl::Spring spring(cl::Constraint c, const cl::Vec3& point, const cl::Vec3& direction, double K, double B) {
    return cl::Spring{
        .constraint = c, .point = point, .direction = direction, .gains = cl::Gains::explicit_gains(K, B)};
}
cl::Mesh mesh_object(const cl::Vec3& position, double angle) {
    cl::Mesh m;
    m.mesh = 1;
    m.position = position;
    m.orientation = {std::cos(angle / 2), 0.0, 0.0, std::sin(angle / 2)};
    m.gains = cl::Gains::explicit_gains(300.0, 3.0);
    m.static_friction = 0.4;
    m.dynamic_friction = 0.3;
    m.shading_crease_angle_deg = 30.0;  // force shading: the interpolated normal in the tick, on one face
    return m;
}
cl::Field field(const cl::Vec3& center, double radius, const cl::Vec3& force) {
    cl::Field f;
    f.center = center;
    f.radius = radius;
    f.force = force;
    f.jacobian = {cl::Vec3{-50.0, 0.0, 0.0}, cl::Vec3{0.0, -50.0, 0.0}, cl::Vec3{0.0, 0.0, -50.0}};
    f.damping = 1.0;
    return f;
}

TEST(TickAllocation, ABusySceneTicksWithoutAnAllocation) {
    clear_stop_request();
    const std::filesystem::path dir =
        std::filesystem::temp_directory_path() / ("hapticd_tick_allocation_" + std::to_string(::getpid()));
    std::filesystem::create_directories(dir);

    // The loop's side, as hapticd --serve builds it (server/serve_runtime.cpp).
    std::vector<VirtualWall> walls;
    for (const WallDef& w : kWalls) {
        walls.emplace_back(
            WallGeometry{w.axis, w.position, w.direction, w.bilateral ? WallMode::Bilateral : WallMode::Unilateral},
            w.K, w.B, kT);
    }
    Scene scene(std::move(walls), 3, 10.0);
    CommitRing ring(64), departures(kSceneObjectCapacity);
    SceneObjectsConfig oc;
    oc.period = kT;
    oc.ramp_time = 0.03;
    oc.axes = 3;
    oc.move_interval_max = 0.05;
    oc.activation_speed = 0.01;
    SceneObjects objects(oc, ring, &departures);
    StatePublisher state("/hapticd-tick-alloc-" + std::to_string(::getpid()), 3, kT, -1);
    ContactRing contact_ring(kContactRingCapacity);
    ContactDetector contacts(contact_ring);
    Recorder recorder((dir / "run.rec").string(), "{}", 1 << 12, true);
    objects.set_observer(&recorder);
    TraceWriter trace((dir / "trace.csv").string(), 1 << 12, true);
    PassivityControlConfig pcc;
    pcc.period = kT;
    pcc.damping_cap = 50.0;
    pcc.max_force = 10.0;
    pcc.axes = 3;
    PassivityController passivity(pcc);

    // The clients' batches, planned by the server's commit transaction.
    ServerSide srv;
    BatchFeeder feeder(ring, departures);
    std::vector<std::uint32_t> ids;
    feeder.at(10, srv.commit({add(plane({0, 0, -1}, -0.001, false, 300, 3)),
                              add(spring(cl::Constraint::Point, {0.001, 0, 0}, {1, 0, 0}, 80, 1)),
                              add(field({0, 0.002, 0}, 0.004, {0.5, 0, 0}))},
                             &ids));
    ASSERT_EQ(ids.size(), 3U);
    const std::uint32_t moving_plane = ids[0], moving_spring = ids[1], the_field = ids[2];
    feeder.at(20, srv.commit({add(plane({1, 0, 0}, 0.003, true, 200, 2)),
                              add(spring(cl::Constraint::Line, {0, 0, 0.001}, {0, 0, 1}, 40, 0.5))},
                             &ids));
    ASSERT_EQ(ids.size(), 2U);
    const std::uint32_t bilateral_plane = ids[0];
    feeder.at(30, srv.commit({add(mesh_object({0.002, 0.0, 0.003}, 0.0))}, &ids));
    ASSERT_EQ(ids.size(), 1U);
    const std::uint32_t the_mesh = ids[0];
    for (std::uint64_t tick = 150; tick < 3300; tick += 5) {  // moves: first-order holds in progress throughout
        const double s = std::sin(2.0 * std::numbers::pi * static_cast<double>(tick) * kT);
        std::vector<CommitOperation> ops{modify(moving_plane, plane({0, 0, -1}, -0.001 + 0.002 * s, false, 300, 3))};
        if (tick % 10 == 0) {  // the mesh moved and turned: holds of its position and orientation
            ops.push_back(modify(the_mesh, mesh_object({0.002, 0.001 * s, 0.003}, 0.5 * s)));
        }
        if (tick % 15 == 0) {
            ops.push_back(
                modify(moving_spring, spring(cl::Constraint::Point, {0.001 + 0.001 * s, 0, 0}, {1, 0, 0}, 80, 1)));
        }
        feeder.at(tick, srv.commit(std::move(ops)));
        if (tick == 1500) feeder.at(tick, srv.commit({modify(the_field, field({0, 0.002, 0}, 0.004, {0, 0.8, 0}))}));
        if (tick == 2500) feeder.at(tick, srv.commit({remove(bilateral_plane)}));
    }
    feeder.at(3500, srv.commit({clear()}), true);  // the client leaves: its objects ramp out (departures ring)

    DaemonConfig cfg;
    cfg.loop = {1'000'000, true};  // lockstep
    cfg.max_ticks = kTicks;
    cfg.delay_samples = 2;
    cfg.watchdog_enabled = false;
    cfg.passivity = &passivity;
    cfg.recorder = &recorder;
    cfg.feeder = &feeder;
    cfg.trace_axis = 0;
    PathDevice device;
    Daemon daemon(device, scene, &trace, cfg);
    daemon.attach(ServerHooks{&objects, &state, &contacts});

    test::start_counting();  // only this thread counts: the recorder's and the trace's writer threads allocate freely
    const RunResult result = daemon.run();
    const auto [allocations, releases] = test::stop_counting();

    EXPECT_EQ(allocations, 0U) << "operator new called " << allocations << " times in " << kTicks << " ticks";
    EXPECT_EQ(releases, 0U) << "operator delete called " << releases << " times in " << kTicks << " ticks";

    // The scene was busy: every batch reached the loop and was applied, the objects were in contact, moves
    // glided, the limiter and passivity control acted.
    EXPECT_EQ(result.fault, StateFault::None);
    EXPECT_EQ(result.counters.ticks, kTicks);
    EXPECT_EQ(feeder.pushed(), feeder.size());
    EXPECT_EQ(objects.stats().commits_applied, feeder.size());
    EXPECT_EQ(objects.stats().departures_applied, 1U);
    EXPECT_GT(objects.stats().commits_held, 0U);  // batches waited for ramps
    EXPECT_GT(objects.classifications(), 100U);
    EXPECT_EQ(objects.occupied(), 0U);  // all ramped out after the departure
    EXPECT_GT(result.limiter.largest_step, 0.0);
    EXPECT_GT(passivity.stats().damper_ticks + passivity.stats().guarded_ticks, 0U);
    EXPECT_NE(contact_ring.front(), nullptr);  // contact events were detected
    bool mesh_touched = false;                 // the path went into the mesh: its proxy rendered contacts
    for (const ContactRecord* r = contact_ring.front(); r != nullptr; r = contact_ring.front()) {
        mesh_touched = mesh_touched || (r->object_id == the_mesh && r->begin);
        contact_ring.pop();
    }
    EXPECT_TRUE(mesh_touched);
    EXPECT_TRUE(recorder.close());
    EXPECT_EQ(recorder.ticks_written(), kTicks);
    EXPECT_EQ(recorder.batches_written(), feeder.size());
    std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace hapticd
