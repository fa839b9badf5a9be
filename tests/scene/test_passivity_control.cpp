// SPDX-License-Identifier: Apache-2.0
// The passivity controller (scene/passivity_controller.hpp) on the simulated device through the
// real daemon tick (lockstep): a bilateral wall beyond alpha_max diverges without it and stays bounded with
// it, for d = 0, 1, 3 (delay buffer); the energy bound W_j >= -(S_j + E_j) holds at every tick; no NaN at
// v = 0; non-finite input zeroes the force and is counted.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <vector>

#include <hapticopt/stability_region.hpp>

#include <nlohmann/json.hpp>

#include "daemon/daemon.hpp"
#include "common/process.hpp"
#include "devices/sim_device.hpp"
#include "scene/passivity_controller.hpp"
#include "scene/scene.hpp"

namespace hapticd {
namespace {

constexpr double kMass = 0.3, kT = 1e-3, kMaxForce = 1e4;

// Records what the controller sees each tick, wrapping the simulated device (the daemon writes the final force).
class RecordingDevice final : public Device {
  public:
    RecordingDevice(SimDevice& sim, PassivityController* pc) : sim_(sim), pc_(pc) {}
    DeviceStatus open() override { return sim_.open(); }
    DeviceStatus home() override { return sim_.home(); }
    void close() noexcept override { sim_.close(); }
    DeviceStatus read_position(AxisVector& p) noexcept override {
        const DeviceStatus s = sim_.read_position(p);
        positions.push_back(p[0]);
        return s;
    }
    DeviceStatus write_force(const AxisVector& f) noexcept override {
        forces.push_back(f[0]);
        if (pc_ != nullptr) {
            port_energy.push_back(pc_->port_energy(0));
            bound.push_back(-(pc_->stats().shortfall + pc_->stats().prediction_error));
            observed_energy.push_back(pc_->observed_energy(0));
            const PassivityControlStats& s = pc_->stats();
            const std::uint64_t shorts =
                s.capped_ticks + s.guarded_ticks + s.saturated_ticks + s.nonfinite_events + s.limited_ticks;
            // this tick neither capped, guarded, saturated, zeroed nor changed by the daemon's force limiter
            unconstrained.push_back(shorts == shorts_);
            shorts_ = shorts;
        }
        return sim_.write_force(f);
    }
    DeviceStatus read_external_force(AxisVector& f) noexcept override { return sim_.read_external_force(f); }
    [[nodiscard]] const DeviceCapabilities& capabilities() const noexcept override { return sim_.capabilities(); }
    [[nodiscard]] std::string_view name() const noexcept override { return "recording-sim"; }
    [[nodiscard]] std::string last_error() const override { return sim_.last_error(); }

    std::vector<double> positions, forces, port_energy, bound, observed_energy;
    std::vector<bool> unconstrained;

  private:
    std::uint64_t shorts_ = 0;
    SimDevice& sim_;
    PassivityController* pc_;
};

struct StepRun {
    double max_abs_x = 0;   // over the whole run
    double late_abs_x = 0;  // max |x| over the last 20 % of the run
    bool finite = true;
    PassivityControlStats stats;
    double worst_bound_violation = 0;   // max over ticks of (bound - W), > 0 violates
    double worst_observed_deficit = 0;  // max over unconstrained ticks of (-P - allowance), > 0 violates
    std::size_t unconstrained_ticks = 0;
};

// The paper's step (1 N into a bilateral wall at rest) for `ticks` ticks, wall K, B, delay buffer `d`.
StepRun step_run(double K, double B, std::size_t d, bool control, double device_damping = 0.0,
                 std::uint64_t ticks = 3000) {
    SimDeviceConfig c;
    c.capabilities.axes = 1;
    c.capabilities.max_force = kMaxForce;
    c.plant = {kMass, device_damping, 0.0};
    c.period = kT;
    c.scenario.kind = Scenario::Step;
    c.scenario.step_force = 1.0;
    SimDevice sim(c);
    PassivityControlConfig pcc;
    pcc.period = kT;
    pcc.damping_cap = 2.0 / (double(d) + 1.0) * kMass / kT;  // hapticd's default: beta <= 2 / (N + 1)
    pcc.velocity_guard = 1e-4;
    pcc.max_force = kMaxForce;
    PassivityController pc(pcc);
    RecordingDevice dev(sim, control ? &pc : nullptr);
    EXPECT_EQ(dev.open(), DeviceStatus::Ok);
    EXPECT_EQ(dev.home(), DeviceStatus::Ok);
    std::vector<VirtualWall> walls;
    walls.emplace_back(WallGeometry{0, 0.0, 1.0, WallMode::Bilateral}, K, B, kT);
    Scene scene(std::move(walls), 1, kMaxForce);
    DaemonConfig cfg;
    cfg.loop = {1'000'000, true};
    cfg.max_ticks = ticks;
    cfg.delay_samples = d;
    cfg.watchdog_enabled = false;
    cfg.passivity = control ? &pc : nullptr;
    // The controller alone: the daemon's force limiter at its largest rate (a step of 0.999 kMaxForce per tick;
    // the runs stay far below it unless they diverge), as the forces are left unsaturated (10 kN).
    cfg.max_force_rate = 0.999 * kMaxForce / kT;
    clear_stop_request();
    Daemon daemon(dev, scene, nullptr, cfg);
    daemon.run();
    StepRun r;
    const std::size_t n = dev.positions.size();
    for (std::size_t j = 0; j < n; ++j) {
        const double x = dev.positions[j];
        if (!std::isfinite(x)) r.finite = false;
        r.max_abs_x = std::max(r.max_abs_x, std::abs(x));
        if (j >= n * 4 / 5) r.late_abs_x = std::max(r.late_abs_x, std::abs(x));
    }
    for (std::size_t j = 0; j < dev.port_energy.size(); ++j) {
        // Rounding allowance: 1e-12 J plus 1e-12 of the bound's terms (sums of ~3000 products, each exact to ~1e-16).
        const double allowance = 1e-12 * (1 + std::abs(dev.bound[j]) + std::abs(dev.port_energy[j]));
        r.worst_bound_violation = std::max(r.worst_bound_violation, dev.bound[j] - dev.port_energy[j] - allowance);
    }
    // The controller's own invariant (the induction step of the bound): on a tick where the damper was neither
    // capped, guarded off nor saturated, the observed energy P_j after the written force is >= 0. The damper makes
    // P_j = P + b v^2 T with b = -P / (v^2 T), zero up to the rounding of that sum: a few ulp of |W| + |F v T|,
    // allowed as 1e-12 (1 + |W|) J (the forces here are <= 10 kN over <= 1 m per tick).
    for (std::size_t j = 0; j < dev.observed_energy.size(); ++j) {
        if (!dev.unconstrained[j]) continue;
        ++r.unconstrained_ticks;
        const double allowance = 1e-12 * (1 + std::abs(dev.port_energy[j]));
        r.worst_observed_deficit = std::max(r.worst_observed_deficit, -dev.observed_energy[j] - allowance);
    }
    r.stats = pc.stats();
    return r;
}

struct Gains {
    double K, B;
};

// alpha = factor * alpha_max at the beta of the region's tip (the damping that makes alpha_max reachable).
Gains beyond(double factor, std::size_t d, double device_damping) {
    const hapticopt::StabilityRegion region(hapticopt::NormalizedPlant{0, device_damping * kT / kMass, double(d)});
    return {factor * region.alpha_max() * kMass / (kT * kT), region.beta_at_alpha_max() * kMass / kT};
}

// Device damping b = 0 and b = 6 N s/m (delta = 0.02), forces unsaturated (10 kN), the default cap.
// Bounded: after 3 s the step response stays within 10x its final value 1 N / K over the last 0.6 s;
// diverged: it left 1000x. (The unstable loop's amplitude grows geometrically, by the spectral radius per
// tick; the controlled one settles near x_inf, see docs/passivity.md for the traces.)
TEST(PassivityControl, WallBeyondAlphaMaxDivergesWithoutAndStaysBoundedWith) {
    for (double b : {0.0, 6.0})
        for (std::size_t d : {0U, 1U, 3U}) {
            const Gains g = beyond(1.5, d, b);
            const double x_inf = 1.0 / g.K;
            const StepRun off = step_run(g.K, g.B, d, false, b);
            const StepRun on = step_run(g.K, g.B, d, true, b);
            EXPECT_TRUE(!off.finite || off.max_abs_x > 1000 * x_inf) << "d=" << d << " max|x| " << off.max_abs_x;
            EXPECT_TRUE(on.finite) << "d=" << d;
            // Known limitation (docs/passivity.md): with device damping and no delay buffer the controller does not
            // hold 1.5 alpha_max. Update the docs and this line together if the controller improves.
            const bool expected_to_hold = !(b > 0 && d == 0);
            EXPECT_EQ(on.late_abs_x < 10 * x_inf, expected_to_hold)
                << "b=" << b << " d=" << d << " late max|x| " << on.late_abs_x << " x_inf " << x_inf;
            EXPECT_GT(on.stats.damper_ticks, 0U) << "d=" << d;
            EXPECT_EQ(on.stats.nonfinite_events, 0U);
            // The stated bound at every tick (with the rounding allowance of step_run).
            EXPECT_LE(on.worst_bound_violation, 0.0) << "d=" << d;
            EXPECT_LE(on.worst_observed_deficit, 0.0) << "b=" << b << " d=" << d;
            EXPECT_GT(on.unconstrained_ticks, 0U);
            std::printf(
                "b=%g d=%zu 1.5 alpha_max: off max|x| %.3g, on late max|x| %.3g (x_inf %.3g); damper %llu ticks, "
                "capped %llu; port energy min %.3g J; bound terms: shortfall %.3g J, prediction error %.3g J\n",
                b, d, off.max_abs_x, on.late_abs_x, x_inf, static_cast<unsigned long long>(on.stats.damper_ticks),
                static_cast<unsigned long long>(on.stats.capped_ticks), on.stats.min_port_energy, on.stats.shortfall,
                on.stats.prediction_error);
        }
}

// The largest factor of alpha_max the controller holds (bounded as above), on the grid 1.25 .. 32, per d.
TEST(PassivityControl, LargestFactorItHolds) {
    for (double b : {0.0, 6.0})
        for (std::size_t d : {0U, 1U, 3U}) {
            double held = 0;
            for (double factor : {1.25, 1.5, 1.75, 2.0, 2.5, 3.0, 4.0, 6.0, 8.0, 12.0, 16.0, 24.0, 32.0}) {
                const Gains g = beyond(factor, d, b);
                const StepRun on = step_run(g.K, g.B, d, true, b);
                if (!(on.finite && on.late_abs_x < 10 / g.K)) break;
                EXPECT_LE(on.worst_bound_violation, 0.0) << "d=" << d << " factor " << factor;
                held = factor;
            }
            if (b > 0 && d == 0) {
                EXPECT_EQ(held, 0.0) << "the known limitation of the test above";
            } else {
                EXPECT_GE(held, 1.5) << "b=" << b << " d=" << d;
            }
            std::printf("b=%g d=%zu: largest factor of alpha_max held (grid 1.25 .. 32): %.2f\n", b, d, held);
        }
}

// v = 0: a wall at rest with the device at rest gives zero velocity every tick; the guard keeps the damper
// off (no division by v^2 = 0), nothing is NaN. A non-finite force in is zeroed and counted.
TEST(PassivityControl, ZeroVelocityAndNonFiniteInput) {
    PassivityControlConfig c;
    c.period = kT;
    c.damping_cap = 100;
    c.velocity_guard = 1e-4;
    c.max_force = 10;
    PassivityController pc(c);
    for (int j = 0; j < 100; ++j) {
        AxisVector x{0.001, 0, 0}, f{-2.0, 0, 0};  // constant position, a force: P stays 0, W stays 0
        pc.apply(x, f);
        EXPECT_TRUE(std::isfinite(f[0]));
        EXPECT_EQ(f[0], -2.0);
    }
    // Energy already negative (tick 1: the +5 N written at tick 0 acted over +1 um), then standing still: the
    // damper is guarded off, never a NaN or an infinite damping.
    pc.reset();
    for (int j = 0; j < 10; ++j) {
        AxisVector x{j == 0 ? 0.0 : 1e-6, 0, 0}, f{j == 0 ? 5.0 : 0.0, 0, 0};
        pc.apply(x, f);
        EXPECT_TRUE(std::isfinite(f[0]));
        EXPECT_LE(std::abs(f[0]), c.max_force);
        if (j >= 1) {
            EXPECT_LT(pc.port_energy(0), 0.0);
        }
    }
    EXPECT_GT(pc.stats().guarded_ticks, 0U);
    EXPECT_EQ(pc.stats().nonfinite_events, 0U);
    AxisVector x{0.001, 0, 0}, f{std::numeric_limits<double>::quiet_NaN(), 0, 0};
    pc.apply(x, f);
    EXPECT_EQ(f[0], 0.0);
    EXPECT_EQ(pc.stats().nonfinite_events, 1U);
    EXPECT_THROW(PassivityController(PassivityControlConfig{kT, 0.0, 1e-4, 10, 1}), std::invalid_argument);
    EXPECT_THROW(PassivityController(PassivityControlConfig{kT, 10.0, -1.0, 10, 1}), std::invalid_argument);
}

// The command line: hapticd refuses unstable explicit gains (exit 5) unless --passivity-control is given; then it
// runs them, prints the counters and writes them to the summary; a bad cap is refused naming it (exit 4).
TEST(PassivityControl, HapticdOption) {
    const Gains g = beyond(1.5, 1, 0.0);
    const std::string K = std::to_string(g.K), B = std::to_string(g.B);
    const std::vector<std::string> common{"--device",      "sim", "--lockstep",     "--bilateral", "--stiffness", K,
                                          "--damping",     B,     "--delay-buffer", "1",           "--duration",  "2",
                                          "--rt-priority", "0"};
    const test::Result refused = test::run(common, "pc_refused");
    EXPECT_EQ(refused.code, 5) << refused.err;
    const std::string summary = (test::scratch_dir() / "pc_summary.json").string();
    std::vector<std::string> with = common;
    for (const char* a : {"--passivity-control", "--summary-json"}) with.emplace_back(a);
    with.push_back(summary);
    const test::Result run = test::run(with, "pc_run");
    ASSERT_EQ(run.code, 0) << run.err;
    EXPECT_NE(run.out.find("passivity control: damper on"), std::string::npos) << run.out;
    const nlohmann::json j = nlohmann::json::parse(test::read_file(summary));
    ASSERT_TRUE(j.at("passivity_control").is_object()) << j.dump();
    EXPECT_GT(j["passivity_control"]["damper_ticks"].get<long long>(), 0);
    EXPECT_EQ(j["passivity_control"]["nonfinite_events"].get<long long>(), 0);
    std::vector<std::string> bad = common;
    for (const char* a : {"--passivity-control", "--passivity-velocity-guard", "0"}) bad.emplace_back(a);
    const test::Result rejected = test::run(bad, "pc_bad");
    EXPECT_EQ(rejected.code, 4) << rejected.err;
    EXPECT_NE(rejected.err.find("passivity-velocity-guard"), std::string::npos) << rejected.err;
}

}  // namespace
}  // namespace hapticd
