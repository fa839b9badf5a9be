// SPDX-License-Identifier: Apache-2.0
// MeshHierarchy::sweep against brute force over every triangle with barycentric coordinates (the same hit rule,
// written independently): random segments near random meshes, segments through shared edges and vertices; the
// tree's structure (every triangle in exactly one leaf, boxes holding their triangles, the depth bound).
#include <gtest/gtest.h>

#include <algorithm>
#include <random>
#include <vector>

#include "mesh/mesh_hierarchy.hpp"
#include "mesh_reference.hpp"

namespace hapticd::mesh {
namespace {

namespace ref = reference;

// The hit rule of mesh_hierarchy.hpp by brute force: smallest allowed fraction over the faces met, or 2.
struct BruteHit {
    double fraction = 2.0;
    int face = -1;
};
BruteHit brute_sweep(const std::vector<ref::Face>& f, const Eigen::Vector3d& p, const Eigen::Vector3d& q,
                     double offset) {
    BruteHit best;
    const Eigen::Vector3d d = q - p;
    for (int i = 0; i < static_cast<int>(f.size()); ++i) {
        const double sp = f[i].normal.dot(p - f[i].a), st = f[i].normal.dot(q - f[i].a);
        if (!(st - sp < -1e-12 * d.norm()) || sp < -offset / 2 || !(st < offset - 1e-12)) continue;
        const Eigen::Vector3d x = sp < 0   ? Eigen::Vector3d(p - sp * f[i].normal)
                                  : st < 0 ? Eigen::Vector3d(p + sp / (sp - st) * d)
                                           : Eigen::Vector3d(q - st * f[i].normal);
        const Eigen::Vector3d bc = ref::barycentric(f[i], x);
        if (bc.minCoeff() < 0.0) continue;  // strictly inside: the tolerance band is compared apart
        const double along = (x - p).norm(), reach = MeshHierarchy::kRestingReach;
        const double s = sp >= offset ? (sp - offset) / (sp - st) : along <= reach ? 0.0 : (along - reach) / d.norm();
        if (s < best.fraction) best = {s, i};
    }
    return best;
}

TEST(MeshHierarchy, StructureHoldsEveryTriangleOnce) {
    std::mt19937_64 rng(7);
    const TriangleMesh m = ref::bumpy_sphere(0.05, 5, 0.2, rng);  // 20480 triangles
    const auto h = MeshHierarchy::build(m, MeshMode::solid);
    std::vector<int> seen(m.triangles.size(), 0);
    for (const auto& node : h->nodes()) {
        if (node.count == 0) continue;
        EXPECT_LE(node.count, MeshHierarchy::kLeafSize);
        for (std::uint32_t i = node.first; i < node.first + node.count; ++i) {
            const auto& t = h->triangles()[i];
            ++seen[t.index];
            for (const std::uint32_t vi : m.triangles[t.index]) {
                const Eigen::Vector3d& v = m.vertices[vi];
                EXPECT_TRUE((v.array() >= node.lower.array()).all() && (v.array() <= node.upper.array()).all());
            }
        }
    }
    EXPECT_TRUE(std::all_of(seen.begin(), seen.end(), [](int n) { return n == 1; }));
    // Median split: depth ceil(log2(20480 / 4)) + 1 = 14 (+1 for uneven halves).
    EXPECT_LE(h->depth(), 15u);
    EXPECT_GT(h->memory_bytes(), m.triangles.size() * sizeof(HierarchyTriangle));
}

TEST(MeshHierarchy, SweepEqualsBruteForceOnRandomSegments) {
    std::mt19937_64 rng(11);
    int hits = 0, misses = 0;
    for (int mesh_index = 0; mesh_index < 4; ++mesh_index) {
        const TriangleMesh m =
            mesh_index % 2 == 0 ? ref::bumpy_sphere(0.05, 3, 0.25, rng) : ref::height_field(0.05, 20, 0.01, rng);
        const auto f = ref::faces(m);
        const auto h = MeshHierarchy::build(m, mesh_index % 2 == 0 ? MeshMode::solid : MeshMode::surface);
        std::uniform_real_distribution<double> u(-0.07, 0.07), len(0.0, 0.06);
        for (int k = 0; k < 5000; ++k) {
            const Eigen::Vector3d p(u(rng), u(rng), u(rng));
            const Eigen::Vector3d q = p + len(rng) * Eigen::Vector3d::Random().normalized();
            const BruteHit b = brute_sweep(f, p, q, kSurfaceOffset);
            const SweepHit s = h->sweep(p, q);
            if (b.face < 0) {
                // No face met strictly inside: the tree's 1e-9 m band around the edges could add one, with a
                // chance of about 1e-9 m / 1 mm per segment here, so none is expected.
                EXPECT_FALSE(s.hit()) << "segment " << k << " of mesh " << mesh_index;
                ++misses;
                continue;
            }
            ++hits;
            ASSERT_TRUE(s.hit()) << "segment " << k << " of mesh " << mesh_index;
            EXPECT_NEAR(s.fraction, b.fraction, 1e-12) << "segment " << k << " of mesh " << mesh_index;
            EXPECT_LE(s.fraction, b.fraction + 1e-12);
            EXPECT_NEAR(s.normal.dot(f[b.face].normal), 1.0,
                        s.triangle == static_cast<std::uint32_t>(b.face) ? 1e-12 : 2.0);
        }
    }
    EXPECT_GT(hits, 1000);
    EXPECT_GT(misses, 1000);
}

TEST(MeshHierarchy, SegmentsThroughSharedEdgesAndVerticesAreMet) {
    // A segment aimed exactly at a vertex or an edge's midpoint from outside meets the surface: rounding must not
    // let it slip between the triangles that share it.
    const TriangleMesh m = icosphere(0.05, 3);
    const auto h = MeshHierarchy::build(m, MeshMode::solid);
    int tested = 0;
    for (const auto& t : m.triangles) {
        for (int k = 0; k < 3; ++k) {
            const Eigen::Vector3d& a = m.vertices[t[k]];
            const Eigen::Vector3d mid = 0.5 * (a + m.vertices[t[(k + 1) % 3]]);
            for (const Eigen::Vector3d& target : {a, mid}) {
                // From outside, at a grazing tilt and straight in, through the target to inside.
                for (const Eigen::Vector3d& from :
                     {Eigen::Vector3d(target * 1.2),
                      Eigen::Vector3d(target * 1.02 + 0.3 * target.norm() * target.unitOrthogonal())}) {
                    const Eigen::Vector3d to = target + 0.5 * (target - from);
                    const SweepHit s = h->sweep(from, to);
                    ASSERT_TRUE(s.hit()) << "through " << target.transpose();
                    EXPECT_LT(s.fraction, 2.0 / 3.0);
                    ++tested;
                }
            }
        }
    }
    EXPECT_EQ(tested, static_cast<int>(m.triangles.size()) * 12);
}

TEST(MeshHierarchy, BackFacesAndParallelSegmentsAreFree) {
    const TriangleMesh m = box({0.02, 0.02, 0.02}, 2);
    const auto h = MeshHierarchy::build(m, MeshMode::solid);
    // From inside out through a face: the face is met from behind, which a proxy passes.
    EXPECT_FALSE(h->sweep({0, 0, 0}, {0, 0, 0.05}).hit());
    // Sliding on the offset level above the top face: not met.
    const double z = 0.02 + kSurfaceOffset;
    EXPECT_FALSE(h->sweep({-0.01, 0, z}, {0.015, 0.007, z}).hit());
    // Into the top face from above: stopped kSurfaceOffset above it.
    const SweepHit s = h->sweep({0.001, 0.002, 0.03}, {0.001, 0.002, 0.0});
    ASSERT_TRUE(s.hit());
    EXPECT_NEAR(0.03 + s.fraction * (0.0 - 0.03), 0.02 + kSurfaceOffset, 1e-15);
    EXPECT_NEAR(s.normal.z(), 1.0, 1e-15);
}

}  // namespace
}  // namespace hapticd::mesh
