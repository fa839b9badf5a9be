// SPDX-License-Identifier: Apache-2.0
// The mesh's costs (docs/mesh-rendering.md), baselines in the same run:
//  * BM_Validate / BM_HierarchyBuild: mesh_error (solid) and MeshHierarchy::build of a 100 000-triangle torus
//    (goal: accepted and built in under 1 s); BM_EmbreeBuild: Embree 3's scene commit of the same triangles;
//    BM_ValidateFlatFaces: mesh_error (solid) of a 99 372-triangle box (coplanar neighbours on its faces).
//  * BM_ShadingNormals: force shading's corner normals of the torus (crease 30 deg).
//  * BM_Sweep*: one segment query over the same torus on the segments a proxy sweeps in contact (recorded from a
//    proxy path): the hierarchy, brute force over every triangle, and Embree's rtcIntersect1 (first hit, no
//    offset rule) when libembree-dev is installed.
//  * BM_ProxyStepContact/<triangles>: GodObjectProxy::step with the handle 2 mm inside the surface moving 0.5 mm a
//    tick (0.5 m/s) along it, frictionless and with friction (mu 0.6/0.4), on the 100 000-triangle torus and on a
//    12-triangle box (the baseline); each step timed (clock_gettime) for p50/p99/max counters.
//  * BM_ProxyStepFast: 10 mm a tick (10 m/s) through the torus, in and out.
//  * BM_TickMeshContact/0: the tick's compute path with the 100 000-triangle torus as a client's mesh object in
//    contact (the contact path above, 0.5 m/s): SceneObjects::apply_commits and add_forces (the proxy, the wall law
//    in the mesh frame, the finite check), the delay buffer with the law's change, the force limiter; each tick timed
//    for p50/p99/max. /1, the baseline in the same run: the same path against one unilateral plane (a client's
//    one-wall scene, the handle 2 mm in). /2: /0 with force shading (crease 30 deg: every face of the torus is
//    smooth, each contact on one face shaded). The device's read and write and the state's publication (~30 ns,
//    docs/clients.md) are not in either.
#include <benchmark/benchmark.h>

#include <time.h>

#include <algorithm>
#include <cmath>
#include <memory>
#include <numbers>
#include <vector>

#include "mesh/god_object_proxy.hpp"
#include "mesh/procedural_meshes.hpp"
#include "scene/delay_ring.hpp"
#include "scene/force_limiter.hpp"
#include "scene/scene_objects.hpp"

#ifdef HAPTICD_BENCHMARK_EMBREE
#include <embree3/rtcore.h>
#endif

namespace {

using namespace hapticd::mesh;

// 500 x 100 quads: 100 000 triangles, 50 000 vertices; major radius 6 cm, tube 2 cm.
const TriangleMesh& big_torus() {
    static const TriangleMesh m = torus(0.06, 0.02, 500, 100);
    return m;
}

std::shared_ptr<const MeshHierarchy> big_hierarchy() {
    static const auto h = MeshHierarchy::build(big_torus(), MeshMode::solid);
    return h;
}

std::int64_t now_ns() {
    timespec t{};
    clock_gettime(CLOCK_MONOTONIC, &t);
    return static_cast<std::int64_t>(t.tv_sec) * 1'000'000'000 + t.tv_nsec;
}

// A point on the torus' outer equator at angle theta, pushed `depth` inward along the normal (the normal there is
// the radial direction).
Eigen::Vector3d on_torus(double theta, double depth) {
    const double r = 0.06 + 0.02 - depth;
    return {r * std::cos(theta), r * std::sin(theta), 0.004 * std::sin(7 * theta)};
}

// The handle's path: from 1 cm outside to 2 mm inside, then along the surface at `step` m a tick.
std::vector<Eigen::Vector3d> contact_path(std::size_t n, double step) {
    std::vector<Eigen::Vector3d> path;
    for (int k = 0; k <= 20; ++k) path.push_back(on_torus(0.0, -0.01 + 0.012 * k / 20.0));
    const double dtheta = step / 0.078;
    for (std::size_t k = 0; path.size() < n; ++k) path.push_back(on_torus(dtheta * static_cast<double>(k), 0.002));
    return path;
}

struct Segment {
    Eigen::Vector3d p, q;
};

// The segments a proxy sweeps: its position before each step to the handle.
const std::vector<Segment>& contact_segments() {
    static const std::vector<Segment> segments = [] {
        std::vector<Segment> s;
        GodObjectProxy proxy(big_hierarchy(), {});
        const auto path = contact_path(2000, 5e-4);
        proxy.reset(path.front());
        for (const auto& h : path) {
            s.push_back({proxy.contact().proxy, h});
            proxy.step(h);
        }
        return s;
    }();
    return segments;
}

void BM_Validate(benchmark::State& state) {
    for (auto _ : state) benchmark::DoNotOptimize(mesh_error(big_torus(), MeshMode::solid));
    state.counters["triangles"] = static_cast<double>(big_torus().triangles.size());
}
BENCHMARK(BM_Validate)->Unit(benchmark::kMillisecond);

// A box whose faces are grids of 91 x 91 squares: 99 372 triangles, each face's triangles coplanar (the coplanar
// overlap test runs on every pair of neighbours on a face).
void BM_ValidateFlatFaces(benchmark::State& state) {
    static const TriangleMesh m = box({0.03, 0.02, 0.01}, 91);
    bool accepted = false;
    for (auto _ : state) {
        const auto e = mesh_error(m, MeshMode::solid);
        accepted = !e.has_value();
        benchmark::DoNotOptimize(accepted);
    }
    state.counters["triangles"] = static_cast<double>(m.triangles.size());
    state.counters["accepted"] = accepted ? 1.0 : 0.0;
}
BENCHMARK(BM_ValidateFlatFaces)->Unit(benchmark::kMillisecond);

void BM_HierarchyBuild(benchmark::State& state) {
    std::size_t bytes = 0, depth = 0;
    for (auto _ : state) {
        const auto h = MeshHierarchy::build(big_torus(), MeshMode::solid);
        bytes = h->memory_bytes();
        depth = h->depth();
        benchmark::DoNotOptimize(h.get());
    }
    state.counters["triangles"] = static_cast<double>(big_torus().triangles.size());
    state.counters["memory_MB"] = static_cast<double>(bytes) / 1e6;
    state.counters["depth"] = static_cast<double>(depth);
}
BENCHMARK(BM_HierarchyBuild)->Unit(benchmark::kMillisecond);

// Force shading's corner normals of the same torus at crease 30 deg (off the loop: the first commit that asks for the
// angle pays it).
void BM_ShadingNormals(benchmark::State& state) {
    std::size_t bytes = 0;
    for (auto _ : state) {
        const ShadingNormals s = shading_normals(big_torus(), 30.0);
        bytes = s.memory_bytes();
        benchmark::DoNotOptimize(s.corners.data());
    }
    state.counters["memory_MB"] = static_cast<double>(bytes) / 1e6;
}
BENCHMARK(BM_ShadingNormals)->Unit(benchmark::kMillisecond);

void BM_SweepHierarchy(benchmark::State& state) {
    const auto h = big_hierarchy();
    const auto& s = contact_segments();
    std::size_t i = 0, hits = 0;
    for (auto _ : state) {
        const Segment& seg = s[i++ % s.size()];
        const SweepHit hit = h->sweep(seg.p, seg.q);
        hits += hit.hit() ? 1 : 0;
        benchmark::DoNotOptimize(hit);
    }
    state.counters["hit_fraction"] = static_cast<double>(hits) / static_cast<double>(state.iterations());
}
BENCHMARK(BM_SweepHierarchy);

// Brute force: every triangle's plane test (the lower bound of any method without a hierarchy).
void BM_SweepBruteForce(benchmark::State& state) {
    const auto h = big_hierarchy();
    const auto& tris = h->triangles();
    const auto& s = contact_segments();
    std::size_t i = 0;
    for (auto _ : state) {
        const Segment& seg = s[i++ % s.size()];
        const Eigen::Vector3d d = seg.q - seg.p;
        double best = 2.0;
        for (const auto& t : tris) {
            const double sp = t.normal.dot(seg.p - t.a), nd = t.normal.dot(d);
            if (nd < 0 && sp >= 0 && sp + nd < 0) best = std::min(best, sp / -nd);
        }
        benchmark::DoNotOptimize(best);
    }
}
BENCHMARK(BM_SweepBruteForce)->Unit(benchmark::kMicrosecond);

#ifdef HAPTICD_BENCHMARK_EMBREE
struct EmbreeScene {
    RTCDevice device = rtcNewDevice(nullptr);
    RTCScene scene = nullptr;
    explicit EmbreeScene(const TriangleMesh& m) {
        scene = rtcNewScene(device);
        RTCGeometry g = rtcNewGeometry(device, RTC_GEOMETRY_TYPE_TRIANGLE);
        auto* v = static_cast<float*>(rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3,
                                                              3 * sizeof(float), m.vertices.size()));
        for (std::size_t i = 0; i < m.vertices.size(); ++i)
            for (int k = 0; k < 3; ++k) v[3 * i + k] = static_cast<float>(m.vertices[i][k]);
        auto* ix = static_cast<unsigned*>(rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3,
                                                                  3 * sizeof(unsigned), m.triangles.size()));
        for (std::size_t i = 0; i < m.triangles.size(); ++i)
            for (int k = 0; k < 3; ++k) ix[3 * i + k] = m.triangles[i][k];
        rtcCommitGeometry(g);
        rtcAttachGeometry(scene, g);
        rtcReleaseGeometry(g);
        rtcCommitScene(scene);
    }
    ~EmbreeScene() {
        rtcReleaseScene(scene);
        rtcReleaseDevice(device);
    }
};

void BM_EmbreeBuild(benchmark::State& state) {
    for (auto _ : state) {
        EmbreeScene e(big_torus());
        benchmark::DoNotOptimize(e.scene);
    }
}
BENCHMARK(BM_EmbreeBuild)->Unit(benchmark::kMillisecond);

void BM_SweepEmbree(benchmark::State& state) {
    static EmbreeScene e(big_torus());
    const auto& s = contact_segments();
    std::size_t i = 0, hits = 0;
    RTCIntersectContext context;
    rtcInitIntersectContext(&context);
    for (auto _ : state) {
        const Segment& seg = s[i++ % s.size()];
        const Eigen::Vector3d d = seg.q - seg.p;
        RTCRayHit rh{};
        rh.ray.org_x = static_cast<float>(seg.p.x());
        rh.ray.org_y = static_cast<float>(seg.p.y());
        rh.ray.org_z = static_cast<float>(seg.p.z());
        rh.ray.dir_x = static_cast<float>(d.x());
        rh.ray.dir_y = static_cast<float>(d.y());
        rh.ray.dir_z = static_cast<float>(d.z());
        rh.ray.tnear = 0.0f;
        rh.ray.tfar = 1.0f;
        rh.ray.mask = 0xffffffffu;
        rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
        rtcIntersect1(e.scene, &context, &rh);
        hits += rh.hit.geomID != RTC_INVALID_GEOMETRY_ID ? 1 : 0;
        benchmark::DoNotOptimize(rh);
    }
    state.counters["hit_fraction"] = static_cast<double>(hits) / static_cast<double>(state.iterations());
}
BENCHMARK(BM_SweepEmbree);
#endif

void report_percentiles(benchmark::State& state, std::vector<std::int64_t>& ns) {
    if (ns.empty()) return;
    std::sort(ns.begin(), ns.end());
    const auto at = [&](double q) { return static_cast<double>(ns[static_cast<std::size_t>(q * (ns.size() - 1))]); };
    state.counters["p50_ns"] = at(0.5);
    state.counters["p99_ns"] = at(0.99);
    state.counters["p99.9_ns"] = at(0.999);
    state.counters["max_ns"] = static_cast<double>(ns.back());
}

// Arg 0: 100 000-triangle torus, 1: 12-triangle box; arg 1: friction 0/1.
void BM_ProxyStepContact(benchmark::State& state) {
    const bool torus_mesh = state.range(0) == 0;
    const MeshFriction friction = state.range(1) ? MeshFriction{0.6, 0.4} : MeshFriction{};
    std::shared_ptr<const MeshHierarchy> h =
        torus_mesh ? big_hierarchy() : MeshHierarchy::build(box({0.08, 0.08, 0.02}, 1), MeshMode::solid);
    std::vector<Eigen::Vector3d> path;
    if (torus_mesh) {
        path = contact_path(20000, 5e-4);
    } else {  // the box's top face, 2 mm deep, a circle of 5 cm
        for (int k = 0; k < 20000; ++k) {
            const double a = 5e-4 * k / 0.025;
            path.emplace_back(0.025 * std::cos(a), 0.025 * std::sin(a), k < 20 ? 0.03 - 0.0012 * k : 0.018);
        }
    }
    GodObjectProxy proxy(h, friction);
    proxy.reset(path.front());
    std::vector<std::int64_t> ns;
    ns.reserve(1 << 22);
    std::size_t i = 0, contacts = 0, sweeps = 0;
    for (auto _ : state) {
        const Eigen::Vector3d& handle = path[i++ % path.size()];
        if (i % path.size() == 0) proxy.reset(path.front());
        const std::int64_t t0 = now_ns();
        const ProxyContact& c = proxy.step(handle);
        const std::int64_t t1 = now_ns();
        if (ns.size() < ns.capacity()) ns.push_back(t1 - t0);
        contacts += c.constraints > 0 ? 1 : 0;
        sweeps += static_cast<std::size_t>(c.sweeps);
    }
    state.counters["triangles"] = static_cast<double>(h->triangles().size());
    state.counters["contact_fraction"] = static_cast<double>(contacts) / static_cast<double>(state.iterations());
    state.counters["sweeps_per_step"] = static_cast<double>(sweeps) / static_cast<double>(state.iterations());
    report_percentiles(state, ns);
}
BENCHMARK(BM_ProxyStepContact)->Args({0, 0})->Args({0, 1})->Args({1, 0})->Args({1, 1});

// 10 mm a tick through the torus' tube and out again (across the tube, 4 cm each way).
void BM_ProxyStepFast(benchmark::State& state) {
    GodObjectProxy proxy(big_hierarchy(), {});
    std::vector<Eigen::Vector3d> path;
    for (int k = 0; k <= 8; ++k) path.push_back(on_torus(0.3, -0.02 + 0.005 * k));
    for (int k = 8; k >= 0; --k) path.push_back(on_torus(0.3, -0.02 + 0.005 * k));
    proxy.reset(path.front());
    std::vector<std::int64_t> ns;
    ns.reserve(1 << 22);
    std::size_t i = 0;
    for (auto _ : state) {
        const std::int64_t t0 = now_ns();
        benchmark::DoNotOptimize(proxy.step(path[i++ % path.size()]));
        const std::int64_t t1 = now_ns();
        if (ns.size() < ns.capacity()) ns.push_back(t1 - t0);
    }
    report_percentiles(state, ns);
}
BENCHMARK(BM_ProxyStepFast);

void BM_TickMeshContact(benchmark::State& state) {
    using namespace hapticd;
    const bool with_mesh = state.range(0) != 1;
    std::shared_ptr<const MeshHierarchy> h = big_hierarchy();
    CommitRing ring(8);
    SceneObjectsConfig config;
    config.period = 1e-3;
    config.ramp_time = 0.0;
    config.axes = 3;
    SceneObjects objects(config, ring);
    ObjectParams p;
    p.id = 1;
    p.K = 2000.0;
    p.B = 5.0;
    const std::vector<Eigen::Vector3d> path = contact_path(20000, 5e-4);
    if (with_mesh) {
        p.kind = ObjectKind::Mesh;
        p.mesh = h.get();
        if (state.range(0) == 2) {
            p.shading = h->shading(30.0);
            p.crease_angle_deg = 30.0;
        }
    } else {  // the plane x = 0.078 with normal +x (solid for x < 0.078): 1 cm out for 20 ticks, then 2 mm in, along y,
              // z
        p.kind = ObjectKind::Plane;
        p.direction = {1.0, 0.0, 0.0};
        p.offset = 0.078;
    }
    ObjectCommit add;
    add.seq = 1;
    add.updates[add.count++] = SlotUpdate{0, SlotUpdate::Action::Set, p};
    ring.try_push(add);
    struct LawForce {
        AxisVector force{};
        LawChange change{};
    };
    DelayRing<LawForce> delay(6);
    ForceLimiter limiter(10.0, default_max_force_rate(10.0, 1e-3), 1e-3, 3);
    std::vector<std::int64_t> ns;
    ns.reserve(1 << 22);
    std::size_t i = 0, contacts = 0;
    for (auto _ : state) {
        const Eigen::Vector3d& e = path[i++ % path.size()];
        const bool pressed = i % path.size() > 20;
        const AxisVector x =
            with_mesh ? AxisVector{e.x(), e.y(), e.z()} : AxisVector{pressed ? 0.076 : 0.088, e.y(), e.z()};
        const std::int64_t t0 = now_ns();
        objects.apply_commits();
        AxisVector f{};
        const bool finite = objects.add_forces(x, f);
        const LawForce out = delay.push_pop(LawForce{finite ? f : AxisVector{}, objects.law_change()});
        benchmark::DoNotOptimize(limiter.step(out.force, out.change));
        const std::int64_t t1 = now_ns();
        if (ns.size() < ns.capacity()) ns.push_back(t1 - t0);
        contacts += objects.contact_mask() != 0 ? 1 : 0;
    }
    state.counters["contact_fraction"] = static_cast<double>(contacts) / static_cast<double>(state.iterations());
    report_percentiles(state, ns);
}
BENCHMARK(BM_TickMeshContact)->Arg(0)->Arg(1)->Arg(2);

}  // namespace
