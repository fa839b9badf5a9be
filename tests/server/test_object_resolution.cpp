// SPDX-License-Identifier: Apache-2.0
// Object resolution (server/object_resolution.hpp) without a socket: each kind's checks in order (axes,
// unit vectors, workspace, gains, limits, stability) with the protocol's codes and messages naming the field
// (docs/protocol.md, sections 5 and 8); the matrices the summed checks add (K n n^T for a plane, K (I - d d^T)
// for a line spring); and ids to slots (unknown_object, not_owner). Device: 0.3 kg per axis, T = 1 ms, a
// delay of one period, workspace +-0.06 m.
#include <string>
#include <variant>

#include <gtest/gtest.h>

#include "mesh/procedural_meshes.hpp"
#include "resolution_device.hpp"
#include "server/object_resolution.hpp"

namespace hapticd::server {
namespace object_resolution_test {

namespace cl = hapticd::client;
using cl::ErrorCode;

using resolution_device::kMass;
using resolution_device::kT;

struct Device {
    explicit Device(std::size_t axes, std::optional<double> max_stiffness = std::nullopt)
        : config(resolution_device::config(axes)),
          checker(resolution_device::plant(axes, max_stiffness)),
          resolver(config, checker) {}

    std::optional<Refusal> resolve(const cl::ObjectDescription& d) { return resolver.resolve(d, last); }

    ServerConfig config;
    GainChecker checker;
    ObjectResolver resolver;
    Resolved last;
};

cl::Plane plane(cl::Vec3 n, double offset, cl::Gains gains) {
    return cl::Plane{.normal = n, .offset = offset, .bilateral = false, .gains = gains};
}

void expect_refusal(const std::optional<Refusal>& r, ErrorCode code, const std::string& start) {
    ASSERT_TRUE(r) << "expected " << cl::to_string(code);
    EXPECT_EQ(r->code, code) << r->message;
    EXPECT_EQ(r->message.rfind(start, 0), 0U) << r->message;
}

TEST(ObjectResolution, APlanesVectorsAreCheckedAgainstTheDevice) {
    Device three(3);
    expect_refusal(three.resolve(plane({0, 0, 2}, 0.0, cl::Gains::explicit_gains(100, 1))), ErrorCode::BadMessage,
                   "plane.normal: length 2");
    expect_refusal(three.resolve(plane({0, 0, -1}, 0.5, cl::Gains::explicit_gains(100, 1))),
                   ErrorCode::BeyondDeviceLimits, "plane.offset = 0.5");
    Device one(1);
    expect_refusal(one.resolve(plane({0, 1, 0}, 0.0, cl::Gains::explicit_gains(100, 1))), ErrorCode::BadMessage,
                   "plane.normal[1] = 1 is invalid: the device has 1 axes");
}

TEST(ObjectResolution, APlaneRendersKAndBAlongItsNormal) {
    Device d(3);
    const double s = 1.0 / std::sqrt(2.0);
    ASSERT_FALSE(d.resolve(plane({s, 0, -s}, -0.01, cl::Gains::explicit_gains(300, 2))));
    const ObjectParams& p = d.last.params;
    EXPECT_EQ(p.kind, ObjectKind::Plane);
    EXPECT_EQ(p.K, 300.0);
    EXPECT_EQ(p.B, 2.0);
    EXPECT_EQ(p.offset, -0.01);
    EXPECT_EQ(p.id, 0U);
    const std::array<double, 3> n{s, 0, -s};
    for (std::size_t i = 0; i < 3; ++i) {
        for (std::size_t j = 0; j < 3; ++j) {
            EXPECT_DOUBLE_EQ(d.last.K_matrix[i][j], 300.0 * n[i] * n[j]) << i << j;
            EXPECT_DOUBLE_EQ(d.last.B_matrix[i][j], 2.0 * n[i] * n[j]) << i << j;
        }
    }
}

TEST(ObjectResolution, CriteriaAreTheCheckersOptimaAndUnknownOnesNameTheAcceptedList) {
    Device d(3);
    ASSERT_FALSE(d.resolve(plane({0, 0, -1}, 0.0, cl::Gains::by_criterion("CE2"))));
    const CriterionGains ce2 = d.checker.criterion_gains(hapticopt::Criterion::CE2, kMass);
    EXPECT_EQ(d.last.params.K, ce2.K);
    EXPECT_EQ(d.last.params.B, ce2.B);
    const auto r = d.resolve(plane({0, 0, -1}, 0.0, cl::Gains::by_criterion("CE9")));
    expect_refusal(r, ErrorCode::UnknownCriterion,
                   "plane.gains.criterion = \"CE9\" is invalid; accepted: amax, OV, CE0");
    EXPECT_NE(r->message.find("CE2+OV"), std::string::npos) << r->message;
}

TEST(ObjectResolution, UnstableGainsCarryALargestStableKThatIsStable) {
    Device d(3);
    const auto r = d.resolve(plane({0, 0, -1}, 0.0, cl::Gains::explicit_gains(1e6, 5)));
    expect_refusal(r, ErrorCode::UnstableGains, "plane: K = 1e+06 N/m, B = 5 N s/m");
    ASSERT_TRUE(r->largest_stable_K);
    EXPECT_GT(*r->largest_stable_K, 0.0);
    EXPECT_LT(*r->largest_stable_K, 1e6);
    // A bisection to 2^-60 of alpha_max in alpha = K T^2 / m (GainChecker::check_pair), converted to K: stable
    // 1e-9 below (far above the conversion's rounding), unstable 1e-6 above (far above the bisection's step).
    EXPECT_TRUE(d.checker.pair_is_stable(*r->largest_stable_K * (1.0 - 1e-9), 5.0, kMass));
    EXPECT_FALSE(d.checker.pair_is_stable(*r->largest_stable_K * (1.0 + 1e-6), 5.0, kMass));
}

TEST(ObjectResolution, TheDevicesStiffnessLimitComesBeforeStability) {
    Device d(3, 1000.0);
    expect_refusal(
        d.resolve(plane({0, 0, -1}, 0.0, cl::Gains::explicit_gains(2000, 1))), ErrorCode::BeyondDeviceLimits,
        "plane: K = 2000 N/m exceeds the device's stiffness limit (device profile key max_stiffness = 1000 N/m)");
}

TEST(ObjectResolution, ALineSpringActsAcrossItsLine) {
    Device d(3);
    const cl::Spring line{.constraint = cl::Constraint::Line,
                          .point = {0, 0, 0},
                          .direction = {1, 0, 0},
                          .gains = cl::Gains::explicit_gains(100, 1)};
    ASSERT_FALSE(d.resolve(line));
    const Matrix3 expected{{{0, 0, 0}, {0, 100, 0}, {0, 0, 100}}};
    for (std::size_t i = 0; i < 3; ++i) {
        for (std::size_t j = 0; j < 3; ++j) EXPECT_NEAR(d.last.K_matrix[i][j], expected[i][j], 1e-12) << i << j;
    }
    cl::Spring bent = line;
    bent.direction = {1, 1, 0};
    expect_refusal(d.resolve(bent), ErrorCode::BadMessage, "spring.direction: length 1.41421");
    cl::Spring outside = line;
    outside.point = {0.1, 0, 0};
    expect_refusal(d.resolve(outside), ErrorCode::BeyondDeviceLimits, "spring.point[0] = 0.1");
}

TEST(ObjectResolution, AFieldNeedsANonNegativeStiffnessAndAForceWithinTheDevices) {
    Device d(3);
    cl::Field pushing{.center = {0, 0, 0},
                      .radius = 0.01,
                      .force = {0, 0, 0},
                      .jacobian = {cl::Vec3{50, 0, 0}, cl::Vec3{0, 0, 0}, cl::Vec3{0, 0, 0}},
                      .damping = 1.0};
    expect_refusal(d.resolve(pushing), ErrorCode::UnstableGains,
                   "field.jacobian: its symmetric part has the eigenvalue 50 N/m > 0");
    cl::Field strong = pushing;
    strong.jacobian = {cl::Vec3{-100, 0, 0}, cl::Vec3{0, -100, 0},
                       cl::Vec3{0, 0, -100}};  // B alone (K = 0) is unstable with a delay
    strong.force = {0, 0, 9.5};                // |F0| + ||J|| radius = 9.5 + 1 > 10 N
    expect_refusal(d.resolve(strong), ErrorCode::BeyondDeviceLimits,
                   "field: the largest force |F0| + ||J|| radius = 10.5 N");
    strong.force = {0, 0, 5};
    const auto accepted = d.resolve(strong);
    ASSERT_FALSE(accepted) << accepted->message;
    EXPECT_EQ(d.last.params.kind, ObjectKind::Field);
    EXPECT_DOUBLE_EQ(d.last.K_matrix[0][0], 100.0);
    EXPECT_DOUBLE_EQ(d.last.B_matrix[2][2], 1.0);
}

TEST(ObjectResolution, AnIdIsTheSessionsSlotOrAReasonWhyNot) {
    SlotTable slots{};
    slots[5].state = ServerSlot::State::Used;
    slots[5].id = 12;
    slots[5].owner = 7;
    slots[6] = slots[5];
    slots[6].id = 13;
    slots[6].state = ServerSlot::State::Draining;  // ramping out: no longer anyone's to change
    EXPECT_EQ(owned_slot(slots, 12, 7, 2).slot, 5);
    EXPECT_FALSE(owned_slot(slots, 12, 7, 2).refusal);
    const SlotLookup other = owned_slot(slots, 12, 8, 2);
    EXPECT_EQ(other.slot, -1);
    ASSERT_TRUE(other.refusal);
    EXPECT_EQ(other.refusal->code, ErrorCode::NotOwner);
    ASSERT_TRUE(owned_slot(slots, 2, 7, 2).refusal);
    EXPECT_EQ(owned_slot(slots, 2, 7, 2).refusal->code, ErrorCode::NotOwner);  // a config wall
    ASSERT_TRUE(owned_slot(slots, 13, 7, 2).refusal);
    EXPECT_EQ(owned_slot(slots, 13, 7, 2).refusal->code, ErrorCode::UnknownObject);
    EXPECT_EQ(objects_held(slots, 7), 1U);
    std::array<bool, kSceneObjectCapacity> taken{};
    taken[0] = true;
    EXPECT_EQ(free_slot(slots, taken), 1);
}

}  // namespace object_resolution_test
}  // namespace hapticd::server

namespace hapticd::server {
namespace object_resolution_shading_test {

namespace cl = hapticd::client;
using cl::ErrorCode;

// Force shading (docs/mesh-rendering.md, "Force shading"): on one free mass (0.3 kg, b = k = 0) a shaded mesh gets the
// hierarchy's normals for its crease angle; an angle outside 0 .. 80 deg, and shading on a device with a mass matrix
// or with damping, are refused naming mesh.shading (the same mesh unshaded is accepted there).
TEST(ObjectResolution, ShadingNeedsACreaseAngleInRangeAndOneFreeMass) {
    const auto h = mesh::MeshHierarchy::build(mesh::icosphere(0.01, 2), mesh::MeshMode::solid);
    const ShadingLookup shading = [&](double crease) -> std::variant<const mesh::ShadingNormals*, Refusal> {
        return h->shading(crease);
    };
    const MeshLookup lookup = [&](std::uint32_t) { return MeshLookupResult{h, std::nullopt, shading}; };
    auto resolve = [&](const GainCheckPlant& plant, std::optional<double> crease, Resolved& out) {
        const ServerConfig c = resolution_device::config(3);
        GainChecker checker(plant);
        ObjectResolver resolver(c, checker);
        cl::Mesh m{.mesh = 1, .gains = cl::Gains::by_criterion("CE2"), .shading_crease_angle_deg = crease};
        return resolver.resolve(cl::ObjectDescription{m}, out, &lookup);
    };
    const GainCheckPlant one = resolution_device::plant(3);
    Resolved out;
    ASSERT_FALSE(resolve(one, 30.0, out));
    EXPECT_EQ(out.params.shading, h->shading(30.0));
    EXPECT_EQ(out.params.crease_angle_deg, 30.0);
    ASSERT_FALSE(resolve(one, std::nullopt, out));
    EXPECT_EQ(out.params.shading, nullptr);
    EXPECT_LT(out.params.crease_angle_deg, 0.0);
    for (const double bad : {-0.5, 80.001, 90.0}) {
        const auto r = resolve(one, bad, out);
        ASSERT_TRUE(r);
        EXPECT_EQ(r->code, ErrorCode::BadMessage);
        EXPECT_EQ(r->message.rfind("mesh.shading.crease_angle_deg = ", 0), 0U) << r->message;
        EXPECT_NE(r->message.find("accepted: 0 .. 80 (degrees)"), std::string::npos) << r->message;
    }
    GainCheckPlant aniso = one;
    MassMatrix M{};
    M[0][0] = 0.45;
    M[1][1] = 0.3;
    M[2][2] = 0.25;
    aniso.mass_matrix = DeviceMass::from_matrix(M, 3);
    GainCheckPlant damped = one;
    damped.damping = 0.5;
    for (const GainCheckPlant& p : {aniso, damped}) {
        const auto r = resolve(p, 30.0, out);
        ASSERT_TRUE(r);
        EXPECT_EQ(r->code, ErrorCode::BadMessage);
        EXPECT_EQ(r->message.rfind("mesh.shading: accepted on devices with one mass and a free-mass plant", 0), 0U)
            << r->message;
        EXPECT_FALSE(resolve(p, std::nullopt, out));
    }
}

}  // namespace object_resolution_shading_test
}  // namespace hapticd::server
