// SPDX-License-Identifier: Apache-2.0
// The simulated hand's grips and releases (devices/sim_device.hpp, config/hand_schedule.hpp,
// docs/simulated-hand.md "Grip and release"): the schedule's text, the plant across its events against the
// closed-form piecewise solution, and a wall's energy across a release and a grip.
#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>
#include <vector>

#include "config/hand_schedule.hpp"
#include "devices/sim_device.hpp"

namespace hapticd {
namespace {

// The Falcon held (Table II: 0.30 kg with the hand, 0.22 kg without), 1 axis, the default hand (b_H = 13.3 s^-1 m,
// k_H = 667 s^-2 m at 0.30 kg), 1 kHz; the hand at rest at the centre (0).
SimDeviceConfig falcon_hand(const std::string& schedule, double delay = 0.0) {
    SimDeviceConfig c;
    c.capabilities.axes = 1;
    c.capabilities.max_force = 100.0;
    c.capabilities.inherent_delay = delay;
    c.plant = {0.30, 0.0, 0.0};
    c.period = 1e-3;
    c.scenario.kind = Scenario::Rest;
    c.scenario.hand.damping = 4.0;
    c.scenario.hand.stiffness = 200.0;
    c.scenario.hand.release_mass = 0.08;
    c.scenario.schedule = parse_hand_schedule(schedule);
    return c;
}

// m x'' + b x' + k (x - x_H) = F from (x0, v0) after t, closed form: underdamped (k > 0) or a free mass (k = b = 0).
struct State {
    double x, v;
};
State closed_form(State s, double m, double b, double k, double x_H, double F, double t) {
    if (k == 0.0 && b == 0.0) return {s.x + s.v * t + F * t * t / (2.0 * m), s.v + F * t / m};
    const double x_eq = x_H + F / k;
    const double z0 = s.x - x_eq;
    const double sigma = b / (2.0 * m);
    const double w0sq = k / m;
    const double wd = std::sqrt(w0sq - sigma * sigma);
    const double e = std::exp(-sigma * t), c = std::cos(wd * t), sn = std::sin(wd * t);
    return {x_eq + e * (z0 * c + (s.v + sigma * z0) / wd * sn), e * (s.v * c - (w0sq * z0 + sigma * s.v) / wd * sn)};
}

TEST(HandSchedule, ParsesEventsAndDescribesThem) {
    const auto e = parse_hand_schedule(" release@2.0, grip@4 ,arm@5.5:k=400:b=8,arm@6:b=2 ");
    ASSERT_EQ(e.size(), 4U);
    EXPECT_EQ(e[0].kind, HandEventKind::Release);
    EXPECT_EQ(e[0].time, 2.0);
    EXPECT_EQ(e[1].kind, HandEventKind::Grip);
    EXPECT_EQ(e[1].time, 4.0);
    EXPECT_EQ(e[2].kind, HandEventKind::Arm);
    EXPECT_EQ(*e[2].stiffness, 400.0);
    EXPECT_EQ(*e[2].damping, 8.0);
    EXPECT_FALSE(e[3].stiffness.has_value());
    EXPECT_EQ(*e[3].damping, 2.0);
    EXPECT_EQ(describe(e), "release@2,grip@4,arm@5.5:k=400:b=8,arm@6:b=2");
    EXPECT_TRUE(parse_hand_schedule("").empty());
    EXPECT_TRUE(parse_hand_schedule("  ").empty());
}

// Every refusal names the option, the event and what is accepted.
TEST(HandSchedule, RefusesBadTextNamingTheEventAndTheAcceptedForm) {
    struct Case {
        const char* text;
        std::vector<std::string> parts;
    };
    const std::vector<Case> cases{
        {"release@2,grip@1", {"event 'grip@1'", "not after the previous event's (2 s)", "strictly increasing"}},
        {"release@2,grip@2", {"event 'grip@2'", "strictly increasing"}},
        {"drop@1", {"unknown event 'drop'", "release@T, grip@T, arm@T:k=K:b=B"}},
        {"release@-1", {"time '-1'", "0 .. 1e7 s"}},
        {"release@nan", {"time 'nan'", "0 .. 1e7 s"}},
        {"release@1e8", {"time '1e8'", "0 .. 1e7 s"}},
        {"release@", {"time ''"}},
        {"release@2s", {"time '2s'"}},
        {"release", {"no '@'"}},
        {"release@1,", {"event ''", "no '@'"}},
        {"grip@1", {"already holds the handle"}},
        {"release@1,release@2", {"event 'release@2'", "already off the handle"}},
        {"release@1:k=3", {"only arm@T takes k=K and b=B"}},
        {"arm@1", {"no k=K or b=B"}},
        {"arm@1:k=-3", {"k=0 .. 1e9 N/m"}},
        {"arm@1:b=inf", {"b=0 .. 1e6 N s/m"}},
        {"arm@1:m=3", {"unknown parameter 'm=3'"}},
    };
    for (const Case& c : cases) {
        try {
            (void)parse_hand_schedule(c.text);
            ADD_FAILURE() << "accepted '" << c.text << "'";
        } catch (const std::invalid_argument& e) {
            const std::string what = e.what();
            EXPECT_EQ(what.rfind("hand-schedule = '" + std::string(c.text) + "' is invalid", 0), 0U) << what;
            for (const auto& part : c.parts) EXPECT_NE(what.find(part), std::string::npos) << part << " in: " << what;
        }
    }
}

// A constant loop force F on the handle held by the default hand, released at 0.5 s, gripped at 1.0 s, the arm
// stiffened at 1.25 s: at every tick the simulated device equals the closed-form solution of each piece (the
// damped hand around x_H = 0, the free 0.22 kg, the damped hand around the grip's position x_H = x(1.0 s) with
// F_H's spring adding nothing there, then k_H 400, b_H 8 around the same x_H), each piece starting from the
// previous one's end: position and velocity continuous at every event, so the momentum is m v with the mass of
// the piece (the hand leaves with, and joins at, the handle's velocity). Tolerance 1e-12 m (1e-11 m/s): the ZOH
// is exact and each step rounds at ~1e-16 relative; over 1500 steps of a state of ~0.3 m that is ~1e-13.
TEST(HandSchedule, FreeHandleWithAConstantForceMatchesTheClosedFormAcrossReleaseAndGrip) {
    const double F = 0.5, T = 1e-3;
    SimDevice dev(falcon_hand("release@0.5,grip@1.0,arm@1.25:k=400:b=8"));
    ASSERT_EQ(dev.open(), DeviceStatus::Ok);
    ASSERT_EQ(dev.home(), DeviceStatus::Ok);
    struct Piece {
        int from;  // tick
        double m, b, k;
        bool grip;
    };
    const std::vector<Piece> pieces{{0, 0.30, 4.0, 200.0, false},
                                    {500, 0.22, 0.0, 0.0, false},
                                    {1000, 0.30, 4.0, 200.0, true},
                                    {1250, 0.30, 8.0, 400.0, false}};
    State start{0.0, 0.0};
    double x_H = 0.0;
    std::size_t piece = 0;
    double worst_x = 0.0, worst_v = 0.0;
    for (int j = 0; j <= 1500; ++j) {
        AxisVector p{};
        ASSERT_EQ(dev.read_position(p), DeviceStatus::Ok);
        while (piece + 1 < pieces.size() && j >= pieces[piece + 1].from) {
            const Piece& q = pieces[piece];
            start = closed_form(start, q.m, q.b, q.k, x_H, F, (pieces[piece + 1].from - q.from) * T);
            ++piece;
            if (pieces[piece].grip) x_H = start.x;
        }
        const Piece& q = pieces[piece];
        const State want = closed_form(start, q.m, q.b, q.k, x_H, F, (j - q.from) * T);
        worst_x = std::max(worst_x, std::abs(p[0] - want.x));
        worst_v = std::max(worst_v, std::abs(dev.true_velocity(0) - want.v));
        ASSERT_NEAR(p[0], want.x, 1e-12) << "tick " << j;
        ASSERT_NEAR(dev.true_velocity(0), want.v, 1e-11) << "tick " << j;
        AxisVector f{};
        f[0] = F;
        ASSERT_EQ(dev.write_force(f), DeviceStatus::Ok);
    }
    std::printf("[ hand schedule ] closed form across release/grip/arm: max |dx| = %.3g m, |dv| = %.3g m/s\n", worst_x,
                worst_v);
    // The device's own record of the events.
    const auto& ev = dev.hand_events();
    ASSERT_EQ(ev.size(), 3U);
    EXPECT_EQ(ev[0].tick, 500);
    EXPECT_DOUBLE_EQ(ev[0].mass, 0.22);
    EXPECT_EQ(ev[0].stiffness, 0.0);
    EXPECT_EQ(ev[1].tick, 1000);
    EXPECT_DOUBLE_EQ(ev[1].mass, 0.30);
    EXPECT_EQ(ev[1].stiffness, 200.0);
    EXPECT_NEAR(ev[1].position, x_H, 1e-12);
    EXPECT_EQ(ev[2].tick, 1250);
    EXPECT_EQ(ev[2].stiffness, 400.0);
    EXPECT_EQ(ev[2].damping, 8.0);
    EXPECT_TRUE(dev.hand_held());
    // home() restarts the schedule.
    ASSERT_EQ(dev.home(), DeviceStatus::Ok);
    EXPECT_EQ(dev.hand_events()[0].tick, -1);
    EXPECT_DOUBLE_EQ(dev.moving_mass(0), 0.30);
}

// The intent's force F_H is the hand's: off while released (read_external_force gives 0, the handle coasts), back
// at the grip. A step of 1 N held by the hand (x -> F_H / k_H), released at 0.2 s: the free 0.22 kg keeps the
// velocity it had (no force at all: the loop writes 0).
TEST(HandSchedule, TheIntentForceLeavesWithTheHand) {
    auto c = falcon_hand("release@0.2,grip@0.3");
    c.scenario.kind = Scenario::Step;
    c.scenario.step_force = 1.0;
    SimDevice dev(c);
    ASSERT_EQ(dev.open(), DeviceStatus::Ok);
    AxisVector p{}, f{};
    double v_release = 0.0;
    for (int j = 0; j <= 400; ++j) {
        ASSERT_EQ(dev.read_position(p), DeviceStatus::Ok);
        ASSERT_EQ(dev.read_external_force(f), DeviceStatus::Ok);
        if (j == 201) v_release = dev.true_velocity(0);
        if (j > 201 && j <= 300) {
            EXPECT_EQ(f[0], 0.0) << j;
            EXPECT_EQ(dev.true_velocity(0), v_release) << j;  // no force on the free handle: exactly constant
        }
        if (j > 301) {
            EXPECT_EQ(f[0], 1.0) << j;
        }
        ASSERT_EQ(dev.write_force(AxisVector{}), DeviceStatus::Ok);
    }
}

// A mass matrix (tests/server/sim3_aniso.toml's, eigenvalues 0.176 .. 0.541 kg), no hand impedance, the hand's
// 0.05 kg leaving and joining, a constant force vector: x(t) is piecewise x0 + v0 t + M_i^-1 F t^2 / 2 with M_i = M
// or M - 0.05 I, whose modes differ (the state is rotated into the new modes at each event). Tolerance 1e-12 m as
// above (the eigenvectors and the inverse each round at ~1e-16).
TEST(HandSchedule, MassMatrixReleaseAndGripRotateTheStateExactly) {
    SimDeviceConfig c;
    c.capabilities.axes = 3;
    c.capabilities.max_force = 100.0;
    c.plant = {0.45, 0.0, 0.0};
    c.mass_matrix = std::array<AxisVector, kMaxAxes>{AxisVector{0.45, 0.10, 0.12}, AxisVector{0.10, 0.30, 0.00},
                                                     AxisVector{0.12, 0.00, 0.25}};
    c.period = 1e-3;
    c.scenario.kind = Scenario::Rest;
    c.scenario.hand.release_mass = 0.05;
    c.scenario.schedule = parse_hand_schedule("release@0.1,grip@0.25");
    SimDevice dev(c);
    ASSERT_EQ(dev.open(), DeviceStatus::Ok);
    Eigen::Matrix3d M;
    M << 0.45, 0.10, 0.12, 0.10, 0.30, 0.00, 0.12, 0.00, 0.25;
    const Eigen::Vector3d F(0.3, -0.2, 0.1);
    const Eigen::Vector3d a_held = M.inverse() * F;
    const Eigen::Vector3d a_free = (M - 0.05 * Eigen::Matrix3d::Identity()).inverse() * F;
    Eigen::Vector3d x0 = Eigen::Vector3d::Zero(), v0 = Eigen::Vector3d::Zero();
    int from = 0;
    Eigen::Vector3d a = a_held;
    for (int j = 0; j <= 400; ++j) {
        if (j == 100 || j == 250) {
            const double t = (j - from) * 1e-3;
            x0 = x0 + v0 * t + a * t * t / 2.0;
            v0 = v0 + a * t;
            from = j;
            a = j == 100 ? a_free : a_held;
        }
        AxisVector p{};
        ASSERT_EQ(dev.read_position(p), DeviceStatus::Ok);
        const double t = (j - from) * 1e-3;
        const Eigen::Vector3d want = x0 + v0 * t + a * t * t / 2.0;
        for (std::size_t i = 0; i < 3; ++i) {
            ASSERT_NEAR(p[i], want(static_cast<Eigen::Index>(i)), 1e-12) << j;
        }
        ASSERT_EQ(dev.write_force(AxisVector{F(0), F(1), F(2)}), DeviceStatus::Ok);
    }
    EXPECT_DOUBLE_EQ(dev.hand_events()[0].mass, 0.40);
}

// The handle pressed by the hand (1 N step) into a stiff bilateral wall with a delay of 1 ms, rendered as the loop
// renders it (F = -K x_j - B (x_j - x_{j-1}) / T, applied one period later): released at 1 s the 0.22 kg handle
// is left alone in the wall with the energy E = m v^2 / 2 + K x^2 / 2 it had; gripped again at 2 s the hand (at
// rest where the handle is) presses it in again. The loop is stable at both masses (alpha = K T^2 / m = 0.0133 and
// 0.0182, beta = B T / m = 0.133 and 0.182, d = 1: inside the region, whose edge at small beta is beta > ~1.5
// alpha): the energy after the release never exceeds 1.05 times its value at the release (the sampled, delayed
// wall is not passive: the peak is 1.0013 times it here), it decays below 1e-9 of it by the grip (the
// continuous loop's decay rate B / (2 m) = 91 s^-1, e^-182 in 1 s), and after the grip the handle settles on
// (F_H + k_H x_H) / (K + k_H) to 1e-9 m.
TEST(HandSchedule, AWallKeepsTheEnergyBoundedAndDecayingAcrossReleaseAndGrip) {
    const double K = 4000.0, B = 40.0, T = 1e-3;
    auto c = falcon_hand("release@1.0,grip@2.0", T);
    c.scenario.kind = Scenario::Step;
    c.scenario.step_force = 1.0;
    SimDevice dev(c);
    ASSERT_EQ(dev.open(), DeviceStatus::Ok);
    double previous = 0.0;
    double e_release = 0.0, e_peak = 0.0, e_before_grip = 0.0;
    for (int j = 0; j <= 3000; ++j) {
        AxisVector p{};
        ASSERT_EQ(dev.read_position(p), DeviceStatus::Ok);
        const double x = dev.true_position(0), v = dev.true_velocity(0);
        const double energy = 0.5 * dev.moving_mass(0) * v * v + 0.5 * K * x * x;
        if (j == 1000) e_release = energy;
        if (j > 1000 && j <= 2000) e_peak = std::max(e_peak, energy);
        if (j == 2000) e_before_grip = energy;
        AxisVector f{};
        f[0] = -K * p[0] - B * (j > 0 ? (p[0] - previous) / T : 0.0);
        previous = p[0];
        ASSERT_EQ(dev.write_force(f), DeviceStatus::Ok);
        if (j == 3000) {  // the balance F_H + k_H x_H = (K + k_H) x around the grip's x_H (the wall's origin to ~1e-8)
            EXPECT_NEAR(x, (1.0 + 200.0 * dev.hand_events()[1].position) / (K + 200.0), 1e-9);
        }
    }
    std::printf("[ hand schedule ] wall: E at release %.4g J, peak after it %.4g J (x %.4f), at the grip %.3g J\n",
                e_release, e_peak, e_peak / e_release, e_before_grip);
    ASSERT_GT(e_release, 0.0);
    EXPECT_LE(e_peak, 1.05 * e_release);
    EXPECT_LT(e_before_grip, 1e-9 * e_release);
}

// The constructor refuses a schedule the text parser would have refused (for configs built in code) and a hand's
// mass that would leave no mass behind.
TEST(HandSchedule, TheDeviceRefusesAnInconsistentScheduleOrMass) {
    auto unordered = falcon_hand("");
    unordered.scenario.schedule = {{HandEventKind::Release, 2.0, {}, {}}, {HandEventKind::Grip, 1.0, {}, {}}};
    EXPECT_THROW(SimDevice{unordered}, std::invalid_argument);
    auto twice = falcon_hand("");
    twice.scenario.schedule = {{HandEventKind::Release, 1.0, {}, {}}, {HandEventKind::Release, 2.0, {}, {}}};
    EXPECT_THROW(SimDevice{twice}, std::invalid_argument);
    auto heavy = falcon_hand("release@1");
    heavy.scenario.hand.release_mass = 0.30;
    try {
        SimDevice dev(heavy);
        ADD_FAILURE() << "accepted a hand as heavy as the plant";
    } catch (const std::invalid_argument& e) {
        EXPECT_NE(std::string(e.what()).find("less hand.release_mass = 0.3"), std::string::npos) << e.what();
    }
}

// With a fractional delay (1.5 periods) each period is two exact sub-intervals; an event switches both at the
// boundary. The free 0.22 kg after a release at rest: with the force written from tick 0, F acts from 1.5 T on;
// the exact solution x = F (t - 1.5 T)^2 / (2 m) for the held 0.30 kg, then the free mass from the release on.
TEST(HandSchedule, FractionalDelayAcrossARelease) {
    auto c = falcon_hand("release@0.1", 1.5e-3);
    c.scenario.hand.damping = 0.0;
    c.scenario.hand.stiffness = 0.0;
    SimDevice dev(c);
    ASSERT_EQ(dev.open(), DeviceStatus::Ok);
    const double F = 0.2, td = 1.5e-3;
    const State at_release = closed_form({0.0, 0.0}, 0.30, 0.0, 0.0, 0.0, F, 0.1 - td);
    for (int j = 0; j <= 300; ++j) {
        AxisVector p{};
        ASSERT_EQ(dev.read_position(p), DeviceStatus::Ok);
        const double t = j * 1e-3;
        const double want = t <= td    ? 0.0
                            : t <= 0.1 ? closed_form({0.0, 0.0}, 0.30, 0.0, 0.0, 0.0, F, t - td).x
                                       : closed_form(at_release, 0.22, 0.0, 0.0, 0.0, F, t - 0.1).x;
        ASSERT_NEAR(p[0], want, 1e-13) << j;
        ASSERT_EQ(dev.write_force(AxisVector{F, 0.0, 0.0}), DeviceStatus::Ok);
    }
}

}  // namespace
}  // namespace hapticd
