// SPDX-License-Identifier: Apache-2.0
// The loop's evaluation of client objects (scene/scene_objects.hpp, "How a tick is computed") against an
// independent, slower evaluation written here from the force laws of docs/protocol.md section 4: every
// object one by one, every tick, no summed law, no safe radius. Random scenes of every kind of object, on
// random trajectories that cross the planes and spheres many times, with and without ramps.
#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <random>
#include <string>
#include <vector>

#include "scene/scene_objects.hpp"

namespace hapticd {
namespace closed_form {  // named: the sanitizer stage builds the tests as one unity file with test_scene_objects.cpp

constexpr double kT = 1e-3;
constexpr double kEps = 2.220446049250313e-16;

double dot3(const AxisVector& a, const AxisVector& b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }

// One object's force and contact flag by its law, and the sum of the magnitudes of its terms (for the
// rounding bound below).
struct Reference {
    AxisVector f{};
    bool contact = false;
    double magnitude = 0.0;
};

// sK, sB, sF: the ramp's weights of the stiffness, damping and constant-force terms (r^2, r, r).
Reference reference_force(const ObjectParams& p, const AxisVector& x, const AxisVector& v, double sK, double sB,
                          double sF) {
    Reference r;
    switch (p.kind) {
        case ObjectKind::Plane: {
            const double pen = p.offset - dot3(p.direction, x);
            double fn = sK * p.K * pen - sB * p.B * dot3(p.direction, v);
            r.magnitude = std::fabs(p.K) * (std::fabs(p.offset) + std::fabs(x[0]) + std::fabs(x[1]) + std::fabs(x[2])) +
                          std::fabs(p.B) * (std::fabs(v[0]) + std::fabs(v[1]) + std::fabs(v[2]));
            r.contact = pen > 0.0;
            if (!p.bilateral) {
                if (!r.contact) return r;
                fn = std::max(fn, 0.0);
            }
            for (std::size_t a = 0; a < 3; ++a) r.f[a] = fn * p.direction[a];
            return r;
        }
        case ObjectKind::Spring: {
            AxisVector d{};
            for (std::size_t a = 0; a < 3; ++a) d[a] = x[a] - p.point[a];
            const double dn = dot3(d, p.direction), vn = dot3(v, p.direction);
            for (std::size_t a = 0; a < 3; ++a) {
                double ra = d[a], va = v[a];
                if (p.constraint == SpringConstraint::Plane) {
                    ra = dn * p.direction[a];
                    va = vn * p.direction[a];
                } else if (p.constraint == SpringConstraint::Line) {
                    ra = d[a] - dn * p.direction[a];
                    va = v[a] - vn * p.direction[a];
                }
                r.f[a] = -sK * p.K * ra - sB * p.B * va;
                r.magnitude +=
                    std::fabs(p.K) * (std::fabs(x[a]) + std::fabs(p.point[a])) + std::fabs(p.B) * std::fabs(v[a]);
            }
            r.contact = true;
            return r;
        }
        case ObjectKind::Field: {
            AxisVector d{};
            for (std::size_t a = 0; a < 3; ++a) d[a] = x[a] - p.point[a];
            r.contact = std::sqrt(dot3(d, d)) <= p.radius;
            if (!r.contact) return r;
            for (std::size_t a = 0; a < 3; ++a) {
                r.f[a] = sF * p.force[a] + sK * dot3(p.jacobian[a], d) - sB * p.B * v[a];
                r.magnitude += std::fabs(p.force[a]) + std::fabs(p.B * v[a]);
                for (std::size_t c = 0; c < 3; ++c)
                    r.magnitude += std::fabs(p.jacobian[a][c]) * (std::fabs(x[c]) + std::fabs(p.point[c]));
            }
            return r;
        }
        case ObjectKind::Mesh:  // stateful (its proxy), no closed form: random_object never makes one
            ADD_FAILURE() << "a mesh in the closed-form test";
            return r;
    }
    return r;
}

AxisVector random_unit(std::mt19937_64& rng) {
    std::normal_distribution<double> n(0.0, 1.0);
    AxisVector u{n(rng), n(rng), n(rng)};
    const double len = std::sqrt(dot3(u, u));
    for (double& c : u) c /= len;
    return u;
}

ObjectParams random_object(std::mt19937_64& rng, std::uint32_t id) {
    std::uniform_real_distribution<double> pos(-0.01, 0.01), gain(1.0, 2000.0), damping(0.0, 20.0);
    std::uniform_int_distribution<int> kind(0, 5);
    ObjectParams o;
    o.id = id;
    o.direction = random_unit(rng);
    o.K = gain(rng);
    o.B = damping(rng);
    switch (kind(rng)) {
        case 0:
            o.kind = ObjectKind::Plane;
            o.offset = pos(rng);
            o.bilateral = false;
            break;
        case 1:
            o.kind = ObjectKind::Plane;
            o.offset = pos(rng);
            o.bilateral = true;
            break;
        case 2:
            o.kind = ObjectKind::Spring;
            o.constraint = SpringConstraint::Point;
            o.point = {pos(rng), pos(rng), pos(rng)};
            break;
        case 3:
            o.kind = ObjectKind::Spring;
            o.constraint = SpringConstraint::Line;
            o.point = {pos(rng), pos(rng), pos(rng)};
            break;
        case 4:
            o.kind = ObjectKind::Spring;
            o.constraint = SpringConstraint::Plane;
            o.point = {pos(rng), pos(rng), pos(rng)};
            break;
        default:
            o.kind = ObjectKind::Field;
            o.point = {pos(rng), pos(rng), pos(rng)};
            o.radius = std::uniform_real_distribution<double>(0.001, 0.01)(rng);
            o.force = {pos(rng) * 100, pos(rng) * 100, pos(rng) * 100};
            for (auto& row : o.jacobian) {
                for (double& c : row) c = -gain(rng) * 0.1;
            }
            break;
    }
    return o;
}

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
};

// One object in a rig without ramps, ticked along a path, each tick compared with the object's own law:
// force within 1e-12 N (a few roundings of terms of ~10 N), contact flag exact. `object` is what the law
// is evaluated for: a test that moves the object updates it as it pushes the Move.
struct LawCheck {
    Rig rig{0.0};
    ObjectParams object;
    AxisVector previous{};
    explicit LawCheck(const ObjectParams& o) : object(o) {
        ObjectCommit c;
        c.seq = 1;
        c.updates[c.count++] = SlotUpdate{0, SlotUpdate::Action::Set, o};
        EXPECT_TRUE(rig.ring.try_push(c));
    }
    AxisVector tick(const AxisVector& to, const std::string& where) {
        rig.objects.apply_commits();
        AxisVector f{};
        EXPECT_TRUE(rig.objects.add_forces(to, f)) << where;
        AxisVector v{};
        for (std::size_t a = 0; a < 3; ++a) v[a] = (to[a] - previous[a]) / kT;
        previous = to;
        const Reference r = reference_force(object, to, v, 1.0, 1.0, 1.0);
        for (std::size_t a = 0; a < 3; ++a) EXPECT_NEAR(f[a], r.f[a], 1e-12) << where;
        EXPECT_EQ(rig.objects.contact_mask(), r.contact ? 1U : 0U) << where;
        return f;
    }
};

// The summed law and the safe radius give the per-object sum: force within the rounding bound of the two
// ways of summing, and the contact flags identical. Bound: each way sums at most ~4n + 10 products, so
// each differs from the exact sum by at most (4n + 10) eps times the sum of the magnitudes of the terms
// (the standard bound for recursive summation, Higham, Accuracy and Stability, 2002, eq. 4.4); the test
// allows twice that (plus the ramp factor's own rounding, see below). Samples with a surface within 1e-12 m of the
// handle are not compared for the flag (there the direct evaluation's own rounding decides it).
void compare_on_random_scenes(double ramp_time, bool with_moves, std::uint64_t seed) {
    std::mt19937_64 rng(seed);
    std::uniform_real_distribution<double> unit(0.0, 1.0);
    const int ramp_ticks = ramp_time > 0.0 ? static_cast<int>(std::lround(ramp_time / kT)) : 0;
    std::size_t compared_flags = 0, ticks_total = 0;
    std::uint64_t classified_total = 0, summed_total = 0, one_by_one_total = 0;
    for (int scene = 0; scene < 40; ++scene) {
        Rig rig(ramp_time);
        const std::size_t n = 1 + static_cast<std::size_t>(unit(rng) * kSceneObjectCapacity) % kSceneObjectCapacity;
        std::vector<ObjectParams> objs;
        ObjectCommit commit;
        commit.seq = 1;
        for (std::size_t i = 0; i < n; ++i) {
            objs.push_back(random_object(rng, static_cast<std::uint32_t>(i + 1)));
            commit.updates[commit.count++] =
                SlotUpdate{static_cast<std::uint8_t>(i), SlotUpdate::Action::Set, objs.back()};
        }
        ASSERT_TRUE(rig.ring.try_push(commit));
        // A random walk with small steps (mostly inside the safe radius) and jumps (across surfaces).
        AxisVector x{}, previous{};
        const std::uint64_t c0 = rig.objects.classifications();
        for (int k = 0; k < 400; ++k) {
            const double step = unit(rng) < 0.05 ? 5e-3 : 2e-5;
            const AxisVector u = random_unit(rng);
            for (std::size_t a = 0; a < 3; ++a) x[a] = std::clamp(x[a] + step * u[a], -0.015, 0.015);
            if (with_moves && k > 0 && unit(rng) < 0.3) {  // a client moves one object (Move: place only)
                const std::size_t i = static_cast<std::size_t>(unit(rng) * static_cast<double>(n)) % n;
                ObjectParams& o = objs[i];
                const double shift = (unit(rng) < 0.1 ? 5e-3 : 5e-5) * (unit(rng) - 0.5);
                o.offset += shift;
                for (std::size_t a = 0; a < 3; ++a) o.point[a] += shift * u[a];
                if (o.kind == ObjectKind::Field) o.force[0] += 100.0 * shift;
                ObjectCommit move;
                move.seq = static_cast<std::uint64_t>(k + 2);
                move.updates[move.count++] = SlotUpdate{static_cast<std::uint8_t>(i), SlotUpdate::Action::Move, o};
                ASSERT_TRUE(rig.ring.try_push(move));
            }
            rig.objects.apply_commits();
            AxisVector f{};
            ASSERT_TRUE(rig.objects.add_forces(x, f));
            AxisVector v{};
            if (k > 0) {
                for (std::size_t a = 0; a < 3; ++a) v[a] = (x[a] - previous[a]) / kT;
            }
            previous = x;
            const double s = ramp_ticks > 0 ? std::min(1.0, static_cast<double>(k) / ramp_ticks) : 1.0;
            AxisVector expected{};
            double magnitude = 0.0;
            std::uint64_t mask = 0;
            bool flag_decidable = true;
            for (std::size_t i = 0; i < n; ++i) {
                const Reference r = reference_force(objs[i], x, v, s * s, s, s);
                for (std::size_t a = 0; a < 3; ++a) expected[a] += r.f[a];
                magnitude += r.magnitude;
                if (r.contact) mask |= std::uint64_t{1} << i;
                const ObjectParams& p = objs[i];
                if (p.kind == ObjectKind::Plane && std::fabs(p.offset - dot3(p.direction, x)) < 1e-12)
                    flag_decidable = false;
                if (p.kind == ObjectKind::Field) {
                    AxisVector d{};
                    for (std::size_t a = 0; a < 3; ++a) d[a] = x[a] - p.point[a];
                    if (std::fabs(std::sqrt(dot3(d, d)) - p.radius) < 1e-12) flag_decidable = false;
                }
            }
            // + ramp_ticks eps: the loop's ramp factor is a sum of k steps T / ramp_time, not k T / ramp_time.
            const double bound = (2.0 * (4.0 * static_cast<double>(n) + 10.0) + ramp_ticks) * kEps * magnitude;
            for (std::size_t a = 0; a < 3; ++a) {
                ASSERT_LE(std::fabs(f[a] - expected[a]), bound)
                    << "scene " << scene << " tick " << k << " axis " << a << ": " << f[a] << " vs " << expected[a];
            }
            if (flag_decidable) {
                ASSERT_EQ(rig.objects.contact_mask(), mask) << "scene " << scene << " tick " << k;
                ++compared_flags;
            }
        }
        ticks_total += 400;
        classified_total += rig.objects.classifications() - c0;
        summed_total += rig.objects.pressed_summed();
        one_by_one_total += rig.objects.pressed_fallbacks();
    }
    EXPECT_GT(compared_flags, ticks_total * 9 / 10);
    // Both ways of rendering deeply pressed unilateral planes were compared: their summed law (a slow hand)
    // and one by one (a tick whose motion fails the test).
    EXPECT_GT(summed_total, 100U);
    EXPECT_GT(one_by_one_total, 100U);
    // The safe radius does skip: without ramps most ticks are small steps inside it.
    if (ramp_time == 0.0 && !with_moves) {
        EXPECT_LT(classified_total, ticks_total / 2) << "the safe radius never skipped a classification";
    }
}

TEST(SceneObjectsClosedForm, TheSummedLawAndTheSafeRadiusGiveThePerObjectSumAndFlags) {
    compare_on_random_scenes(0.0, false, 20261201);
}

// Moves (a Move commit: the place only) are applied without a re-classification (the constant terms
// re-summed, the safe radius shrunk by how far the surfaces moved): the same comparison.
TEST(SceneObjectsClosedForm, TheSameWhileClientsMoveTheirObjects) { compare_on_random_scenes(0.0, true, 99); }

TEST(SceneObjectsClosedForm, TheSameDuringRampsIn) { compare_on_random_scenes(0.03, false, 7); }

// A unilateral plane pressed 5 mm deep (K = 1000 N/m, B = 10 N s/m: b / k = 10 ms). Held still or moved
// slowly, its clamp cannot act and the summed law renders it; pulled out at 1 m/s while still 4 mm in, the
// damping term (10 N) exceeds the spring's (4 N): the force must be clamped to zero, which the summed law
// would not do — the tick must fall back to the plane's own law. Each tick is compared with the law.
TEST(SceneObjectsClosedForm, APressedPlaneIsSummedOnlyWhileItsClampCannotAct) {
    ObjectParams plane;
    plane.id = 1;
    plane.kind = ObjectKind::Plane;
    plane.direction = {0.0, 0.0, 1.0};
    plane.offset = 0.005;  // pressed 5 mm at x = 0
    plane.K = 1000.0;
    plane.B = 10.0;
    LawCheck check(plane);
    Rig& rig = check.rig;
    AxisVector x{0.0, 0.0, 0.0};
    auto tick = [&](const AxisVector& to) { return check.tick(to, "z = " + std::to_string(to[2])); };
    for (int k = 0; k < 10; ++k) tick(x);  // still
    for (int k = 0; k < 10; ++k) {         // 1 mm/s: b/k ||v|| = 10 um
        x[2] += 1e-6;
        tick(x);
    }
    EXPECT_EQ(rig.objects.pressed_summed(), 20U);
    EXPECT_EQ(rig.objects.pressed_fallbacks(), 0U);
    x[2] = 0.001;  // pulled out at 1 m/s: K p = 4 N < B v = ~10 N
    const AxisVector f = tick(x);
    EXPECT_EQ(f[2], 0.0);
    EXPECT_EQ(rig.objects.pressed_fallbacks(), 1U);
    tick(x);  // at rest again, 4 mm in: summed (the test holds again)
    EXPECT_EQ(rig.objects.pressed_summed(), 21U);
    x[2] = 0.006;  // out of the wall, 1 mm beyond it: no force, no contact, one by one
    EXPECT_EQ(tick(x)[2], 0.0);
    EXPECT_EQ(rig.objects.pressed_fallbacks(), 2U);
}

// A proxy moved every tick for 20 000 ticks among 63 still objects: the compensated update of the summed
// constant (TwoSum, scene_objects_affine.cpp) does not drift. Each tick is compared with the per-object sum,
// within the bound of compare_on_random_scenes.
TEST(SceneObjectsClosedForm, TwentyThousandMovesDoNotDriftFromThePerObjectSum) {
    std::mt19937_64 rng(314);
    Rig rig(0.0);
    std::vector<ObjectParams> objs;
    ObjectCommit commit;
    commit.seq = 1;
    for (std::size_t i = 0; i < kSceneObjectCapacity; ++i) {
        ObjectParams o = random_object(rng, static_cast<std::uint32_t>(i + 1));
        if (i == 0) {  // the proxy: a spring to a point
            o.kind = ObjectKind::Spring;
            o.constraint = SpringConstraint::Point;
        }
        objs.push_back(o);
        commit.updates[commit.count++] = SlotUpdate{static_cast<std::uint8_t>(i), SlotUpdate::Action::Set, o};
    }
    ASSERT_TRUE(rig.ring.try_push(commit));
    const AxisVector x{0.001, -0.002, 0.0005};  // held: no re-classification, every move is an update
    std::uniform_real_distribution<double> pos(-0.01, 0.01);
    double worst = 0.0;
    const std::uint64_t c0 = rig.objects.classifications();
    for (int k = 0; k < 20000; ++k) {
        objs[0].point = {pos(rng), pos(rng), pos(rng)};
        ObjectCommit move;
        move.seq = static_cast<std::uint64_t>(k + 2);
        move.updates[move.count++] = SlotUpdate{0, SlotUpdate::Action::Move, objs[0]};
        ASSERT_TRUE(rig.ring.try_push(move));
        rig.objects.apply_commits();
        AxisVector f{};
        ASSERT_TRUE(rig.objects.add_forces(x, f));
        AxisVector expected{};
        double magnitude = 0.0;
        for (const ObjectParams& o : objs) {
            const Reference r = reference_force(o, x, {0.0, 0.0, 0.0}, 1.0, 1.0, 1.0);
            for (std::size_t a = 0; a < 3; ++a) expected[a] += r.f[a];
            magnitude += r.magnitude;
        }
        const double bound = 2.0 * (4.0 * kSceneObjectCapacity + 10.0) * kEps * magnitude;
        for (std::size_t a = 0; a < 3; ++a) {
            ASSERT_LE(std::fabs(f[a] - expected[a]), bound) << "move " << k << " axis " << a;
            worst = std::max(worst, std::fabs(f[a] - expected[a]) / (kEps * magnitude));
        }
    }
    EXPECT_LE(rig.objects.classifications() - c0, 1U);  // the first tick's only
    RecordProperty("worst_error_in_eps_of_magnitudes", std::to_string(worst));
}

// Moving an object (a Move commit every tick) re-sums the law: the force follows the moved object at once.
TEST(SceneObjectsClosedForm, AProxyMovedEveryTickIsFollowedAtOnce) {
    Rig rig(0.0);
    ObjectParams spring;
    spring.id = 1;
    spring.kind = ObjectKind::Spring;
    spring.constraint = SpringConstraint::Point;
    spring.K = 500.0;
    ObjectCommit c;
    c.seq = 1;
    c.updates[c.count++] = SlotUpdate{0, SlotUpdate::Action::Set, spring};
    ASSERT_TRUE(rig.ring.try_push(c));
    for (int k = 0; k < 50; ++k) {
        ObjectCommit m;
        m.seq = static_cast<std::uint64_t>(k + 2);
        spring.point = {1e-4 * k, 0, 0};
        m.updates[m.count++] = SlotUpdate{0, SlotUpdate::Action::Move, spring};
        ASSERT_TRUE(rig.ring.try_push(m));
        rig.objects.apply_commits();
        AxisVector f{};
        ASSERT_TRUE(rig.objects.add_forces({0, 0, 0}, f));
        EXPECT_NEAR(f[0], 500.0 * 1e-4 * k, 1e-12) << k;
    }
}

// A move re-bounds the safe radius by the moved surface's own new distance to where the scene was
// classified (not by how far it moved): each object here is classified 5 mm from its surface, moved to
// 1.5 mm (still beyond kNearDistance, so it is not re-classified), and the handle then walks 2 mm towards
// it in 0.1 mm steps — within the old 5 mm radius, across the new surface. Every tick is compared with the
// object's own law (force within 1e-12 N, flag exact): a loop that kept the old radius would miss the
// contact. Moves that carry a far surface across the handle, or within kNearDistance of it, re-classify.
TEST(SceneObjectsClosedForm, AMovedSurfaceBoundsTheSafeRadiusByItsNewDistance) {
    std::vector<ObjectParams> cases;
    ObjectParams plane;  // unilateral, out of contact: the solid is x < offset
    plane.id = 1;
    plane.kind = ObjectKind::Plane;
    plane.direction = {1.0, 0.0, 0.0};
    plane.offset = -0.005;
    plane.K = 1000.0;
    plane.B = 1.0;
    cases.push_back(plane);
    ObjectParams bilateral = plane;  // its flag (p > 0) must follow, its force is linear anyway
    bilateral.bilateral = true;
    cases.push_back(bilateral);
    ObjectParams field;  // the handle 5 mm outside a sphere of 5 mm radius
    field.id = 1;
    field.kind = ObjectKind::Field;
    field.point = {-0.010, 0.0, 0.0};
    field.radius = 0.005;
    field.force = {1.0, 0.0, 0.0};
    field.B = 0.5;
    cases.push_back(field);
    ObjectParams inside = field;  // the handle 5 mm inside a sphere of 10 mm radius, leaving it
    inside.point = {0.005, 0.0, 0.0};
    inside.radius = 0.010;
    cases.push_back(inside);
    for (std::size_t c = 0; c < cases.size(); ++c) {
        LawCheck check(cases[c]);
        Rig& rig = check.rig;
        ObjectParams& o = check.object;
        AxisVector x{};
        auto tick = [&](const AxisVector& to, int k) {
            check.tick(to, "case " + std::to_string(c) + " tick " + std::to_string(k));
        };
        tick(x, 0);
        tick(x, 1);
        const std::uint64_t classified = rig.objects.classifications();
        if (o.kind == ObjectKind::Plane) {
            o.offset = -0.0015;
        } else if (c == 2) {
            o.point = {-0.0065, 0.0, 0.0};  // its sphere 1.5 mm from the handle
        } else {
            o.point = {0.0085, 0.0, 0.0};  // the handle 1.5 mm inside the sphere's surface (at x = -1.5 mm)
        }
        ObjectCommit move;
        move.seq = 2;
        move.updates[move.count++] = SlotUpdate{0, SlotUpdate::Action::Move, o};
        ASSERT_TRUE(rig.ring.try_push(move));
        tick(x, 2);
        EXPECT_EQ(rig.objects.classifications(), classified) << "case " << c << ": a move 1.5 mm away re-classified";
        bool contact_changed = false;
        const bool before = rig.objects.contact_mask() != 0;
        for (int k = 3; k < 23; ++k) {
            x[0] -= 1e-4;
            tick(x, k);
            contact_changed = contact_changed || (rig.objects.contact_mask() != 0) != before;
        }
        EXPECT_TRUE(contact_changed) << "case " << c << ": the walk did not cross the moved surface";
    }
}

}  // namespace closed_form
}  // namespace hapticd
