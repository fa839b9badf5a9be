// SPDX-License-Identifier: Apache-2.0
// The loop's side of client objects (scene/scene_objects.hpp) and the server's gain checks
// (tuning/object_checks.hpp), in process: force laws, ramps, moving proxies, the rate limit, whole-batch
// application; the pair and summed-gain checks against hapticopt::is_stable directly; with an anisotropic
// mass matrix: the objects' effective masses, the summed check against an independently built 3-axis
// state matrix, the criterion optimum per mass, the simulated device's exact ZOH, and the profile keys.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <complex>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <random>
#include <utility>

#include <Eigen/Dense>
#include <unsupported/Eigen/MatrixFunctions>

#include <hapticopt/hapticopt.hpp>

#include "config/options.hpp"
#include "daemon/exit_codes.hpp"
#include "devices/sim_device.hpp"
#include "scene/force_limiter.hpp"
#include "scene/scene_objects.hpp"
#include "server/object_resolution.hpp"
#include "tuning/object_checks.hpp"

namespace hapticd {
namespace {

constexpr double kT = 1e-3;

struct Rig {
    CommitRing ring{8};
    SceneObjects objects;
    explicit Rig(double ramp) : objects(config(ramp), ring) {}
    static SceneObjectsConfig config(double ramp) {
        SceneObjectsConfig c;
        c.period = kT;
        c.ramp_time = ramp;
        c.axes = 3;
        return c;
    }
    void commit(std::initializer_list<SlotUpdate> updates, std::uint64_t seq = 1) {
        ObjectCommit c;
        c.seq = seq;
        for (const auto& u : updates) c.updates[c.count++] = u;
        ASSERT_TRUE(ring.try_push(c));
    }
    AxisVector tick(const AxisVector& x) {
        objects.apply_commits();
        AxisVector f{};
        EXPECT_TRUE(objects.add_forces(x, f));
        return f;
    }
};

ObjectParams spring_point(std::uint32_t id, const AxisVector& p, double K, double B) {
    ObjectParams o;
    o.id = id;
    o.kind = ObjectKind::Spring;
    o.constraint = SpringConstraint::Point;
    o.point = p;
    o.K = K;
    o.B = B;
    return o;
}

// Moving the proxy by delta changes the force by exactly K delta (the damping acts on the device's own
// velocity, which is zero here): no step beyond what the motion implies. Exact in floating point up to
// the rounding of K (x - p): 1e-12 relative.
TEST(SceneObjects, MovingASpringsProxyChangesTheForceByKDeltaOnly) {
    Rig rig(0.0);
    const AxisVector x{0.01, -0.02, 0.005};
    rig.commit({{0, SlotUpdate::Action::Set, spring_point(7, {0, 0, 0}, 200.0, 50.0)}});
    rig.tick(x);
    const AxisVector f0 = rig.tick(x);
    for (std::size_t a = 0; a < 3; ++a) EXPECT_NEAR(f0[a], -200.0 * x[a], 1e-12);
    rig.commit({{0, SlotUpdate::Action::Move, spring_point(7, {1e-3, 0, -2e-3}, 200.0, 50.0)}}, 2);
    const AxisVector f1 = rig.tick(x);
    EXPECT_NEAR(f1[0] - f0[0], 200.0 * 1e-3, 1e-12);
    EXPECT_NEAR(f1[1] - f0[1], 0.0, 1e-12);
    EXPECT_NEAR(f1[2] - f0[2], 200.0 * -2e-3, 1e-12);
    EXPECT_EQ(rig.objects.stats().last_commit_seq, 2U);
}

// A line spring pulls only perpendicular to its direction; a plane spring only along its normal.
TEST(SceneObjects, LineAndPlaneSpringsActOnlyOnTheConstrainedDirections) {
    Rig rig(0.0);
    ObjectParams line = spring_point(1, {0, 0, 0}, 100.0, 0.0);
    line.constraint = SpringConstraint::Line;
    line.direction = {1, 0, 0};
    rig.commit({{0, SlotUpdate::Action::Set, line}});
    AxisVector f = rig.tick({0.5, 0.01, -0.02});
    EXPECT_DOUBLE_EQ(f[0], 0.0);
    EXPECT_NEAR(f[1], -1.0, 1e-12);
    EXPECT_NEAR(f[2], 2.0, 1e-12);
    ObjectParams plane = line;
    plane.constraint = SpringConstraint::Plane;
    rig.commit({{0, SlotUpdate::Action::Set, plane}}, 2);  // cross-fade with ramp 0: replaced at once
    f = rig.tick({0.5, 0.01, -0.02});
    EXPECT_NEAR(f[0], -50.0, 1e-12);
    EXPECT_DOUBLE_EQ(f[1], 0.0);
    EXPECT_DOUBLE_EQ(f[2], 0.0);
}

// Ramp in over 10 ticks (ramp 10 ms at T = 1 ms): s_k = k / 10 after the commit's tick k = 0, then 1; the
// removal fades it out the same way and frees the slot.
TEST(SceneObjects, RampInAndOutAreLinearAndTheSlotIsFreedAfterwards) {
    Rig rig(0.010);
    ObjectParams field;
    field.id = 3;
    field.kind = ObjectKind::Field;
    field.radius = 1.0;
    field.force = {1.0, 0, 0};
    rig.commit({{5, SlotUpdate::Action::Set, field}});
    for (int k = 0; k <= 12; ++k) {
        const AxisVector f = rig.tick({0, 0, 0});
        EXPECT_NEAR(f[0], std::min(1.0, 0.1 * k), 1e-12) << k;
    }
    EXPECT_EQ(rig.objects.slot_object_id(5), 3U);
    rig.commit({{5, SlotUpdate::Action::Remove, field}}, 2);
    for (int k = 0; k < 10; ++k) {
        const AxisVector f = rig.tick({0, 0, 0});
        EXPECT_NEAR(f[0], 1.0 - 0.1 * k, 1e-12) << k;
    }
    EXPECT_NEAR(rig.tick({0, 0, 0})[0], 0.0, 1e-12);
    EXPECT_EQ(rig.objects.slot_object_id(5), 0U);
    EXPECT_EQ(rig.objects.occupied(), 0U);
}

// The published contact flags (contact_mask() & occupied_mask(), StatePublisher::publish) name occupied
// slots only: through a field's ramp-out (the handle inside it all along) the flag is published while its
// slot holds it; the tick whose ramp step frees the slot rendered it (raw flag set) but publishes no contact,
// so a state never shows a contact without an object (id 0).
TEST(SceneObjects, ARampedOutObjectLeavesNoContactFlagBehind) {
    Rig rig(0.010);
    ObjectParams field;
    field.id = 9;
    field.kind = ObjectKind::Field;
    field.radius = 1.0;
    field.force = {1.0, 0, 0};
    rig.commit({{6, SlotUpdate::Action::Set, field}});
    for (int k = 0; k <= 12; ++k) rig.tick({0, 0, 0});
    EXPECT_EQ(rig.objects.contact_mask(), std::uint64_t{1} << 6);
    rig.commit({{6, SlotUpdate::Action::Remove, field}}, 2);
    int ticks_with_flag = 0, ticks_rendered = 0;
    for (int k = 0; k < 15; ++k) {
        rig.tick({0, 0, 0});
        ticks_rendered += rig.objects.contact_mask() != 0 ? 1 : 0;
        const std::uint64_t mask = rig.objects.contact_mask() & rig.objects.occupied_mask();
        for (std::size_t s = 0; s < kSceneObjectCapacity; ++s) {
            if ((mask >> s & 1U) != 0U) {
                EXPECT_NE(rig.objects.slot_object_id(s), 0U) << "tick " << k << " slot " << s;
            }
        }
        ticks_with_flag += mask != 0 ? 1 : 0;
    }
    EXPECT_EQ(rig.objects.slot_object_id(6), 0U);
    // Ramp-out of 10 ticks: r = 1 - 0.1 k renders k = 0 .. 9; the slot is freed at the end of tick 9.
    EXPECT_EQ(ticks_rendered, 10);
    EXPECT_EQ(ticks_with_flag, 9);
}

// A departure with no stable ramp-out (docs/protocol.md, section 5, step 4): Cut removes the object at
// once, with no intermediate scene (a Remove would render 9 more ticks of ramp-out here); rendered_gains
// reports the spring's gains before and nothing after. Like every batch that changes gains it waits for the
// ramps in progress (the order the server checked).
TEST(SceneObjects, ACutRemovesAnObjectAtOnce) {
    Rig rig(0.010);
    ObjectParams spring;
    spring.id = 4;
    spring.kind = ObjectKind::Spring;
    spring.K = 100.0;
    spring.B = 2.0;
    rig.commit({{2, SlotUpdate::Action::Set, spring}});
    for (int k = 0; k < 12; ++k) rig.tick({0.01, 0, 0});
    std::array<AxisVector, 3> K{}, B{};
    rig.objects.apply_commits();
    rig.objects.rendered_gains(K, B);
    EXPECT_EQ(K[0][0], 100.0);
    EXPECT_EQ(K[2][2], 100.0);
    EXPECT_EQ(B[1][1], 2.0);
    rig.commit({{2, SlotUpdate::Action::Cut, spring}}, 2);
    rig.objects.apply_commits();
    EXPECT_EQ(rig.objects.slot_object_id(2), 0U);
    rig.objects.rendered_gains(K, B);
    EXPECT_EQ(K, (std::array<AxisVector, 3>{}));
    EXPECT_EQ(B, (std::array<AxisVector, 3>{}));
    AxisVector f{};
    EXPECT_TRUE(rig.objects.add_forces({0.01, 0, 0}, f));
    EXPECT_EQ(f, AxisVector{});
}

// One batch ramps at a time (SceneObjects::apply_commits): a batch that adds an object while another
// object's 10-tick ramp-in runs is held until that ramp has ended, then ramps in itself; a batch of moves of
// another object passes it at once; a move of the held object waits behind it. last_commit_seq means
// "every batch up to it applied". So every tick renders the scene the server checked for it: the held
// object's ramp starts from the scene in which the first has reached its final weight.
// A field of constant force F0 inside a sphere of 0.5 m around the origin (its force is r F0 while it ramps).
ObjectParams constant_field(std::uint32_t id, const AxisVector& F0) {
    ObjectParams o;
    o.id = id;
    o.kind = ObjectKind::Field;
    o.radius = 0.5;
    o.force = F0;
    return o;
}

TEST(SceneObjects, ABatchThatStartsRampsWaitsUntilTheRampsInProgressEnd) {
    Rig rig(0.010);
    const ObjectParams a = constant_field(1, {1.0, 0, 0});
    const ObjectParams c = constant_field(2, {0, 1.0, 0});
    rig.commit({{0, SlotUpdate::Action::Set, a}}, 1);
    const AxisVector x{0, 0, 0};
    for (int k = 0; k < 3; ++k) EXPECT_NEAR(rig.tick(x)[0], 0.1 * k, 1e-12) << k;
    rig.commit({{1, SlotUpdate::Action::Set, c}}, 2);  // while a ramps (0.3 now)
    ObjectParams a_moved = a;
    a_moved.point = {2.0, 0, 0};  // the handle is then outside a's sphere
    rig.commit({{0, SlotUpdate::Action::Move, a_moved}}, 3);
    ObjectParams c_moved = c;
    c_moved.point = {0, 0, 0.1};  // still inside
    rig.commit({{1, SlotUpdate::Action::Move, c_moved}}, 4);
    // Tick 3: batch 2 held, batch 3 (a's move, another slot) applied, batch 4 (c's move) waits behind 2.
    AxisVector f = rig.tick(x);
    EXPECT_EQ(f[0], 0.0);  // a moved away at once
    EXPECT_EQ(f[1], 0.0);  // c not there yet
    EXPECT_EQ(rig.objects.held(), 1U);
    EXPECT_EQ(rig.objects.stats().commits_held, 1U);
    EXPECT_EQ(rig.objects.stats().last_commit_seq, 1U);  // batch 3 is applied, but batch 2 is not
    EXPECT_EQ(rig.objects.slot_object_id(1), 0U);
    // Until a's ramp has reached 1 (after its 10th tick), c stays out; batch 2 is applied at the next tick
    // and batch 4 right after it, in the same tick.
    int k = 4;
    for (; rig.objects.slot_ramp(0) < 1.0 && k < 40; ++k) {
        f = rig.tick(x);
        EXPECT_EQ(f[1], 0.0) << k;
        EXPECT_EQ(rig.objects.slot_object_id(1), 0U) << k;
        EXPECT_EQ(rig.objects.stats().last_commit_seq, 1U) << k;
    }
    EXPECT_EQ(k, 10);  // a's ramp took its 10 ticks (k = 0 .. 9), counted in whole steps
    for (int j = 0; j <= 11; ++j) {
        f = rig.tick(x);
        EXPECT_NEAR(f[1], std::min(1.0, 0.1 * j), 1e-12) << j;
        EXPECT_EQ(rig.objects.slot_object_id(1), 2U) << j;
        EXPECT_EQ(rig.objects.stats().last_commit_seq, 4U) << j;
        EXPECT_EQ(rig.objects.held(), 0U) << j;
    }
    EXPECT_EQ(rig.objects.stats().commits_applied, 4U);
}

// Without ramps (ramp_s = 0) nothing is ever held: a batch is applied in the tick it arrives.
TEST(SceneObjects, WithoutRampsNoBatchIsHeld) {
    Rig rig(0.0);
    rig.commit({{0, SlotUpdate::Action::Set, constant_field(1, {1.0, 0, 0})}}, 1);
    EXPECT_EQ(rig.tick({0, 0, 0})[0], 1.0);
    rig.commit({{1, SlotUpdate::Action::Set, constant_field(2, {1.0, 0, 0})}}, 2);
    EXPECT_EQ(rig.tick({0, 0, 0})[0], 2.0);
    EXPECT_EQ(rig.objects.stats().commits_held, 0U);
    EXPECT_EQ(rig.objects.stats().last_commit_seq, 2U);
}

TEST(SceneObjects, AFieldActsOnlyInsideItsRadiusAndSetsTheContactFlag) {
    Rig rig(0.0);
    ObjectParams field;
    field.id = 9;
    field.kind = ObjectKind::Field;
    field.point = {0.01, 0, 0};
    field.radius = 0.005;
    field.force = {0, 0, -1};
    field.jacobian = {AxisVector{-100, 0, 0}, AxisVector{0, -100, 0}, AxisVector{0, 0, -100}};
    rig.commit({{2, SlotUpdate::Action::Set, field}});
    AxisVector f = rig.tick({0.012, 0, 0});
    EXPECT_NEAR(f[0], -0.2, 1e-12);
    EXPECT_NEAR(f[2], -1.0, 1e-12);
    EXPECT_EQ(rig.objects.contact_mask(), std::uint64_t{1} << 2);
    f = rig.tick({0.02, 0, 0});
    EXPECT_EQ(f, AxisVector{});
    EXPECT_EQ(rig.objects.contact_mask(), 0U);
}

// A field's damping acts on the device's velocity (backward difference): f = F0 + J d - B v.
TEST(SceneObjects, AFieldsDampingActsOnTheDeviceVelocity) {
    Rig rig(0.0);
    ObjectParams field;
    field.id = 5;
    field.kind = ObjectKind::Field;
    field.radius = 1.0;
    field.jacobian = {AxisVector{-100, 0, 0}, AxisVector{0, -100, 0}, AxisVector{0, 0, -100}};
    field.B = 2.0;
    rig.commit({{0, SlotUpdate::Action::Set, field}});
    rig.tick({0.001, 0, 0});
    const AxisVector f = rig.tick({0.002, 0, 0});  // v = 1 m/s
    EXPECT_NEAR(f[0], -100.0 * 0.002 - 2.0 * 1.0, 1e-9);
}

// A batch lands whole in one tick: two objects committed together both act from the same tick.
TEST(SceneObjects, ABatchIsAppliedWholeAtOneTick) {
    Rig rig(0.0);
    ObjectParams a;
    a.id = 1;
    a.kind = ObjectKind::Field;
    a.radius = 1.0;
    a.force = {1, 0, 0};
    ObjectParams b = a;
    b.id = 2;
    b.force = {0, 2, 0};
    rig.commit({{0, SlotUpdate::Action::Set, a}, {1, SlotUpdate::Action::Set, b}});
    const AxisVector f = rig.tick({0, 0, 0});
    EXPECT_DOUBLE_EQ(f[0], 1.0);
    EXPECT_DOUBLE_EQ(f[1], 2.0);
    EXPECT_EQ(rig.objects.stats().commits_applied, 1U);
}

// The unilateral plane: the analysed law along n inside, nothing outside, never pulling.
TEST(SceneObjects, AUnilateralPlaneIsTheWallLawAlongItsNormal) {
    Rig rig(0.0);
    ObjectParams p;
    p.id = 4;
    p.kind = ObjectKind::Plane;
    p.direction = {0.0, 0.6, 0.8};
    p.offset = 0.0;
    p.K = 1000.0;
    p.B = 10.0;
    rig.commit({{0, SlotUpdate::Action::Set, p}});
    AxisVector f = rig.tick({0, 0.001, 0});  // outside (n.x > 0)
    EXPECT_EQ(f, AxisVector{});
    const AxisVector x1{0, -0.0006, -0.0008};  // penetration 0.001
    f = rig.tick(x1);
    const double pen = 0.001, dpen = 0.001 - (-0.0006);  // p_j - p_{j-1}: from -0.0006 to 0.001
    const double fn = 1000.0 * pen + 10.0 * dpen / kT;
    EXPECT_NEAR(f[1], 0.6 * fn, 1e-9);
    EXPECT_NEAR(f[2], 0.8 * fn, 1e-9);
    // Moving out fast: the law would pull; a unilateral wall gives zero instead.
    f = rig.tick({0, -0.00006, -0.00008});
    EXPECT_EQ(f, AxisVector{});
}

// The objects' sum is their laws' sum, neither saturated nor rate-limited: the force limiter
// (scene/force_limiter.hpp) does both on the force written, the change a new object makes limited to
// max_force_rate T per tick (scaled as a whole).
TEST(SceneObjects, TheTotalIsTheLawsSumAndTheForceLimiterLimitsItsRate) {
    Rig rig(0.0);
    ForceLimiter limiter(1e6, 1000.0, kT, 3);  // 1 N per tick
    ObjectParams field;
    field.id = 1;
    field.kind = ObjectKind::Field;
    field.radius = 1.0;
    field.force = {3.0, 4.0, 0};
    rig.commit({{0, SlotUpdate::Action::Set, field}});
    AxisVector total = rig.tick({0, 0, 0});
    EXPECT_EQ(total, (AxisVector{3.0, 4.0, 0.0}));
    EXPECT_TRUE(rig.objects.law_change().whole);  // the field appeared
    AxisVector f = limiter.step(total, rig.objects.law_change());
    EXPECT_NEAR(f[1], 1.0, 1e-12);  // the larger component moves by 1 N, the direction is kept
    EXPECT_NEAR(f[0], 0.75, 1e-12);
    for (int k = 0; k < 5; ++k) {
        const AxisVector law = rig.tick({0, 0, 0});
        EXPECT_FALSE(rig.objects.law_change().whole);
        f = limiter.step(law, rig.objects.law_change());  // the offset decays by 1 N per tick
    }
    EXPECT_NEAR(f[0], 3.0, 1e-12);
    EXPECT_NEAR(f[1], 4.0, 1e-12);
    EXPECT_GE(limiter.stats().rate_limited_ticks, 3U);
}

TEST(SceneObjects, ANonFiniteForceIsAFaultWithZeroForce) {
    Rig rig(0.0);
    rig.commit({{0, SlotUpdate::Action::Set, spring_point(1, {0, 0, 0}, 100.0, 0.0)}});
    rig.objects.apply_commits();
    AxisVector f{};
    EXPECT_FALSE(rig.objects.add_forces({std::nan(""), 0, 0}, f));
    EXPECT_EQ(f, AxisVector{});
}

// --- the checks ------------------------------------------------------------------------------------

GainCheckPlant plant(double delay) {
    GainCheckPlant p;
    p.mass = 0.3;
    p.period = kT;
    p.time_delay = delay;
    return p;
}

TEST(GainChecker, PairVerdictIsHapticoptsAndTheLargestStableKBracketsTheBoundary) {
    GainChecker checker(plant(kT));
    const hapticopt::NormalizedPlant np{0.0, 0.0, 1.0};
    for (const double B : {5.0, 50.0, 150.0}) {
        const PairVerdict v = checker.check_pair(1e4, B, 0.3);
        EXPECT_EQ(v.stable, hapticopt::is_stable(np, {1e4 * kT * kT / 0.3, B * kT / 0.3}));
        EXPECT_EQ(checker.pair_is_stable(1e4, B, 0.3), v.stable);
        ASSERT_GT(v.largest_stable_K, 0.0);
        const double beta = B * kT / 0.3;
        EXPECT_TRUE(hapticopt::is_stable(np, {v.largest_stable_K * (1 - 1e-9) * kT * kT / 0.3, beta})) << B;
        EXPECT_FALSE(hapticopt::is_stable(np, {v.largest_stable_K * (1 + 1e-9) * kT * kT / 0.3, beta})) << B;
    }
}

// The damping interval for a stiffness (GainChecker::damping_range) against a brute-force scan of the
// loop's spectral radius (eigenvalues of the closed loop's transition matrix, hapticopt::stability, an
// independent computation from the region's D-decomposition): on 4000 B from 0 to 1.25 B_max, rho < 1
// exactly at the B strictly inside (B_min, B_max), away from the ends by 1e-6 B_max (the eigenvalues' and
// the bisection's errors are ~1e-12; near an end rho - 1 is of the order of the distance to it). Delays
// d = 0, 1, 3 periods, stiffnesses from 1 % to 90 % of alpha_max. A stiffness beyond alpha_max has none;
// a line spring's two masses get the intersection.
TEST(GainChecker, TheDampingRangeIsTheStableIntervalOfTheSpectralRadius) {
    for (const int d : {0, 1, 3}) {
        GainChecker checker(plant(d * kT));
        const hapticopt::NormalizedPlant np{0.0, 0.0, static_cast<double>(d)};
        const double alpha_max = hapticopt::StabilityRegion(np).alpha_max();
        for (const double fraction : {0.01, 0.3, 0.9}) {
            const double K = fraction * alpha_max * 0.3 / (kT * kT);
            const auto range = checker.damping_range(K, {0.3});
            ASSERT_TRUE(range.has_value()) << d << " " << fraction;
            const auto [lo, hi] = *range;
            ASSERT_LT(0.0, lo);
            ASSERT_LT(lo, hi);
            int stable_points = 0;
            for (int i = 0; i <= 4000; ++i) {
                const double B = 1.25 * hi * i / 4000.0;
                if (std::abs(B - lo) < 1e-6 * hi || std::abs(B - hi) < 1e-6 * hi) continue;
                const hapticopt::StabilityReport r = hapticopt::stability(np, {K * kT * kT / 0.3, B * kT / 0.3});
                EXPECT_EQ(r.spectral_radius < 1.0, lo < B && B < hi)
                    << "d " << d << " K " << K << " B " << B << " rho " << r.spectral_radius;
                stable_points += r.spectral_radius < 1.0 ? 1 : 0;
            }
            EXPECT_GT(stable_points, 0);
        }
        EXPECT_FALSE(checker.damping_range(1.01 * alpha_max * 0.3 / (kT * kT), {0.3}).has_value());
    }
    GainChecker checker(plant(kT));
    const double K = 2e4;
    const auto light = checker.damping_range(K, {0.3}), heavy = checker.damping_range(K, {0.6});
    const auto both = checker.damping_range(K, {0.3, 0.6});
    ASSERT_TRUE(light && heavy && both);
    EXPECT_EQ(both->first, std::max(light->first, heavy->first));
    EXPECT_EQ(both->second, std::min(light->second, heavy->second));
}

Matrix3 outer(const std::array<double, 3>& u, double s) {
    Matrix3 m{};
    for (std::size_t i = 0; i < 3; ++i) {
        for (std::size_t j = 0; j < 3; ++j) m[i][j] = s * u[i] * u[j];
    }
    return m;
}

Matrix3 plus(const Matrix3& a, const Matrix3& b) {
    Matrix3 m{};
    for (std::size_t i = 0; i < 3; ++i) {
        for (std::size_t j = 0; j < 3; ++j) m[i][j] = a[i][j] + b[i][j];
    }
    return m;
}

// Commuting sums decouple: two parallel planes are one scalar loop with the summed gains, so the verdict
// must be hapticopt's for (2 alpha, 2 beta); two orthogonal planes are two independent loops.
TEST(GainChecker, SummedGainsOfParallelPlanesAreCheckedAsTheirSum) {
    GainChecker checker(plant(0.0));
    const CriterionGains ce2 = checker.criterion_gains(hapticopt::Criterion::CE2, 0.3);
    const std::array<double, 3> n{0.0, 0.6, 0.8}, e{1.0, 0.0, 0.0};
    std::string why;
    const hapticopt::NormalizedPlant np{0.0, 0.0, 0.0};
    for (const double factor : {1.0, 1.5, 2.0, 3.0}) {
        const bool expected = hapticopt::is_stable(np, {factor * ce2.K * kT * kT / 0.3, factor * ce2.B * kT / 0.3});
        EXPECT_EQ(checker.sum_is_stable(outer(n, factor * ce2.K), outer(n, factor * ce2.B), why), expected)
            << factor << why;
    }
    EXPECT_TRUE(
        checker.sum_is_stable(plus(outer(n, ce2.K), outer(e, ce2.K)), plus(outer(n, ce2.B), outer(e, ce2.B)), why))
        << why;
    EXPECT_FALSE(checker.sum_is_stable(outer(n, 3.0 * ce2.K), outer(n, ce2.B), why));
    EXPECT_NE(why.find("largest stable K"), std::string::npos) << why;
}

TEST(GainChecker, FieldStiffnessIsMinusTheSymmetricPartOfTheJacobian) {
    const auto fs = GainChecker::field_stiffness({std::array<double, 3>{-100, 20, 0}, {0, -50, 0}, {0, 0, 10}});
    // -sym(J) = [[100, -10, 0], [-10, 50, 0], [0, 0, -10]]: eigenvalues -10 and 75 +- sqrt(25^2 + 10^2).
    EXPECT_NEAR(fs.stiffness_min, -10.0, 1e-9);
    EXPECT_NEAR(fs.stiffness_max, 75.0 + std::sqrt(725.0), 1e-9);
    EXPECT_GT(fs.jacobian_norm, 100.0);
}

// --- an anisotropic mass ----------------------------------------------------------------------------

// A full symmetric positive-definite mass matrix, b = k = 0 (tests/server/sim3_aniso.toml): along
// n = (0, 0.6, 0.8) m_n = 1 / (n^T M^-1 n) = 0.2123 kg, against n^T M n = 0.268 kg and the mean 0.333 kg.
MassMatrix anisotropic_matrix() {
    return MassMatrix{std::array<double, 3>{0.45, 0.10, 0.12}, {0.10, 0.30, 0.0}, {0.12, 0.0, 0.25}};
}

Eigen::Matrix3d eigen_of(const MassMatrix& m) {
    Eigen::Matrix3d e;
    for (int i = 0; i < 3; ++i) {
        for (int j = 0; j < 3; ++j) e(i, j) = m[static_cast<std::size_t>(i)][static_cast<std::size_t>(j)];
    }
    return e;
}

// The ramps between two stable scenes can pass through unstable ones (docs/protocol.md, section 5). The
// case: a plane along n1 (the scene before) and a second one along n2, nearly orthogonal (found by a random
// search over normalised gains for d = 1). Normalised (m = T = 1): alpha1 = 0.0766, beta1 = 0.2424;
// alpha2 = 0.103, beta2 = 0.1499; here m = 0.3 kg, T = 1 ms, K = alpha m / T^2, B = beta m / T.
namespace ramp_case {
const std::array<double, 3> n1{0.11098019180348687, 0.99382261849248599, 0.0};
const std::array<double, 3> n2{-0.99931483376676711, -0.037011660509880265, 0.0};
constexpr double m = 0.3;
// hapticopt's own verdict on physical matrices (normalised here, independently of GainChecker).
hapticopt::MatrixGainStability library_verdict(const Matrix3& K, const Matrix3& B) {
    Eigen::MatrixXd A(3, 3), Bn(3, 3);
    for (int r = 0; r < 3; ++r) {
        for (int c = 0; c < 3; ++c) {
            A(r, c) = K[r][c] * kT * kT / m;
            Bn(r, c) = B[r][c] * kT / m;
        }
    }
    return hapticopt::matrix_gain_stability(hapticopt::NormalizedPlant{0.0, 0.0, 1.0}, A, Bn);
}
Matrix3 scaled(const Matrix3& a, double s) {
    Matrix3 r{};
    for (std::size_t i = 0; i < 3; ++i) {
        for (std::size_t j = 0; j < 3; ++j) r[i][j] = s * a[i][j];
    }
    return r;
}
}  // namespace ramp_case

TEST(GainChecker, RampsAreCheckedAtEveryTickAndStiffnessFollowsDamping) {
    using namespace ramp_case;
    GainChecker checker(plant(kT));
    const Matrix3 K1 = outer(n1, 0.0766 * m / (kT * kT)), B1 = outer(n1, 0.2424 * m / kT);
    const Matrix3 K2 = outer(n2, 0.103 * m / (kT * kT)), B2 = outer(n2, 0.1499 * m / kT);
    std::string why;
    ASSERT_TRUE(checker.sum_is_stable(K1, B1, why)) << why;
    ASSERT_TRUE(checker.sum_is_stable(plus(K1, K2), plus(B1, B2), why)) << why;
    // A linear ramp (K and B both x s) of the second plane would pass through unstable scenes: at s = 2/3
    // the spectral radius is 1.0036 (and 1.00009 at s = 1/30, where the plane alone is already unstable:
    // beta / alpha = 1.46 < d + 1/2).
    const auto linear_middle = library_verdict(plus(K1, scaled(K2, 2.0 / 3.0)), plus(B1, scaled(B2, 2.0 / 3.0)));
    EXPECT_FALSE(linear_middle.stable);
    EXPECT_GT(linear_middle.spectral_radius, 1.003);
    EXPECT_FALSE(hapticopt::is_stable(hapticopt::NormalizedPlant{0.0, 0.0, 1.0}, {0.103 / 30.0, 0.1499 / 30.0}));
    // The loop's ramp (K x s^2, B x s: damping first) stays inside at every tick of a 30 ms ramp at 1 kHz.
    EXPECT_TRUE(hapticopt::is_stable(hapticopt::NormalizedPlant{0.0, 0.0, 1.0}, {0.103 / 900.0, 0.1499 / 30.0}));
    const Matrix3 zero{};
    EXPECT_TRUE(checker.ramp_is_stable(K1, B1, K2, B2, zero, zero, 1.0 / 30.0, why)) << why;
    // Replacing the first plane by the second (a cross-fade, nothing else in the scene) does not: refused,
    // naming the ramp. Independently: the scene at tick 26 (s = 26/30) is unstable for hapticopt.
    EXPECT_FALSE(checker.ramp_is_stable(zero, zero, K2, B2, K1, B1, 1.0 / 30.0, why));
    EXPECT_NE(why.find("during the ramp"), std::string::npos) << why;
    const double s = 26.0 / 30.0;
    EXPECT_FALSE(
        library_verdict(plus(scaled(K2, s * s), scaled(K1, (1 - s) * (1 - s))), plus(scaled(B2, s), scaled(B1, 1 - s)))
            .stable);
    // Without a ramp (step 1) the scene jumps from before to after: both stable, accepted.
    EXPECT_TRUE(checker.ramp_is_stable(zero, zero, K2, B2, K1, B1, 1.0, why)) << why;
}

GainCheckPlant anisotropic_plant(double delay) {
    GainCheckPlant p = plant(delay);
    p.mass_matrix = DeviceMass::from_matrix(anisotropic_matrix(), 3);
    p.mass = p.mass_matrix->of_axis(0);
    return p;
}

// The directional masses against an independent inverse (Eigen's LU of M, not the eigen-decomposition the
// checker uses): a plane's is 1 / (n^T M^-1 n), not n^T M n; a point spring's are M's eigenvalues; a line
// spring's the inverses of the non-zero eigenvalues of M^-1/2 (I - d d^T) M^-1/2. Relative 1e-12: both are
// a few double operations on a matrix of condition ~2.5.
TEST(AnisotropicMass, DirectionalMassesAreThoseOfTheForceDirection) {
    const GainChecker checker(anisotropic_plant(0.0));
    const Eigen::Matrix3d M = eigen_of(anisotropic_matrix());
    const Eigen::Matrix3d Minv = M.inverse();
    const Eigen::Vector3d n = Eigen::Vector3d(0.0, 0.6, 0.8);
    const double m_n = 1.0 / n.dot(Minv * n);
    EXPECT_NEAR(checker.mass_along({0.0, 0.6, 0.8}), m_n, 1e-12 * m_n);
    EXPECT_GT(std::abs(m_n - n.dot(M * n)), 0.05);  // the wrong reading differs by far more than rounding
    Matrix3 P = outer({0.0, 0.6, 0.8}, 1.0);
    const std::vector<double> plane_mass = checker.masses_of(P);
    ASSERT_EQ(plane_mass.size(), 1U);
    EXPECT_NEAR(plane_mass[0], m_n, 1e-12 * m_n);
    Matrix3 I{};
    for (std::size_t a = 0; a < 3; ++a) I[a][a] = 1.0;
    const std::vector<double> point = checker.masses_of(I);
    const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es(M);
    ASSERT_EQ(point.size(), 3U);
    for (int i = 0; i < 3; ++i) EXPECT_NEAR(point[static_cast<std::size_t>(i)], es.eigenvalues()(i), 1e-12) << i;
    // Line spring along d: the two masses of the plane perpendicular to d, independently as the
    // generalised eigenvalues of (Q^T M^-1 Q)^-1 with Q an orthonormal basis of that plane.
    const Eigen::Vector3d d = Eigen::Vector3d(1.0, 1.0, 0.0).normalized();
    const Matrix3 line = plus(I, outer({d(0), d(1), d(2)}, -1.0));
    Eigen::Matrix<double, 3, 2> Q;
    Q.col(0) = Eigen::Vector3d(1.0, -1.0, 0.0).normalized();
    Q.col(1) = Eigen::Vector3d(0.0, 0.0, 1.0);
    const Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> el((Q.transpose() * Minv * Q).inverse());
    const std::vector<double> line_masses = checker.masses_of(line);
    ASSERT_EQ(line_masses.size(), 2U);
    EXPECT_NEAR(line_masses[0], el.eigenvalues()(0), 1e-12);
    EXPECT_NEAR(line_masses[1], el.eigenvalues()(1), 1e-12);
}

// A pair stable for the isotropic mean mass (trace / 3) but not for m_n is refused by the object check,
// and the largest stable K brackets hapticopt's boundary for m_n (bisection width 2^-60 alpha_max, so
// +-1e-9 relative is far outside it).
TEST(AnisotropicMass, AnObjectIsCheckedWithItsOwnMass) {
    const GainChecker checker(anisotropic_plant(kT));
    const double m_n = checker.mass_along({0.0, 0.6, 0.8});
    const double mean = (0.45 + 0.30 + 0.25) / 3.0;
    ASSERT_LT(m_n, 0.95 * mean);
    const hapticopt::NormalizedPlant np{0.0, 0.0, 1.0};
    const double B = 0.4 * m_n / kT;  // beta = 0.4 at m_n
    // Just beyond the boundary at m_n: bisect hapticopt directly for a K stable at the mean, unstable at m_n.
    double K = 0.0;
    for (double alpha = 0.01; alpha < 1.0; alpha += 0.001) {
        const double k = alpha * m_n / (kT * kT);
        if (!hapticopt::is_stable(np, {alpha, B * kT / m_n}) &&
            hapticopt::is_stable(np, {k * kT * kT / mean, B * kT / mean})) {
            K = k;
            break;
        }
    }
    ASSERT_GT(K, 0.0) << "no pair separates the two masses (the test would prove nothing)";
    EXPECT_TRUE(checker.pair_is_stable(K, B, mean));
    const PairVerdict v = checker.check_object(K, B, checker.masses_of(outer({0.0, 0.6, 0.8}, 1.0)));
    EXPECT_FALSE(v.stable);
    EXPECT_NEAR(v.mass, m_n, 1e-12 * m_n);
    const double beta = B * kT / m_n;
    EXPECT_TRUE(hapticopt::is_stable(np, {v.largest_stable_K * (1 - 1e-9) * kT * kT / m_n, beta}));
    EXPECT_FALSE(hapticopt::is_stable(np, {v.largest_stable_K * (1 + 1e-9) * kT * kT / m_n, beta}));
}

// b = k = 0: the criterion optimum for any mass is optimal_wall's for that mass (the normalised optimum is
// mass-independent; equal to rounding, 1e-12 relative).
TEST(AnisotropicMass, CriterionGainsAreTheOptimumForTheObjectsMass) {
    GainChecker checker(anisotropic_plant(kT));
    for (const double m : {checker.mass_along({0.0, 0.6, 0.8}), checker.mass_along({1.0, 0.0, 0.0}), 0.45}) {
        const CriterionGains g = checker.criterion_gains(hapticopt::Criterion::CE1, m);
        const hapticopt::WallTuning t =
            hapticopt::optimal_wall(hapticopt::Criterion::CE1, hapticopt::PhysicalPlant{m, 0.0, 0.0, kT, kT});
        EXPECT_NEAR(g.K, t.K, 1e-12 * t.K) << m;
        EXPECT_NEAR(g.B, t.B, 1e-12 * t.B) << m;
    }
}

// The loop state (x_j, v_j, x_{j-1} .. x_{j-d-1}) in physical units with M x'' = -u, u_j = K x_{j-d} +
// B (x_{j-d} - x_{j-d-1}) / T held over the period; one period from Eigen's exponential of the 9 x 9
// augmented matrix [[0, I, 0], [0, 0, -M^-1], [0, 0, 0]] T — no change of coordinates, no polynomial.
Eigen::VectorXcd physical_state_eigenvalues(const Eigen::Matrix3d& M, const Eigen::Matrix3d& K,
                                            const Eigen::Matrix3d& B, int d) {
    Eigen::Matrix<double, 9, 9> c = Eigen::Matrix<double, 9, 9>::Zero();
    c.block<3, 3>(0, 3) = Eigen::Matrix3d::Identity();
    c.block<3, 3>(3, 6) = -M.inverse();
    const Eigen::Matrix<double, 9, 9> e = (c * kT).exp();
    const Eigen::Matrix<double, 6, 6> phi = e.topLeftCorner<6, 6>();
    const Eigen::Matrix<double, 6, 3> gamma = e.topRightCorner<6, 3>();
    const int n = 6 + 3 * (d + 1);
    auto x_block = [](int age) { return age == 0 ? 0 : 3 + 3 * age; };  // x_{j-age}
    Eigen::MatrixXd S = Eigen::MatrixXd::Zero(n, n);
    S.topLeftCorner<6, 6>() = phi;
    const Eigen::Matrix3d Kd = K + B / kT, Bd = -B / kT;
    S.block(0, x_block(d), 6, 3) += gamma * Kd;
    S.block(0, x_block(d + 1), 6, 3) += gamma * Bd;
    for (int age = 1; age <= d + 1; ++age) S.block(x_block(age), x_block(age - 1), 3, 3) = Eigen::Matrix3d::Identity();
    const Eigen::EigenSolver<Eigen::MatrixXd> es(S, false);
    return es.eigenvalues();
}

double physical_state_spectral_radius(const Eigen::Matrix3d& M, const Eigen::Matrix3d& K, const Eigen::Matrix3d& B,
                                      int d) {
    return physical_state_eigenvalues(M, K, B, d).cwiseAbs().maxCoeff();
}

// The summed check with a matrix mass against that independent construction: spectral radius agreement and
// "reported stable => radius < 1". Tolerance 1e-8 absolute on radii of order 1, as in
// tests/beyond/test_matrix_gain_stability.cpp (eps times the conditioning of simple dominant roots of
// ~15-square companion and state matrices).
TEST(AnisotropicMass, SummedGainsAgreeWithThePhysicalStateMatrix) {
    const Eigen::Matrix3d M = eigen_of(anisotropic_matrix());
    std::mt19937 rng(20261201);
    std::uniform_real_distribution<double> unit(-1.0, 1.0), alpha_of(0.01, 0.45), beta_of(0.0, 1.2);
    int stable = 0, unstable = 0, non_commuting = 0;
    double largest_difference = 0.0;
    for (int trial = 0; trial < 120; ++trial) {
        const int d = trial % 3;
        const GainChecker checker(anisotropic_plant(d * kT));
        Matrix3 K{}, B{};
        Eigen::Matrix3d Ke = Eigen::Matrix3d::Zero(), Be = Eigen::Matrix3d::Zero();
        for (int object = 0; object < 3; ++object) {
            const Eigen::Vector3d n = Eigen::Vector3d(unit(rng), unit(rng), unit(rng)).normalized();
            const double m_n = 1.0 / n.dot(M.inverse() * n);
            const double k = alpha_of(rng) / (1 + d) * m_n / (kT * kT), b = beta_of(rng) * m_n / kT;
            K = plus(K, outer({n(0), n(1), n(2)}, k));
            B = plus(B, outer({n(0), n(1), n(2)}, b));
            Ke += k * n * n.transpose();
            Be += b * n * n.transpose();
        }
        const hapticopt::MatrixGainStability v = checker.coupled(K, B);
        const double reference = physical_state_spectral_radius(M, Ke, Be, d);
        non_commuting += v.commuting ? 0 : 1;
        EXPECT_NEAR(v.spectral_radius, reference, 1e-8) << "trial " << trial;
        largest_difference = std::max(largest_difference, std::abs(v.spectral_radius - reference));
        std::string why;
        EXPECT_EQ(checker.sum_is_stable(K, B, why), v.stable) << trial;
        if (v.stable) {
            EXPECT_LT(reference, 1.0) << "trial " << trial;
            ++stable;
        } else {
            EXPECT_GT(reference, 1.0 - 2 * hapticopt::kMatrixGainRadiusMargin) << "trial " << trial;
            EXPECT_FALSE(why.empty());
            ++unstable;
        }
    }
    std::printf(
        "[ anisotropic sums ] %d stable, %d unstable, %d non-commuting; max |radius - physical state matrix| = %.3g\n",
        stable, unstable, non_commuting, largest_difference);
    EXPECT_GT(stable, 15);
    EXPECT_GT(unstable, 15);
    EXPECT_GT(non_commuting, 100);
}

// One plane alone: the coupled verdict in the unit-mass coordinates is the scalar verdict for m_n.
TEST(AnisotropicMass, OnePlaneAloneIsTheScalarVerdictForItsMass) {
    const GainChecker checker(anisotropic_plant(kT));
    const double m_n = checker.mass_along({0.0, 0.6, 0.8});
    const hapticopt::NormalizedPlant np{0.0, 0.0, 1.0};
    int both = 0;
    for (double alpha = 0.02; alpha < 0.6; alpha += 0.04) {
        for (double beta = 0.05; beta < 1.2; beta += 0.1) {
            const double K = alpha * m_n / (kT * kT), B = beta * m_n / kT;
            std::string why;
            const bool expected = hapticopt::is_stable(np, {alpha, beta});
            EXPECT_EQ(checker.sum_is_stable(outer({0.0, 0.6, 0.8}, K), outer({0.0, 0.6, 0.8}, B), why), expected)
                << alpha << " " << beta;
            both += expected ? 1 : 0;
        }
    }
    EXPECT_GT(both, 10);
}

// The simulated device with a full mass matrix against the exact solution of M x'' + b x' + k x = u with u
// constant per period, from the 9 x 9 matrix exponential of [0 I 0; -k M^-1 -b M^-1 M^-1; 0 0 0]: free (b = k
// = 0) and held by the simulated hand (b_H = 4 N s/m, k_H = 200 N/m, which the device integrates per
// eigenvector of M). The same ZOH, so equal to rounding (1e-12 of the motion's scale after 200 steps).
TEST(AnisotropicMass, TheSimulatedDeviceRendersTheMassMatrixExactly) {
    for (const auto& [b, k] : {std::pair{0.0, 0.0}, std::pair{4.0, 200.0}}) {
        SimDeviceConfig cfg;
        cfg.capabilities.axes = 3;
        cfg.capabilities.max_force = 100.0;
        cfg.plant = PlantParameters{1.0, 0.0, 0.0};
        cfg.mass_matrix = anisotropic_matrix();
        cfg.scenario.step_force = 0.0;
        cfg.scenario.hand.damping = b;
        cfg.scenario.hand.stiffness = k;
        SimDevice sim(cfg);
        ASSERT_EQ(sim.open(), DeviceStatus::Ok);
        const Eigen::Matrix3d Minv = eigen_of(anisotropic_matrix()).inverse();
        Eigen::Matrix<double, 9, 9> c = Eigen::Matrix<double, 9, 9>::Zero();
        c.block<3, 3>(0, 3) = Eigen::Matrix3d::Identity();
        c.block<3, 3>(3, 0) = -k * Minv;
        c.block<3, 3>(3, 3) = -b * Minv;
        c.block<3, 3>(3, 6) = Minv;
        const Eigen::Matrix<double, 9, 9> e = (c * kT).exp();
        Eigen::Matrix<double, 6, 1> state = Eigen::Matrix<double, 6, 1>::Zero();
        double scale = 0.0, worst = 0.0;
        for (int j = 0; j < 200; ++j) {
            AxisVector x{};
            ASSERT_EQ(sim.read_position(x), DeviceStatus::Ok);
            for (int a = 0; a < 3; ++a) {
                worst = std::max(worst, std::abs(x[static_cast<std::size_t>(a)] - state(a)));
                scale = std::max(scale, std::abs(state(a)));
            }
            const AxisVector u{std::sin(0.05 * j), 0.5 * std::cos(0.03 * j), j < 100 ? 1.0 : -1.0};
            ASSERT_EQ(sim.write_force(u), DeviceStatus::Ok);
            Eigen::Matrix<double, 9, 1> aug;
            aug << state, u[0], u[1], u[2];
            state = (e * aug).head<6>();
        }
        ASSERT_GT(scale, 1e-3);
        std::printf(
            "[ anisotropic sim ] b = %g, k = %g: max |x_sim - x_exact| = %.3g m over 200 ticks (motion up to %.3g m)\n",
            b, k, worst, scale);
        EXPECT_LE(worst, 1e-12 * scale);
    }
}

// The profile keys: each bad value is refused naming the key and the accepted range, with its exit code.
struct ProfileCase {
    const char* keys;
    int code;
    const char* expected;
};

TEST(AnisotropicMass, ProfileKeysAreValidatedByName) {
    const auto dir = std::filesystem::temp_directory_path() / ("hapticd_mass_keys_" + std::to_string(::getpid()));
    std::filesystem::create_directories(dir);
    const std::string common = "driver = \"sim\"\nmax_force = 10.0\naxes = 3\n";
    const ProfileCase cases[] = {
        {"", kExitBadConfig, "missing key 'mass'"},
        {"mass = 0.3\nmass_matrix = [0.3, 0, 0, 0, 0.3, 0, 0, 0, 0.3]\n", kExitBadConfig,
         "mass and mass_matrix are both given"},
        {"mass = [0.3, 0.4]\n", kExitInvalidParameter, "one value (every axis) or one per axis (3)"},
        {"mass = [0.3, -0.4, 0.4]\n", kExitInvalidParameter, "finite, > 0"},
        {"mass_matrix = [0.3, 0, 0, 0, 0.3, 0]\n", kExitInvalidParameter, "3 x 3 = 9 values"},
        {"mass_matrix = [0.3, 0.1, 0, 0, 0.3, 0, 0, 0, 0.3]\n", kExitInvalidParameter, "a symmetric matrix"},
        {"mass_matrix = [0.3, 0.4, 0, 0.4, 0.3, 0, 0, 0, 0.3]\n", kExitInvalidParameter, "positive definite"},
        {"mass = [0.3, 0.3, 0.45]\ndamping = 1.0\n", kExitInvalidParameter, "accepted: damping = 0 and stiffness = 0"},
        {"mass = 0.3\nmax_stiffness = -5\n", kExitInvalidParameter,
         "max_stiffness = -5 is invalid; accepted range: finite, > 0"},
    };
    int i = 0;
    for (const ProfileCase& c : cases) {
        const auto path = dir / ("case" + std::to_string(i++) + ".toml");
        std::ofstream(path) << common << c.keys;
        Options o;
        o.device = path.string();
        try {
            (void)load_device_profile(o);
            ADD_FAILURE() << c.keys << " was accepted";
        } catch (const StartupError& e) {
            EXPECT_EQ(exit_code(e.kind()), c.code) << c.keys << ": " << e.what();
            EXPECT_NE(std::string(e.what()).find(c.expected), std::string::npos) << c.keys << ": " << e.what();
        }
    }
    // Accepted: a per-axis mass (the mass of axis a is M_aa) and a matrix (1 / (M^-1)_aa), and the limit.
    const auto good = dir / "good.toml";
    std::ofstream(good) << common << "mass = [0.3, 0.3, 0.45]\nmax_stiffness = 5e4\n";
    Options o;
    o.device = good.string();
    const DeviceProfile p = load_device_profile(o);
    EXPECT_FALSE(p.mass_model.isotropic);
    EXPECT_TRUE(p.mass_model.diagonal);
    EXPECT_EQ(p.mass_model.of_axis(2), 0.45);
    ASSERT_TRUE(p.max_stiffness);
    EXPECT_EQ(*p.max_stiffness, 5e4);
    o.identify = true;  // one mass only
    EXPECT_THROW((void)load_device_profile(o), StartupError);
    std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace hapticd

namespace hapticd {
namespace {

// The orthogonal projector on the span of the columns of N (Eigen's QR, independent of the loop's Gram-Schmidt).
Eigen::Matrix3d projector_on(const Eigen::MatrixXd& N) {
    const Eigen::HouseholderQR<Eigen::MatrixXd> qr(N);
    const Eigen::MatrixXd Q = qr.householderQ() * Eigen::MatrixXd::Identity(3, N.cols());
    return Q * Q.transpose();
}

// A mesh object's gains as the server checks them (server/object_resolution.cpp, mesh_masses over the plant set
// [1/1.1, 1.1] of the anisotropic M), at the criterion's optimum and at 99 % of the largest K the check accepts at
// that B (bisection), against the physical state matrix of every contact configuration the proxy can render: K P, B P
// with P the projector on 1, 2 or 3 random normals, and P = I (friction), at the set's corners c_min M and c_max M and
// at M; d = 0, 1, 2. Every one decays (spectral radius < 1). The same gains checked with the point spring's masses
// alone (M's eigenvalues) would miss the masses between them; mesh_masses' chain covers the interval.
TEST(AnisotropicMass, AMeshsGainsAreStableInEveryContactConfigurationOverThePlantSet) {
    const Eigen::Matrix3d M = eigen_of(anisotropic_matrix());
    std::mt19937 rng(20261205);
    std::uniform_real_distribution<double> unit(-1.0, 1.0);
    double worst = 0.0;
    int configurations = 0;
    for (int d = 0; d < 3; ++d) {
        GainCheckPlant p = anisotropic_plant(d * kT);
        p.mass_margin = 0.1;
        GainChecker checker(p);
        Matrix3 I{};
        for (std::size_t i = 0; i < 3; ++i) I[i][i] = 1.0;
        const auto [c_min, c_max] = checker.mass_scales();
        const std::vector<double> masses = server::mesh_masses(checker.masses_of(I), c_min, c_max);
        ASSERT_GE(masses.size(), 3U);
        const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es(M);
        EXPECT_NEAR(masses.front(), es.eigenvalues()(0), 1e-12);
        EXPECT_NEAR(masses.back(), es.eigenvalues()(2), 1e-12);
        for (std::size_t i = 1; i < masses.size(); ++i)
            EXPECT_LE(masses[i] * c_min, masses[i - 1] * c_max * (1 + 1e-12));
        const CriterionGains optimum = checker.criterion_gains(hapticopt::Criterion::CE2, masses.front());
        const PairVerdict at_optimum = checker.check_object(optimum.K, optimum.B, masses);
        ASSERT_TRUE(at_optimum.stable);
        double lo = optimum.K, hi = 100.0 * optimum.K;  // the largest K the check accepts at B, by bisection
        ASSERT_FALSE(checker.check_object(hi, optimum.B, masses).stable);
        for (int i = 0; i < 40; ++i) {
            const double mid = 0.5 * (lo + hi);
            (checker.check_object(mid, optimum.B, masses).stable ? lo : hi) = mid;
        }
        const double near_edge = 0.99 * lo;
        ASSERT_TRUE(checker.check_object(near_edge, optimum.B, masses).stable);
        {  // not vacuous: 5 % beyond the accepted K, a contact along M's lightest direction grows at the set's lightest
            const Eigen::Vector3d e = es.eigenvectors().col(0);
            const Eigen::VectorXcd ev =
                physical_state_eigenvalues(c_min * M, 1.05 * lo * e * e.transpose(), optimum.B * e * e.transpose(), d);
            double beyond = 0.0;
            for (const auto& z : ev) {
                if (std::abs(z - 1.0) > 1e-6) beyond = std::max(beyond, std::abs(z));
            }
            EXPECT_GT(beyond, 1.0) << "d " << d;
        }
        for (const double K : {optimum.K, near_edge}) {
            for (int trial = 0; trial < 60; ++trial) {
                const int rank = 1 + trial % 4;  // 4: friction, P = I
                Eigen::MatrixXd N(3, std::min(rank, 3));
                for (int c = 0; c < N.cols(); ++c)
                    N.col(c) = Eigen::Vector3d(unit(rng), unit(rng), unit(rng)).normalized();
                const Eigen::Matrix3d P = rank == 4 ? Eigen::Matrix3d::Identity() : projector_on(N);
                for (const double c : {c_min, 1.0, c_max}) {
                    // A rank-r P leaves 3 - r directions free: a double integrator each, 2 (3 - r) eigenvalues at 1
                    // (a Jordan block: within ~1e-8 of 1 in double). Those nearest 1 are set aside (checked within
                    // 1e-6 of it); the radius of the rest is the contact's.
                    const int r = rank == 4 ? 3 : rank;
                    Eigen::VectorXcd ev = physical_state_eigenvalues(c * M, K * P, optimum.B * P, d);
                    std::vector<std::complex<double>> rest(ev.data(), ev.data() + ev.size());
                    std::sort(rest.begin(), rest.end(),
                              [](auto a, auto b) { return std::abs(a - 1.0) < std::abs(b - 1.0); });
                    for (int f = 0; f < 2 * (3 - r); ++f)
                        EXPECT_LT(std::abs(rest[static_cast<std::size_t>(f)] - 1.0), 1e-6);
                    double radius = 0.0;
                    for (std::size_t i = static_cast<std::size_t>(2 * (3 - r)); i < rest.size(); ++i) {
                        radius = std::max(radius, std::abs(rest[i]));
                    }
                    worst = std::max(worst, radius);
                    EXPECT_LT(radius, 1.0) << "d " << d << " K " << K << " rank " << rank << " c " << c;
                    ++configurations;
                }
            }
        }
    }
    std::printf("[ mesh configurations ] %d contact configurations x masses, largest spectral radius %.9f\n",
                configurations, worst);
}

}  // namespace
}  // namespace hapticd
