// SPDX-License-Identifier: Apache-2.0
// GodObjectProxy::step and reset allocate nothing (the tick's rule, docs/architecture.md): this executable replaces
// the global operator new and delete with counting ones (as tests/daemon/test_tick_allocation.cpp does) and counts
// the calls during proxy steps on a 20 480-triangle bumpy sphere, a box and a one-sided height field, with and
// without friction, in free space, in contact, at edges and vertices and through fast moves.
#include <gtest/gtest.h>

#include <atomic>
#include <cmath>
#include <cstdlib>
#include <new>
#include <random>

#include "mesh/god_object_proxy.hpp"
#include "mesh/procedural_meshes.hpp"
#include "mesh_reference.hpp"

namespace {
thread_local bool t_counting = false;
std::atomic<std::uint64_t> g_allocations{0};
std::atomic<std::uint64_t> g_releases{0};

void* counted_alloc(std::size_t size, std::size_t align = 0) {
    if (t_counting) g_allocations.fetch_add(1, std::memory_order_relaxed);
    if (size == 0) size = 1;
    return align > alignof(std::max_align_t) ? std::aligned_alloc(align, (size + align - 1) / align * align)
                                             : std::malloc(size);
}
void counted_free(void* p) noexcept {
    if (p == nullptr) return;
    if (t_counting) g_releases.fetch_add(1, std::memory_order_relaxed);
    std::free(p);
}
}  // namespace

void* operator new(std::size_t size) {
    void* p = counted_alloc(size);
    if (p == nullptr) throw std::bad_alloc();
    return p;
}
void* operator new[](std::size_t size) {
    void* p = counted_alloc(size);
    if (p == nullptr) throw std::bad_alloc();
    return p;
}
void* operator new(std::size_t size, const std::nothrow_t&) noexcept { return counted_alloc(size); }
void* operator new[](std::size_t size, const std::nothrow_t&) noexcept { return counted_alloc(size); }
void* operator new(std::size_t size, std::align_val_t align) {
    void* p = counted_alloc(size, static_cast<std::size_t>(align));
    if (p == nullptr) throw std::bad_alloc();
    return p;
}
void* operator new[](std::size_t size, std::align_val_t align) {
    void* p = counted_alloc(size, static_cast<std::size_t>(align));
    if (p == nullptr) throw std::bad_alloc();
    return p;
}
void operator delete(void* p) noexcept { counted_free(p); }
void operator delete[](void* p) noexcept { counted_free(p); }
void operator delete(void* p, std::size_t) noexcept { counted_free(p); }
void operator delete[](void* p, std::size_t) noexcept { counted_free(p); }
void operator delete(void* p, std::align_val_t) noexcept { counted_free(p); }
void operator delete[](void* p, std::align_val_t) noexcept { counted_free(p); }
void operator delete(void* p, std::size_t, std::align_val_t) noexcept { counted_free(p); }
void operator delete[](void* p, std::size_t, std::align_val_t) noexcept { counted_free(p); }

namespace hapticd::mesh {
namespace {

TEST(ProxyAllocation, StepAndResetAllocateNothing) {
    std::mt19937_64 rng(1);
    const TriangleMesh meshes[] = {reference::bumpy_sphere(0.05, 5, 0.1, rng), box({0.04, 0.03, 0.05}, 8),
                                   reference::height_field(0.05, 40, 0.005, rng)};
    std::uint64_t steps = 0;
    int contacts = 0;
    for (const TriangleMesh& m : meshes) {
        for (const MeshFriction friction : {MeshFriction{}, MeshFriction{0.7, 0.4}}) {
            GodObjectProxy proxy(MeshHierarchy::build(m, MeshMode::surface), friction);
            std::uniform_real_distribution<double> u(-1.0, 1.0);
            // Waypoints chosen before counting; the handle visits them at 0.5 and 10 mm a tick.
            std::vector<Eigen::Vector3d> waypoints;
            for (int k = 0; k < 60; ++k) waypoints.push_back(0.06 * Eigen::Vector3d(u(rng), u(rng), u(rng)));
            g_allocations = 0;
            g_releases = 0;
            t_counting = true;
            proxy.reset({0, 0, 0.2});
            Eigen::Vector3d handle(0, 0, 0.2);
            for (std::size_t k = 0; k < waypoints.size(); ++k) {
                const double speed = k % 3 == 0 ? 1e-2 : 5e-4;
                const int n = static_cast<int>((waypoints[k] - handle).norm() / speed) + 1;
                const Eigen::Vector3d from = handle;
                for (int j = 1; j <= n; ++j) {
                    handle = from + (waypoints[k] - from) * (static_cast<double>(j) / n);
                    contacts += proxy.step(handle).constraints > 0 ? 1 : 0;
                    ++steps;
                }
            }
            proxy.reset(handle);
            t_counting = false;
            EXPECT_EQ(g_allocations.load(), 0u);
            EXPECT_EQ(g_releases.load(), 0u);
        }
    }
    EXPECT_GT(steps, 10000u);
    EXPECT_GT(contacts, 2000);
}

// The counter counts: a vector's growth on the counting thread is seen (the test above can fail).
TEST(ProxyAllocation, TheCounterSeesAnAllocation) {
    g_allocations = 0;
    t_counting = true;
    std::vector<int>* v = new std::vector<int>(100);
    delete v;
    t_counting = false;
    EXPECT_EQ(g_allocations.load(), 2u);
}

}  // namespace
}  // namespace hapticd::mesh
