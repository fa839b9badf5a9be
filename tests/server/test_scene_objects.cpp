// The loop's side of client objects (scene/scene_objects.hpp) and the server's gain checks
// (tuning/object_checks.hpp), in process: force laws, ramps, moving proxies, the rate limit, whole-batch
// application; the pair and summed-gain checks against hapticopt::is_stable directly.
#include <gtest/gtest.h>

#include <cmath>

#include <hapticopt/hapticopt.hpp>

#include "scene/scene_objects.hpp"
#include "tuning/object_checks.hpp"

namespace hapticd {
namespace {

constexpr double kT = 1e-3;

struct Rig {
    CommitRing ring{8};
    SceneObjects objects;
    explicit Rig(double ramp, double rate = 1e9) : objects(config(ramp, rate), ring) {}
    static SceneObjectsConfig config(double ramp, double rate) {
        SceneObjectsConfig c;
        c.period = kT;
        c.ramp_time = ramp;
        c.max_force = 1e6;
        c.max_force_rate = rate;
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

// The total force's change per tick is limited to max_force_rate T (scaled as a whole).
TEST(SceneObjects, TheTotalForceRateIsLimited) {
    Rig rig(0.0, 1000.0);  // 1 N per tick
    ObjectParams field;
    field.id = 1;
    field.kind = ObjectKind::Field;
    field.radius = 1.0;
    field.force = {3.0, 4.0, 0};
    rig.commit({{0, SlotUpdate::Action::Set, field}});
    AxisVector f = rig.tick({0, 0, 0});
    EXPECT_NEAR(f[1], 1.0, 1e-12);  // the larger component moves by 1 N, the direction is kept
    EXPECT_NEAR(f[0], 0.75, 1e-12);
    for (int k = 0; k < 5; ++k) f = rig.tick({0, 0, 0});
    EXPECT_NEAR(f[0], 3.0, 1e-12);
    EXPECT_NEAR(f[1], 4.0, 1e-12);
    EXPECT_GE(rig.objects.stats().rate_limited_ticks, 3U);
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
        const PairVerdict v = checker.check_pair(1e4, B);
        EXPECT_EQ(v.stable, hapticopt::is_stable(np, {1e4 * kT * kT / 0.3, B * kT / 0.3}));
        EXPECT_EQ(checker.pair_is_stable(1e4, B), v.stable);
        ASSERT_GT(v.largest_stable_K, 0.0);
        const double beta = B * kT / 0.3;
        EXPECT_TRUE(hapticopt::is_stable(np, {v.largest_stable_K * (1 - 1e-9) * kT * kT / 0.3, beta})) << B;
        EXPECT_FALSE(hapticopt::is_stable(np, {v.largest_stable_K * (1 + 1e-9) * kT * kT / 0.3, beta})) << B;
    }
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
    const auto ce2 = checker.criterion_gains("CE2");
    ASSERT_TRUE(ce2);
    const std::array<double, 3> n{0.0, 0.6, 0.8}, e{1.0, 0.0, 0.0};
    std::string why;
    const hapticopt::NormalizedPlant np{0.0, 0.0, 0.0};
    for (const double factor : {1.0, 1.5, 2.0, 3.0}) {
        const bool expected = hapticopt::is_stable(np, {factor * ce2->K * kT * kT / 0.3, factor * ce2->B * kT / 0.3});
        EXPECT_EQ(checker.sum_is_stable(outer(n, factor * ce2->K), outer(n, factor * ce2->B), why), expected) << factor << why;
    }
    EXPECT_TRUE(checker.sum_is_stable(plus(outer(n, ce2->K), outer(e, ce2->K)), plus(outer(n, ce2->B), outer(e, ce2->B)), why)) << why;
    EXPECT_FALSE(checker.sum_is_stable(outer(n, 3.0 * ce2->K), outer(n, ce2->B), why));
    EXPECT_NE(why.find("largest stable K"), std::string::npos) << why;
}

TEST(GainChecker, FieldStiffnessIsMinusTheSymmetricPartOfTheJacobian) {
    const auto fs = GainChecker::field_stiffness({std::array<double, 3>{-100, 20, 0}, {0, -50, 0}, {0, 0, 10}});
    // -sym(J) = [[100, -10, 0], [-10, 50, 0], [0, 0, -10]]: eigenvalues -10 and 75 +- sqrt(25^2 + 10^2).
    EXPECT_NEAR(fs.min_stiffness, -10.0, 1e-9);
    EXPECT_NEAR(fs.max_stiffness, 75.0 + std::sqrt(725.0), 1e-9);
    EXPECT_GT(fs.jacobian_norm, 100.0);
}

}  // namespace
}  // namespace hapticd
