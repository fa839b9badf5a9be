// SPDX-License-Identifier: Apache-2.0
// The force limiter (scene/force_limiter.hpp) and what the clients' objects tell it (SceneObjects::law_change()):
//  * the rules of the limiter against their own statement, on random sequences: the force written is within
//    max_force; a tick whose law changed as a whole steps it by at most s = max_force_rate T; a tick that shifted
//    the law by J holds back J, releases s of what is held, and writes a force between the last one and the law's;
//    on a tick with no change the offset from the law shrinks by exactly s (or to zero), whatever the law's force
//    does;
//  * the shift the objects report for their moves against the force itself: with the handle held still the
//    law's change from one tick to the next is the scene's change alone, so on every tick that is not a whole
//    change the shift must equal it (planes, springs, fields; moves at once and interpolated).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>

#include "scene/force_limiter.hpp"
#include "scene/scene_objects.hpp"

namespace hapticd {
namespace force_limiter_test {

constexpr double kT = 1e-3;

double inf_norm(const AxisVector& v) { return std::max({std::fabs(v[0]), std::fabs(v[1]), std::fabs(v[2])}); }

AxisVector minus(const AxisVector& a, const AxisVector& b) { return {a[0] - b[0], a[1] - b[1], a[2] - b[2]}; }

AxisVector saturated(const AxisVector& v, double m) {
    AxisVector s{};
    for (std::size_t a = 0; a < 3; ++a) s[a] = std::clamp(v[a], -m, m);
    return s;
}

// An offset left by a whole change decays by s per tick, in its own direction, whatever the law's force does
// (here a force that jumps by up to 8 N per tick inside the 10 N limit): the written force less the law's is the
// offset's closed form o_k = o_0 (1 - k s / ||o_0||) until it is zero.
TEST(ForceLimiter, WithoutAChangeTheOffsetDecaysBySPerTickWhateverTheLawDoes) {
    const double s = 1.0;
    ForceLimiter l(10.0, s / kT, kT, 3);
    (void)l.step({0.0, 0.0, 0.0}, LawChange::whole_change());
    (void)l.step({4.5, -3.0, 0.0}, LawChange::whole_change());  // a step of 4.5 N asked: 1 N taken, (-3.5, 2.333) held
    const AxisVector o0 = l.offset();
    EXPECT_NEAR(o0[0], -3.5, 1e-12);
    EXPECT_NEAR(o0[1], 3.5 * 2.0 / 3.0, 1e-12);
    std::mt19937_64 rng(7);
    std::uniform_real_distribution<double> force(-4.0, 4.0);
    for (int k = 1; k <= 6; ++k) {
        const AxisVector target{force(rng), force(rng), force(rng)};
        const AxisVector w = l.step(target, LawChange{});
        const double factor = std::max(0.0, 1.0 - k * s / 3.5);
        for (std::size_t a = 0; a < 3; ++a) EXPECT_NEAR(w[a] - target[a], factor * o0[a], 1e-12) << k;
    }
    EXPECT_EQ(l.offset(), AxisVector{});
}

// Random sequences of the three kinds of tick, laws inside and beyond the limit (10 N), shifts up to 30 N.
TEST(ForceLimiter, EveryTickKeepsItsRuleOnRandomSequences) {
    const double m = 10.0, s = 2.5;
    ForceLimiter l(m, s / kT, kT, 3);
    std::mt19937_64 rng(11);
    std::uniform_real_distribution<double> force(-15.0, 15.0), shift(-30.0, 30.0);
    std::uniform_int_distribution<int> kind(0, 2);
    int clamped = 0;
    AxisVector last{};
    const double tol = 1e-12;
    for (int j = 0; j < 20000; ++j) {
        const AxisVector target{force(rng), force(rng), force(rng)};
        LawChange c;
        const int k = kind(rng);
        if (k == 1) c.whole = true;
        if (k == 2) c.shift = {shift(rng), shift(rng), shift(rng)};
        const AxisVector offset_before = l.offset();
        const AxisVector w = l.step(target, c);
        const AxisVector g = saturated(target, m);
        ASSERT_LE(inf_norm(w), m) << j;
        const AxisVector o = l.offset();
        if (c.whole || c.shift != AxisVector{}) {
            // o = shrink(o_before - J) (or w_before - g), then w clamped per axis between the last force and g.
            const AxisVector u = c.whole ? minus(last, g) : minus(offset_before, c.shift);
            const double held = inf_norm(u), keep = held > s ? 1.0 - s / held : 0.0;
            for (std::size_t a = 0; a < 3; ++a) {
                const double lo = std::min(last[a], g[a]), hi = std::max(last[a], g[a]);
                ASSERT_EQ(w[a], std::clamp(g[a] + keep * u[a], lo, hi)) << j;
                ASSERT_LE(std::fabs(w[a] - last[a]), std::fabs(g[a] + keep * u[a] - last[a]) + tol) << j;
                ASSERT_EQ(o[a], w[a] - g[a]) << j;
            }
            if (c.whole) {
                ASSERT_LE(inf_norm(minus(w, last)), s + tol) << j;
            }
            bool moved = false;
            for (std::size_t a = 0; a < 3; ++a) moved = moved || w[a] != g[a] + keep * u[a];
            clamped += !c.whole && moved ? 1 : 0;
        } else {
            // o = shrink(o_before), independent of the target; written = sat(g + o).
            const double before = inf_norm(offset_before), keep = before > s ? 1.0 - s / before : 0.0;
            for (std::size_t a = 0; a < 3; ++a) ASSERT_EQ(o[a], keep * offset_before[a]) << j;
            ASSERT_EQ(w, saturated(AxisVector{g[0] + o[0], g[1] + o[1], g[2] + o[2]}, m)) << j;
        }
        last = w;
    }
    EXPECT_GT(clamped, 1000);  // shifts the clamp between the last force and the law's acted on
    EXPECT_GT(l.stats().rate_limited_ticks, 1000U);
    EXPECT_GT(l.stats().saturated_ticks, 1000U);
}

// A non-finite shift is taken as a whole change (the force stays finite and within one step of the last).
TEST(ForceLimiter, ANonFiniteShiftCountsAsAWholeChange) {
    ForceLimiter l(10.0, 1000.0, kT, 3);
    (void)l.step({3.0, 0.0, 0.0}, LawChange::whole_change());
    const AxisVector w = l.step({3.0, 0.0, 0.0}, LawChange{false, {NAN, 0.0, 0.0}});
    EXPECT_DOUBLE_EQ(w[0], 2.0);
    for (double v : w) EXPECT_TRUE(std::isfinite(v));
}

ObjectParams plane(std::uint32_t id, const AxisVector& n, double offset, double K, double B, bool bilateral) {
    ObjectParams o;
    o.id = id;
    o.kind = ObjectKind::Plane;
    o.bilateral = bilateral;
    o.direction = n;
    o.offset = offset;
    o.K = K;
    o.B = B;
    return o;
}

AxisVector unit(std::mt19937_64& rng) {
    std::normal_distribution<double> g;
    AxisVector v{g(rng), g(rng), g(rng)};
    const double r = std::sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
    for (double& c : v) c /= r;
    return v;
}

// Random scenes of planes (bilateral and unilateral, damped), springs of each constraint and fields, moved at random
// ticks at once or through the move hold (the damping then acting relative to the surface's rate), with the handle
// held still at a random point: on each tick that is not a whole change the law's change is the reported shift,
// contacts that open or close with the move included. Tolerance: the forces are sums of at most 8 terms under 1e3 N,
// each rounded to 2^-52 relative, and the shift is a difference of such terms: 1e-9 N is 1e3 times that bound; a
// shift computed from the wrong pose (a missed or a doubled move) is off by K times a move, >= 1 mN.
TEST(SceneObjectsLawChange, TheShiftOfMovesIsTheLawsChangeAtAStillHandle) {
    std::mt19937_64 rng(3);
    std::uniform_real_distribution<double> u(-1.0, 1.0);
    int checked = 0, moved = 0, opened = 0;
    for (int scene = 0; scene < 60; ++scene) {
        const double hold = scene % 2 == 0 ? 0.0 : 0.02;
        CommitRing ring(16);
        SceneObjectsConfig cfg;
        cfg.period = kT;
        cfg.ramp_time = 0.01;
        cfg.axes = 3;
        cfg.move_interval_max = hold;
        SceneObjects objects(cfg, ring);
        const AxisVector x{0.01 * u(rng), 0.01 * u(rng), 0.01 * u(rng)};
        std::vector<ObjectParams> params;
        for (std::uint32_t i = 0; i < 6; ++i) {
            const int kind = static_cast<int>(rng() % 4);
            const AxisVector n = unit(rng);
            const double K = 1e3 + 4e3 * (u(rng) + 1.0), B = 5.0 * (u(rng) + 1.0);
            ObjectParams p;
            if (kind == 0) p = plane(i + 1, n, 0.01 * u(rng), K, B, true);
            if (kind == 1) p = plane(i + 1, n, 0.01 * u(rng), K, B, false);
            if (kind == 2) {
                p.id = i + 1;
                p.kind = ObjectKind::Spring;
                p.constraint = static_cast<SpringConstraint>(rng() % 3);
                p.direction = n;
                p.point = {0.01 * u(rng), 0.01 * u(rng), 0.01 * u(rng)};
                p.K = K;
                p.B = B;
            }
            if (kind == 3) {
                p.id = i + 1;
                p.kind = ObjectKind::Field;
                p.point = {0.01 * u(rng), 0.01 * u(rng), 0.01 * u(rng)};
                p.radius = 0.012;
                p.force = {u(rng), u(rng), u(rng)};
                for (auto& row : p.jacobian) row = {-K * 0.1 * (u(rng) + 1.0), 0.0, 0.0};
                p.B = B;
            }
            params.push_back(p);
        }
        std::uint64_t seq = 0;
        ObjectCommit add;
        add.seq = ++seq;
        for (std::size_t i = 0; i < params.size(); ++i) {
            add.updates[add.count++] = SlotUpdate{static_cast<std::uint8_t>(i), SlotUpdate::Action::Set, params[i]};
        }
        ASSERT_TRUE(ring.try_push(add));
        AxisVector previous{};
        std::uint64_t previous_mask = 0;
        for (int j = 0; j < 400; ++j) {
            if (j > 20 && rng() % 7 == 0) {
                ObjectCommit move;
                move.seq = ++seq;
                const std::size_t i = rng() % params.size();
                ObjectParams& p = params[i];
                p.offset += 0.001 * u(rng);
                for (double& c : p.point) c += 0.001 * u(rng);
                if (p.kind == ObjectKind::Field) p.force = {u(rng), u(rng), u(rng)};
                move.updates[move.count++] = SlotUpdate{static_cast<std::uint8_t>(i), SlotUpdate::Action::Move, p};
                ASSERT_TRUE(ring.try_push(move));
            }
            objects.apply_commits();
            AxisVector f{};
            ASSERT_TRUE(objects.add_forces(x, f));
            const LawChange& c = objects.law_change();
            if (j > 3 && !c.whole) {
                const AxisVector change = minus(f, previous);
                for (std::size_t a = 0; a < 3; ++a) ASSERT_NEAR(c.shift[a], change[a], 1e-9) << scene << " " << j;
                ++checked;
                moved += inf_norm(c.shift) > 1e-6 ? 1 : 0;
            }
            previous = f;
            opened += objects.contact_mask() != previous_mask && !c.whole ? 1 : 0;
            previous_mask = objects.contact_mask();
        }
    }
    std::printf("[ law change ] %d ticks checked, %d of them with a move's shift, %d with a contact opened or closed\n",
                checked, moved, opened);
    EXPECT_GT(moved, 1000);
    EXPECT_GT(opened, 10);
}

}  // namespace force_limiter_test
}  // namespace hapticd
