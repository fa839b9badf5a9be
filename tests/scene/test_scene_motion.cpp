// SPDX-License-Identifier: Apache-2.0
// The loop's rendering of moving and appearing objects (scene/scene_objects.hpp): moves through a first-order
// hold over the measured update interval, damping relative to the interpolated motion, and the god-object
// activation of a unilateral plane that appears around the handle. Each expectation is the rule's own closed
// form evaluated here (the rendered offset as a function of the tick), not the code path that computes it.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <numbers>

#include "devices/sim_device.hpp"
#include "scene/force_limiter.hpp"
#include "scene/scene_objects.hpp"

namespace hapticd {
namespace {

constexpr double kMotionT = 1e-3;

struct MotionRig {
    CommitRing ring{8};
    SceneObjects objects;
    std::uint64_t seq = 0;
    MotionRig(double ramp, double hold_max, double activation_speed)
        : objects(config(ramp, hold_max, activation_speed), ring) {}
    static SceneObjectsConfig config(double ramp, double hold_max, double activation_speed) {
        SceneObjectsConfig c;
        c.period = kMotionT;
        c.ramp_time = ramp;
        c.axes = 3;
        c.move_interval_max = hold_max;
        c.activation_speed = activation_speed;
        return c;
    }
    void commit(SlotUpdate::Action action, const ObjectParams& p) {
        ObjectCommit c;
        c.seq = ++seq;
        c.updates[c.count++] = SlotUpdate{0, action, p};
        ASSERT_TRUE(ring.try_push(c));
    }
    double tick(const AxisVector& x) {  // the force along -x (the planes below push along n = -x)
        objects.apply_commits();
        AxisVector f{};
        EXPECT_TRUE(objects.add_forces(x, f));
        return -f[0];
    }
};

// A plane with normal -x at `offset`: p = offset + x, solid for x > -offset.
ObjectParams motion_plane(double offset, double K, double B, bool bilateral) {
    ObjectParams o;
    o.id = 5;
    o.kind = ObjectKind::Plane;
    o.bilateral = bilateral;
    o.direction = {-1.0, 0.0, 0.0};
    o.offset = offset;
    o.K = K;
    o.B = B;
    return o;
}

// Poses every 5 ticks, each 10 um further: once the interval is measured (the first pose after the Set comes
// 5 ticks after it), each pose is rendered along a straight line over 5 ticks, the first step in the tick it
// arrives: the offset at the k-th tick after a pose (k = 1 .. 5) is previous + k/5 (new - previous). With
// the handle at rest at x = 0 and B = 0 the force is K times the offset (rounding 1e-12 N).
TEST(SceneMotion, MovesAreAFirstOrderHoldOverTheMeasuredInterval) {
    const double K = 1000.0, d = 10e-6;
    MotionRig rig(0.0, 0.05, 0.0);
    rig.commit(SlotUpdate::Action::Set, motion_plane(0.001, K, 0.0, true));
    double offset = 0.001;
    EXPECT_NEAR(rig.tick({}), K * offset, 1e-12);
    for (int j = 1; j < 5; ++j) rig.tick({});
    for (int pose = 1; pose <= 6; ++pose) {
        const double previous = offset;
        offset += d;
        rig.commit(SlotUpdate::Action::Move, motion_plane(offset, K, 0.0, true));
        for (int k = 1; k <= 5; ++k) {
            const double expected = K * (previous + k / 5.0 * (offset - previous));
            EXPECT_NEAR(rig.tick({}), expected, 1e-12) << "pose " << pose << " tick " << k;
        }
    }
    // A client that stops: the surface goes on along its line for one interval (the next pose might be late),
    // then returns to the last pose over one interval and stays there.
    for (int k = 1; k <= 5; ++k) EXPECT_NEAR(rig.tick({}), K * (offset + k * d / 5.0), 1e-9) << "on, tick " << k;
    for (int k = 1; k <= 5; ++k) EXPECT_NEAR(rig.tick({}), K * (offset + d - k * d / 5.0), 1e-9) << "back, tick " << k;
    for (int j = 0; j < 5; ++j) EXPECT_NEAR(rig.tick({}), K * offset, 1e-12);
    EXPECT_EQ(rig.objects.gliding(), 0U);
}

// The damping acts on the handle's velocity relative to the interpolated surface: a handle that moves with
// the surface (x = -offset + p0, the same velocity) feels K p0 and no damping; at rest it feels the surface's
// velocity times B as well (the commanded poses' rate, d / (5 T)). p0 = 0.1 mm: a plane near its surface
// (evaluated one by one); 2 mm: pressed deep (the summed law).
TEST(SceneMotion, DampingIsRelativeToTheSurfacesMotion) {
    for (const double p0 : {1e-4, 2e-3}) {
        const double K = 1000.0, B = 20.0, d = 10e-6;
        MotionRig rig(0.0, 0.05, 0.0);
        rig.commit(SlotUpdate::Action::Set, motion_plane(0.001, K, B, false));
        double commanded = 0.001;
        double rendered = 0.001;
        AxisVector x{-rendered + p0, 0, 0};
        rig.tick(x);
        for (int j = 1; j < 5; ++j) rig.tick(x);
        for (int pose = 1; pose <= 4; ++pose) {
            const double previous = commanded;
            commanded += d;
            rig.commit(SlotUpdate::Action::Move, motion_plane(commanded, K, B, false));
            for (int k = 1; k <= 5; ++k) {
                rendered = previous + k / 5.0 * (commanded - previous);
                x[0] = -rendered + p0;  // the handle moves with the surface
                const double f = rig.tick(x);
                if (pose >= 2) {  // the first has no velocity history
                    EXPECT_NEAR(f, K * p0, 1e-9) << "pose " << pose << " tick " << k;
                }
            }
        }
        // The same motion with the handle held still: K p + B rate (rate = d / (5 T)); p = rendered + x.
        MotionRig still(0.0, 0.05, 0.0);
        still.commit(SlotUpdate::Action::Set, motion_plane(0.001, K, B, false));
        commanded = 0.001;
        const AxisVector at{-0.001 + p0, 0, 0};
        for (int j = 0; j < 5; ++j) still.tick(at);
        for (int pose = 1; pose <= 3; ++pose) {
            const double previous = commanded;
            commanded += d;
            still.commit(SlotUpdate::Action::Move, motion_plane(commanded, K, B, false));
            for (int k = 1; k <= 5; ++k) {
                rendered = previous + k / 5.0 * (commanded - previous);
                EXPECT_NEAR(still.tick(at), K * (rendered + at[0]) + B * d / (5 * kMotionT), 1e-9) << pose << " " << k;
            }
        }
    }
}

// The same for the affine law (a bilateral plane) and a spring's point: the handle moving with the object by
// the interpolated path feels the stiffness only, once the velocity history covers a whole pose.
TEST(SceneMotion, DampingIsRelativeForBilateralPlanesAndSprings) {
    const double K = 1000.0, B = 20.0, d = 10e-6, off = 2e-4;
    for (const bool spring : {false, true}) {
        MotionRig rig(0.0, 0.05, 0.0);
        ObjectParams o = motion_plane(0.001, K, B, true);
        if (spring) {
            o.kind = ObjectKind::Spring;
            o.constraint = SpringConstraint::Point;
            o.point = {0.001, 0.0, 0.0};
        }
        rig.commit(SlotUpdate::Action::Set, o);
        double commanded = 0.001;
        // plane: p = offset + x (force K p along -x); spring: force -K (x - point) along x, i.e. K (point - x) along +x
        auto place = [&](double rendered) { return AxisVector{spring ? rendered - off : -rendered + off, 0, 0}; };
        for (int j = 0; j < 5; ++j) rig.tick(place(commanded));
        for (int pose = 1; pose <= 4; ++pose) {
            const double previous = commanded;
            commanded += d;
            if (spring) {
                o.point[0] = commanded;
            } else {
                o.offset = commanded;
            }
            rig.commit(SlotUpdate::Action::Move, o);
            for (int k = 1; k <= 5; ++k) {
                const double rendered = previous + k / 5.0 * (commanded - previous);
                const double f = rig.tick(place(rendered));
                if (pose >= 2) {
                    EXPECT_NEAR(spring ? -f : f, K * off, 1e-9)
                        << (spring ? "spring" : "plane") << " pose " << pose << " tick " << k;
                }
            }
        }
    }
}

// The god-object rule: a unilateral plane that appears 5 mm around the handle starts with its surface at the
// handle and moves out by v T per tick, ramping in as usual (stiffness r^2, damping r, r = (j - 1)/30), until
// its gap to the commanded offset is v tau (tau = 20 ms, kActivationTailTime); from there the gap shrinks by
// the factor (1 - T/tau) per tick, in closed form gap_j = v tau (1 - T/tau)^(j - n), n = (depth - v tau)/(v T),
// the surface's speed (gap_{j-1} - gap_j)/T, until the gap is below 1 nm. With the handle held at rest the
// force at tick j (j = 1 for the commit's tick) is r_j^2 K p_j + r_j B s_j (p_j: the surface's distance from
// the handle, s_j its speed), at most the first-tick bound r_1^2 K v T + r_1 B v of docs/protocol.md at j = 1;
// the damping term changes by at most B v T / tau per tick at the end (no step of B v), and the plane stays at
// its commanded offset after. The gains rendered are those of the plane without the rule.
TEST(SceneMotion, APlaneAppearingAroundTheHandleStartsAtItAndMovesOutAtTheActivationSpeed) {
    const double K = 74225.8, B = 223.3, v = 0.01, depth = 0.005, ramp = 0.03, tau = kActivationTailTime;
    MotionRig rig(ramp, 0.05, v);
    rig.commit(SlotUpdate::Action::Set, motion_plane(depth, K, B, false));
    const double linear_ticks = (depth - v * tau) / (v * kMotionT);  // 480 for these values
    const double q = 1.0 - kMotionT / tau;
    auto gap_after = [&](int j) {
        return j <= linear_ticks ? depth - j * v * kMotionT : v * tau * std::pow(q, j - linear_ticks);
    };
    // The tick whose gap falls below kActivationArrival (the next one lands on the offset).
    const int tail_ticks = static_cast<int>(std::ceil(std::log(kActivationArrival / (v * tau)) / std::log(q)));
    const int ticks_to_reach = static_cast<int>(std::lround(linear_ticks)) + tail_ticks + 1;
    double previous = 0.0, largest_change = 0.0;
    for (int j = 1; j <= ticks_to_reach + 20; ++j) {
        const double r = std::min(1.0, (j - 1) * kMotionT / ramp);  // the commit's tick renders r = 0, then steps
        const bool moving = j < ticks_to_reach;
        const double p = moving ? depth - gap_after(j) : depth;
        const double speed = moving ? (gap_after(j - 1) - gap_after(j)) / kMotionT : 0.0;
        const double expected = r * r * K * p + r * B * speed;
        const double f = rig.tick({});
        // The arrival tick itself may fall one tick either way (the offset is a sum of j steps).
        if (std::abs(j - ticks_to_reach) > 1) {
            EXPECT_NEAR(f, expected, 1e-9 * (1 + expected)) << "tick " << j;
        }
        EXPECT_LE(f, r * r * K * p + r * B * v + 1e-9) << "tick " << j;
        if (j == 1) {
            EXPECT_LE(f, r * r * K * v * kMotionT + r * B * v + 1e-12);
        }
        if (j > ramp / kMotionT + 1) largest_change = std::max(largest_change, std::abs(f - previous));
        previous = f;
        if (j == ticks_to_reach + 20) {
            std::array<AxisVector, 3> Kr{}, Br{};
            rig.objects.rendered_gains(Kr, Br);
            EXPECT_DOUBLE_EQ(Kr[0][0], K);
            EXPECT_DOUBLE_EQ(Br[0][0], B);
        }
    }
    // After the ramp: per tick the stiffness term grows by at most K v T and the damping term falls by at most
    // B v T / tau (the tail's speed change), plus 1 nm of K at the arrival; the step B v of an abrupt stop
    // (2.2 N here) does not occur.
    std::printf("[ activation ] largest force change per tick after the ramp %.4f N (abrupt stop: B v = %.4f N)\n",
                largest_change, B * v);
    EXPECT_LE(largest_change, K * v * kMotionT + B * v * kMotionT / tau + K * kActivationArrival + 1e-9);
}

// The rule is for objects that appear: a plane in front of the handle renders as commanded, and so does a
// plane that replaces one in the same slot (a change of gains cross-fades where the old one was).
TEST(SceneMotion, TheActivationRuleLeavesPlanesInFrontOfTheHandleAndReplacementsAlone) {
    const double K = 1000.0;
    MotionRig front(0.0, 0.05, 0.01);
    front.commit(SlotUpdate::Action::Set, motion_plane(0.001, K, 0.0, false));
    EXPECT_DOUBLE_EQ(front.tick({-0.002, 0, 0}), 0.0);
    EXPECT_NEAR(front.tick({-0.0005, 0, 0}), K * 0.0005, 1e-12);  // the commanded surface, at once
    MotionRig replaced(0.0, 0.05, 0.01);
    replaced.commit(SlotUpdate::Action::Set, motion_plane(0.001, K, 0.0, false));
    replaced.tick({-0.0015, 0, 0});
    replaced.commit(SlotUpdate::Action::Set, motion_plane(0.001, 2 * K, 0.0, false));
    EXPECT_NEAR(replaced.tick({-0.0005, 0, 0}), 2 * K * 0.0005, 1e-12);
}

// The README's CE2 plane (K = 74225.8 N/m, B = 223.336 N s/m, normal -x) in closed loop with the simulated device of
// config/devices/sim.toml and its default hand at rest at x = 0 (0.30 kg, 10 N, b_H = 4 N s/m, k_H = 200 N/m), the
// loop's objects (ramp 30 ms) and the force limiter with the given rate.
struct HandLoop {
    static constexpr double K = 74225.8, B = 223.336;
    SimDevice dev;
    CommitRing ring{8};
    SceneObjects objects;
    ForceLimiter limiter;
    bool whole_force = false;  // the limiter's step on the whole force: every tick counted as a whole change
    std::uint64_t seq = 0;
    HandLoop(std::size_t axes, double hold_max, double activation_speed, double max_force_rate)
        : dev(device(axes)),
          objects(MotionRig::config(0.03, hold_max, activation_speed), ring),
          limiter(10.0, max_force_rate, kMotionT, 3) {
        EXPECT_EQ(dev.open(), DeviceStatus::Ok);
    }
    static SimDeviceConfig device(std::size_t axes) {
        SimDeviceConfig dc;
        dc.capabilities.axes = axes;
        dc.capabilities.max_force = 10.0;
        dc.plant = {0.30, 0.0, 0.0};
        dc.period = kMotionT;
        dc.scenario.kind = Scenario::Rest;
        dc.scenario.hand.damping = 4.0;
        dc.scenario.hand.stiffness = 200.0;
        return dc;
    }
    void send(SlotUpdate::Action a, double offset) {
        ObjectCommit c;
        c.seq = ++seq;
        c.updates[c.count++] = SlotUpdate{0, a, motion_plane(offset, K, B, false)};
        EXPECT_TRUE(ring.try_push(c));
    }
    // One tick: the position read (into x) and the force written.
    AxisVector tick(AxisVector& x) {
        AxisVector f{};
        EXPECT_EQ(dev.read_position(x), DeviceStatus::Ok);
        objects.apply_commits();
        EXPECT_TRUE(objects.add_forces(x, f));
        f = limiter.step(f, whole_force ? LawChange::whole_change() : objects.law_change());
        EXPECT_EQ(dev.write_force(f), DeviceStatus::Ok);
        return f;
    }
};

// The 200 Hz moving wall in closed loop with the real simulated device and hand (0.30 kg, b_H = 4 N s/m,
// k_H = 200 N/m, at rest at x = 0): the CE2 plane of the default profile (K = 74225.8, B = 223.336), normal -x,
// offset 5 mm + 2 mm sin(2 pi t), added around the handle at tick 0 and moved with poses every 5 ticks,
// alternately 4 and 6 ticks apart from 1 s on (a client's jitter). Over the tracking phase (0.7 .. 3 s):
//  * no release: the hand presses with k_H x >= 0.6 N, the interpolated wall accelerates at most 0.08 m/s^2
//    (m a = 0.024 N) and the damping acts relative to the wall, so nothing pulls the handle off;
//  * roughness (RMS of f_j - 2 f_{j-1} + f_{j-2}) <= (K T + B) (v_max / n) sqrt(2 / n) = 0.47 N (n = 5,
//    v_max = 12.6 mm/s): a pose one tick off the mean interval changes the rendered surface's velocity by at most
//    v_max / n, which steps the force's slope by K T v_max / n and, through the damping's reference, the force
//    by at most B v_max / n; each enters at most two second differences per interval of n ticks.
// With moves applied at once the same run releases the contact again and again (the assertion's failure case).
TEST(SceneMotion, TheMovingWallTracksWithoutChatterInClosedLoopWithTheHand) {
    for (const bool hold : {true, false}) {
        // The daemon's last stage (10 N per axis; its step, 9.999 N, binds on no change of a force within 0 .. 10 N).
        HandLoop loop(3, hold ? 0.05 : 0.0, hold ? 0.01 : 0.0, 9999.0);
        const double K = HandLoop::K, B = HandLoop::B;
        loop.send(SlotUpdate::Action::Set, 0.005);
        int next_pose = 5, releases = 0, counted = 0;
        double f1 = 0.0, f2 = 0.0, sum2 = 0.0;
        for (int j = 0; j < 3000; ++j) {
            if (j == next_pose) {
                loop.send(SlotUpdate::Action::Move, 0.005 + 0.002 * std::sin(2.0 * std::numbers::pi * j * kMotionT));
                next_pose += j < 1000 ? 5 : (j / 5) % 2 == 0 ? 4 : 6;
            }
            AxisVector x{};
            const double fn = -loop.tick(x)[0];
            if (j >= 700) {
                releases += fn == 0.0 && f1 > 0.0 ? 1 : 0;
                const double d2 = fn - 2.0 * f1 + f2;
                sum2 += d2 * d2;
                ++counted;
            }
            f2 = f1;
            f1 = fn;
        }
        const double roughness = std::sqrt(sum2 / counted);
        std::printf("[ moving wall, closed loop ] moves %s: %d releases, roughness %.4f N over 2.3 s\n",
                    hold ? "interpolated" : "at once", releases, roughness);
        if (hold) {
            EXPECT_EQ(releases, 0);
            EXPECT_LE(roughness, (K * kMotionT + B) * 0.0126 / 5.0 * std::sqrt(2.0 / 5.0));
        } else {
            EXPECT_GT(releases, 10);
        }
    }
}

// The README's plane moved under the resting hand, with the daemon's default force limiter (10 N, 2.5 N per tick):
// the simulated device and hand of config/devices/sim.toml (0.30 kg, k_H = 200 N/m, b_H = 4 N s/m, at rest at
// x = 0), the CE2 plane (K = 74225.8, B = 223.336, normal -x) added at offset 5 mm, which the hand comes to rest
// on (activation at 0.01 m/s), then one move to offset 3 mm at 1 s (interpolated over the 50 ms hold). In the last
// second the handle rests on the moved surface, where the hand's spring balances the wall's:
// k_H (-x) = K (0.003 + x), x = -0.003 K / (K + k_H). The modes of wall and hand have decayed by then (the slowest,
// the hand's spring against the wall's damper, has the time constant B / (K + k_H) = 3 ms; a second is ~330 of
// them), so the handle is there to 1 um. The same step on the whole force (the law's response included) sustains a
// bounce by more than a millimetre (docs/hapticd.md, "Force limits").
TEST(SceneMotion, AMovedPlaneUnderTheRestingHandSettlesWithTheDefaultForceLimiter) {
    // whole_force: the same step applied to the whole force (every tick a whole change), the failure case.
    for (const bool whole_force : {false, true}) {
        HandLoop loop(1, 0.05, 0.01, default_max_force_rate(10.0, kMotionT));
        loop.whole_force = whole_force;
        const double K = HandLoop::K;
        loop.send(SlotUpdate::Action::Set, 0.005);
        double lo = 1.0, hi = -1.0;
        int releases = 0;
        double last = 0.0;
        for (int j = 0; j < 3000; ++j) {
            if (j == 1000) loop.send(SlotUpdate::Action::Move, 0.003);
            AxisVector x{};
            const AxisVector f = loop.tick(x);
            if (j >= 1000) releases += f[0] == 0.0 && last != 0.0 ? 1 : 0;
            last = f[0];
            if (j >= 2000) {
                lo = std::min(lo, x[0]);
                hi = std::max(hi, x[0]);
            }
        }
        const double rest = -0.003 * K / (K + 200.0);
        std::printf(
            "[ moved plane, default limiter%s ] x in [%.6f, %.6f] mm over the last second (rest %.6f mm); %d "
            "releases after the move; %llu rate-limited ticks, largest step %.4g N\n",
            whole_force ? " on the whole force" : "", 1e3 * lo, 1e3 * hi, 1e3 * rest, releases,
            static_cast<unsigned long long>(loop.limiter.stats().rate_limited_ticks),
            loop.limiter.stats().largest_step);
        if (whole_force) {
            EXPECT_GT(hi - lo, 1e-3);  // still bouncing by more than a millimetre a second after the move
        } else {
            EXPECT_NEAR(lo, rest, 1e-6);
            EXPECT_NEAR(hi, rest, 1e-6);
        }
    }
}

}  // namespace
}  // namespace hapticd
