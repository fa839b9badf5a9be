// SPDX-License-Identifier: Apache-2.0
// The state's mesh proxies (docs/protocol.md, section 6; include/hapticd/state_layout.hpp), in process: the loop's
// object slots (scene/scene_objects.hpp) with mesh objects rendered through their god-object proxies, published by
// the real StatePublisher and read back under its seqlock. Checked against the definition: the first 7 slots that
// render a mesh, in slot order; the proxy in the device frame, p + R c; nothing for the slots of other kinds; the
// entries beyond the count zero. And the protocol's table of the layout against the struct's offsets.
#include <gtest/gtest.h>

#include <fcntl.h>
#include <sys/mman.h>
#include <unistd.h>

#include <cmath>
#include <cstring>
#include <fstream>
#include <map>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

#include "common/test_paths.hpp"
#include "mesh/mesh_hierarchy.hpp"
#include "mesh/procedural_meshes.hpp"
#include "scene/scene_objects.hpp"
#include "server/state_publisher.hpp"

namespace hapticd::state_mesh_proxies_test {

struct ProxyRig {
    CommitRing commits{8};
    SceneObjects objects;
    StatePublisher publisher;
    std::shared_ptr<const mesh::MeshHierarchy> cube;  // [-1 cm, 1 cm]^3
    std::uint64_t tick = 0;
    std::uint64_t seq = 0;
    ProxyRig()
        : objects(config(), commits),
          publisher("/hapticd-test-meshproxy-" + std::to_string(::getpid()), 3, 1e-3, -1),
          cube(mesh::MeshHierarchy::build(mesh::box(Eigen::Vector3d(0.01, 0.01, 0.01)), mesh::MeshMode::solid)) {}
    static SceneObjectsConfig config() {
        SceneObjectsConfig c;
        c.period = 1e-3;
        c.ramp_time = 0.005;  // 5 ticks
        c.axes = 3;
        return c;
    }
    ObjectParams mesh_at(std::uint32_t id, const AxisVector& centre, const std::array<double, 4>& q) const {
        ObjectParams p;
        p.id = id;
        p.kind = ObjectKind::Mesh;
        p.mesh = cube.get();
        p.mesh_id = 1;
        p.point = centre;
        p.orientation = q;
        p.K = 100.0;
        p.B = 0.5;
        return p;
    }
    void commit(const std::vector<SlotUpdate>& updates) {
        ObjectCommit c;
        c.seq = ++seq;
        for (const auto& u : updates) c.updates[c.count++] = u;
        ASSERT_TRUE(commits.try_push(c));
    }
    // One loop tick at handle position x (Daemon::tick's order: commits, forces, publication); the published state.
    void step(const AxisVector& x, StateLayout& out) {
        objects.apply_commits();
        StateTick st;
        st.tick = tick++;
        st.position = x;
        EXPECT_TRUE(objects.add_forces(x, st.force));
        publisher.publish(st, &objects);
        EXPECT_TRUE(publisher.read(out));
    }
};

SlotUpdate set(std::size_t slot, const ObjectParams& p) {
    return SlotUpdate{static_cast<std::uint8_t>(slot), SlotUpdate::Action::Set, p};
}
SlotUpdate cut(std::size_t slot) { return SlotUpdate{static_cast<std::uint8_t>(slot), SlotUpdate::Action::Cut, {}}; }

bool all_zero(const StateMeshProxy& e) {
    StateMeshProxy zero{};
    std::memset(&zero, 0, sizeof(zero));
    return std::memcmp(&e, &zero, sizeof(zero)) == 0;
}

TEST(StateMeshProxies, TheFirstSevenMeshSlotsInSlotOrderFreeProxiesAtTheHandleAndNothingForOtherKinds) {
    ProxyRig rig;
    ObjectParams plane;
    plane.id = 100;
    plane.kind = ObjectKind::Plane;
    plane.direction = {1.0, 0.0, 0.0};
    plane.offset = -0.05;  // far: no contact
    plane.K = 100.0;
    plane.B = 0.5;
    // Slot 0 a plane, slot 10 a plane; nine meshes in slots 1..9, each 10 cm from the handle (free).
    std::vector<SlotUpdate> updates{set(0, plane)};
    for (std::size_t s = 1; s <= 9; ++s) {
        updates.push_back(set(s, rig.mesh_at(static_cast<std::uint32_t>(s), {0.1, 0.02 * static_cast<double>(s), 0.0},
                                             {1.0, 0.0, 0.0, 0.0})));
    }
    plane.id = 101;
    updates.push_back(set(10, plane));
    const AxisVector x{0.001, -0.002, 0.003};
    // Before any object: nothing.
    StateLayout l{};
    rig.step(x, l);
    EXPECT_EQ(l.mesh_slot_mask, 0U);
    EXPECT_EQ(l.mesh_proxies, 0U);
    rig.commit(updates);
    for (int i = 0; i < 10; ++i) rig.step(x, l);
    EXPECT_EQ(l.mesh_slot_mask, 0x3FEU);  // slots 1..9: all nine meshes, the two planes not
    ASSERT_EQ(l.mesh_proxies, kStateMeshProxyCapacity);
    for (std::size_t i = 0; i < kStateMeshProxyCapacity; ++i) {
        const StateMeshProxy& e = l.mesh_proxy[i];
        EXPECT_EQ(e.slot, i + 1) << i;
        EXPECT_EQ(e.object_id, i + 1) << i;
        EXPECT_EQ(e.constraints, 0) << i;
        EXPECT_EQ(e.triangle, 0xFFFFFFFFU) << i;
        EXPECT_EQ(e.flags, 0) << i;
        // Free: the proxy is the handle, taken into the mesh frame and back (x - p + p: rounding of |p| ~ 0.2 m,
        // a few 1e-17 m; 1e-15 m is 20 times that).
        for (std::size_t a = 0; a < 3; ++a) EXPECT_NEAR(e.proxy[a], x[a], 1e-15) << i << " axis " << a;
    }
    // Slots 1..5 cut: four meshes left (slots 6..9), the entries beyond them zero.
    rig.commit({cut(1), cut(2), cut(3), cut(4), cut(5)});
    rig.step(x, l);
    EXPECT_EQ(l.mesh_slot_mask, 0x3C0U);
    ASSERT_EQ(l.mesh_proxies, 4U);
    for (std::size_t i = 0; i < 4; ++i) EXPECT_EQ(l.mesh_proxy[i].slot, i + 6);
    // The segment itself beyond the count (read() copies only the count's entries), as a reader maps it: zeros.
    {
        const int fd = ::shm_open(rig.publisher.name().c_str(), O_RDONLY, 0);
        ASSERT_GE(fd, 0);
        void* p = ::mmap(nullptr, sizeof(StateLayout), PROT_READ, MAP_SHARED, fd, 0);
        ::close(fd);
        ASSERT_NE(p, MAP_FAILED);
        const auto* segment = static_cast<const StateLayout*>(p);
        EXPECT_EQ(segment->mesh_proxy_capacity, kStateMeshProxyCapacity);
        for (std::size_t i = 4; i < kStateMeshProxyCapacity; ++i) EXPECT_TRUE(all_zero(segment->mesh_proxy[i])) << i;
        EXPECT_EQ(segment->mesh_proxy[3].slot, 9);
        ::munmap(p, sizeof(StateLayout));
    }
    // Every mesh cut: no mask, no entries.
    rig.commit({cut(6), cut(7), cut(8), cut(9)});
    rig.step(x, l);
    EXPECT_EQ(l.mesh_slot_mask, 0U);
    EXPECT_EQ(l.mesh_proxies, 0U);
    EXPECT_EQ(l.objects, 2U);  // the planes stay
}

// A mesh rotated about x (its +z face's outward normal n = (0, 0.6, 0.8)) with the handle pressed 0.5 mm behind that
// face: the proxy lies on the face's plane moved out by the 1 um offset, it is the handle's projection there (no
// friction), the normal published is n, and the slot's contact bit is set with constraints 1.
TEST(StateMeshProxies, APressedFaceGivesTheProxyOnItsOffsetPlaneAndTheHandleBehind) {
    ProxyRig rig;
    const double a = 0.01;
    const double theta = std::atan2(-0.6, 0.8);  // R_x(theta) e_z = (0, 0.6, 0.8)
    const std::array<double, 4> q{std::cos(theta / 2), std::sin(theta / 2), 0.0, 0.0};
    const AxisVector n{0.0, 0.6, 0.8};
    const AxisVector centre{0.002, -0.6 * a, -0.8 * a};  // the +z face's plane through the origin: n.x = 0
    rig.commit({set(3, rig.mesh_at(42, centre, q))});
    // The handle approaches from outside along -n, then sits 0.5 mm behind the face, 1 mm off its centre.
    AxisVector x{};
    StateLayout l{};
    for (int i = 0; i <= 20; ++i) {
        const double depth = 0.001 - 0.0015 * i / 20.0;  // n.x from +1 mm to -0.5 mm
        x = {0.001, depth * n[1], depth * n[2]};
        rig.step(x, l);
    }
    rig.step(x, l);
    EXPECT_EQ(l.mesh_slot_mask, 1U << 3);
    ASSERT_EQ(l.mesh_proxies, 1U);
    const StateMeshProxy& e = l.mesh_proxy[0];
    EXPECT_EQ(e.slot, 3);
    EXPECT_EQ(e.object_id, 42U);
    EXPECT_EQ(e.constraints, 1);
    EXPECT_TRUE(e.triangle == 10U || e.triangle == 11U) << e.triangle;  // the +z face of mesh::box(.., 1)
    EXPECT_NE((l.contact_mask >> 3) & 1U, 0U);
    const double on = n[0] * e.proxy[0] + n[1] * e.proxy[1] + n[2] * e.proxy[2];
    // On the face's plane (n.x = 0) moved out by kSurfaceOffset (1 um); the proxy's geometry works to 1e-12 m
    // (mesh_hierarchy.hpp), ten times that allowed.
    EXPECT_NEAR(on, mesh::kSurfaceOffset, 1e-11);
    const double handle = n[0] * x[0] + n[1] * x[1] + n[2] * x[2];
    EXPECT_NEAR(handle, -0.0005, 1e-15);
    EXPECT_LT(handle, on);  // the handle is behind the proxy
    // Frictionless: proxy - handle along n (its tangential part within the geometry's 1e-12 m).
    AxisVector d{e.proxy[0] - x[0], e.proxy[1] - x[1], e.proxy[2] - x[2]};
    const double along = n[0] * d[0] + n[1] * d[1] + n[2] * d[2];
    for (std::size_t k = 0; k < 3; ++k) EXPECT_NEAR(d[k] - along * n[k], 0.0, 1e-11) << k;
    // The normal in the device frame, stored as float (a unit vector to 6e-8).
    for (std::size_t k = 0; k < 3; ++k) EXPECT_NEAR(e.normal[0][k], n[k], 1e-6) << k;
    for (std::size_t k = 0; k < 3; ++k) EXPECT_EQ(e.normal[1][k], 0.0F);
}

// docs/protocol.md, section 6: every row of the layout's table and of the mesh proxy's table names its field at
// the struct's offset (a field moved, or a row edited wrongly, fails here).
std::vector<std::pair<std::size_t, std::string>> table_rows(const std::string& text, const std::string& after) {
    std::vector<std::pair<std::size_t, std::string>> rows;
    std::size_t at = text.find(after);
    if (at == std::string::npos) return rows;
    at = text.find("| offset |", at);
    if (at == std::string::npos) return rows;
    std::istringstream in(text.substr(at));
    std::string line;
    std::getline(in, line);  // header
    std::getline(in, line);  // |---|
    while (std::getline(in, line) && line.rfind("| ", 0) == 0) {
        std::size_t offset = 0;
        if (std::sscanf(line.c_str(), "| %zu |", &offset) != 1) continue;
        const std::size_t tick = line.find('`');
        const std::size_t end = tick == std::string::npos ? std::string::npos : line.find('`', tick + 1);
        if (end == std::string::npos) continue;
        rows.emplace_back(offset, line.substr(tick + 1, end - tick - 1));
    }
    return rows;
}

TEST(StateLayoutDoc, TheProtocolTablesGiveEachFieldTheStructsOffset) {
    std::ifstream f(HAPTICD_SOURCE_DIR + "/docs/protocol.md");
    ASSERT_TRUE(f.good());
    std::stringstream buffer;
    buffer << f.rdbuf();
    const std::string text = buffer.str();
    const std::map<std::string, std::size_t> layout{
        {"magic", offsetof(StateLayout, magic)},
        {"layout_version", offsetof(StateLayout, layout_version)},
        {"size", offsetof(StateLayout, size)},
        {"axes", offsetof(StateLayout, axes)},
        {"period_s", offsetof(StateLayout, period_s)},
        {"capacity", offsetof(StateLayout, capacity)},
        {"writer_pid", offsetof(StateLayout, writer_pid)},
        {"mesh_proxy_capacity", offsetof(StateLayout, mesh_proxy_capacity)},
        {"sequence", offsetof(StateLayout, sequence)},
        {"tick", offsetof(StateLayout, tick)},
        {"time_s", offsetof(StateLayout, time_s)},
        {"position", offsetof(StateLayout, position)},
        {"velocity", offsetof(StateLayout, velocity)},
        {"force", offsetof(StateLayout, force)},
        {"contact_mask", offsetof(StateLayout, contact_mask)},
        {"overruns", offsetof(StateLayout, overruns)},
        {"wake_latency_ns", offsetof(StateLayout, wake_latency_ns)},
        {"last_commit_seq", offsetof(StateLayout, last_commit_seq)},
        {"fault", offsetof(StateLayout, fault)},
        {"objects", offsetof(StateLayout, objects)},
        {"slot_object_id", offsetof(StateLayout, slot_object_id)},
        {"slot_ramp", offsetof(StateLayout, slot_ramp)},
        {"heartbeat_ns", offsetof(StateLayout, heartbeat_ns)},
        {"fatal_signal", offsetof(StateLayout, fatal_signal)},
        {"config_contact_mask", offsetof(StateLayout, config_contact_mask)},
        {"mesh_slot_mask", offsetof(StateLayout, mesh_slot_mask)},
        {"mesh_proxies", offsetof(StateLayout, mesh_proxies)},
        {"mesh_proxy", offsetof(StateLayout, mesh_proxy)},
    };
    const auto rows = table_rows(text, "### Shared memory");
    std::map<std::string, std::size_t> documented;
    for (const auto& [offset, name] : rows) documented[name] = offset;
    for (const auto& [name, offset] : layout) {
        ASSERT_TRUE(documented.count(name)) << "docs/protocol.md, section 6: no row for `" << name << "`";
        EXPECT_EQ(documented[name], offset) << "`" << name << "`";
    }
    EXPECT_EQ(documented.size(), layout.size()) << "a documented field the test does not know";
    const std::map<std::string, std::size_t> entry{
        {"proxy", offsetof(StateMeshProxy, proxy)},
        {"normal", offsetof(StateMeshProxy, normal)},
        {"triangle", offsetof(StateMeshProxy, triangle)},
        {"slot", offsetof(StateMeshProxy, slot)},
        {"constraints", offsetof(StateMeshProxy, constraints)},
        {"flags", offsetof(StateMeshProxy, flags)},
        {"object_id", offsetof(StateMeshProxy, object_id)},
    };
    std::map<std::string, std::size_t> entry_rows;
    for (const auto& [offset, name] : table_rows(text, "Each `mesh_proxy[i]`")) entry_rows[name] = offset;
    for (const auto& [name, offset] : entry) {
        ASSERT_TRUE(entry_rows.count(name)) << "docs/protocol.md, section 6: no mesh_proxy row for `" << name << "`";
        EXPECT_EQ(entry_rows[name], offset) << "`" << name << "`";
    }
    EXPECT_EQ(entry_rows.size(), entry.size());
    EXPECT_NE(
        text.find("| 8 | uint32 | `size` of the whole struct in bytes (" + std::to_string(sizeof(StateLayout)) + ")"),
        std::string::npos);
    EXPECT_NE(text.find("`layout_version` = " + std::to_string(kStateLayoutVersion) + " |"), std::string::npos);
}

}  // namespace hapticd::state_mesh_proxies_test
