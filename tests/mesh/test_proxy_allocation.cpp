// SPDX-License-Identifier: Apache-2.0
// GodObjectProxy::step and reset allocate nothing (the tick's rule, docs/architecture.md): this executable replaces
// the global operator new and delete with counting ones (tests/common/counting_allocator.hpp) and counts
// the calls during proxy steps on a 20 480-triangle bumpy sphere, a box and a one-sided height field, with and
// without friction, in free space, in contact, at edges and vertices and through fast moves.
#include <gtest/gtest.h>

#include <atomic>
#include <cmath>
#include <cstdlib>
#include <new>
#include <random>

#include "common/counting_allocator.hpp"
#include "mesh/god_object_proxy.hpp"
#include "mesh/procedural_meshes.hpp"
#include "mesh_reference.hpp"

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
            test::start_counting();
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
            const test::AllocationCounts counted = test::stop_counting();
            EXPECT_EQ(counted.allocations, 0u);
            EXPECT_EQ(counted.releases, 0u);
        }
    }
    EXPECT_GT(steps, 10000u);
    EXPECT_GT(contacts, 2000);
}

// The counter counts: a vector's growth on the counting thread is seen (the test above can fail).
TEST(ProxyAllocation, TheCounterSeesAnAllocation) {
    test::start_counting();
    static std::vector<int>* volatile sink = nullptr;  // escapes: the compiler may not elide the new/delete pair
    sink = new std::vector<int>(100);
    delete sink;
    const test::AllocationCounts counted = test::stop_counting();
    EXPECT_EQ(counted.allocations, 2u);
    EXPECT_EQ(counted.releases, 2u);
}

}  // namespace
}  // namespace hapticd::mesh
