// SPDX-License-Identifier: Apache-2.0
// Identification of the device at start-up: estimation (identification.hpp), excitation safety, tuning
// from the estimates and the identification file (identification_run.hpp), and hapticd --identify.
//
// Tolerances and why:
//  * mass within 1 %, damping within 5 %, delay: whole part exact and |d_hat - d| <= 0.1 period — the
//    issue's requirements, checked on the simulated device with measurement noise 2 um (1e-5 rad rotary)
//    AND encoder quantisation of the same size switched on, for several plants and 5 noise seeds each.
//    The measured worst errors are printed ("[measured]" lines) and quoted in docs/identification.md.
//  * the stated standard errors are honest: |estimate - truth| <= 4.5 standard errors for m, b, k, d
//    (4.5: 5 seeds x 4 plants x 4 parameters = 80 z-scores; the chance of one above 4.5 for correct
//    standard errors is < 0.1 %).
//  * noise-free data: the estimates equal the truth to 1e-6 relative (the model is the device's exact
//    physics; the limit is the finite-difference Jacobian and the 1e-4-period delay tolerance).
//  * tuned K, B from the estimates equal the optimum for the true plant within 3 propagated standard
//    errors (delta method) plus 1e-9 relative.
//  * excitation: |u| <= force limit and |x - x_start| <= position limit at every tick, exactly (no
//    tolerance), over 300 random plants, limits and seeds; the guard trips (zero force) when the device
//    is 10x lighter than designed.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include <unistd.h>

#include <nlohmann/json.hpp>

#include "devices/sim_device.hpp"
#include "daemon/hapticd_main.hpp"
#include "identification/identification.hpp"
#include "identification/identification_run.hpp"
#include "common/stop_flag.hpp"
#include "tuning/tuning.hpp"

namespace hapticd {
namespace {

struct TruePlant {
    const char* name;
    double mass, damping, stiffness, delay_periods;
    double noise;       // m (rad)
    double resolution;  // m (rad)
    double max_force;
    bool rotary;
};

SimDeviceConfig sim_config(const TruePlant& t, std::uint64_t seed, double period = 1e-3) {
    SimDeviceConfig c;
    c.capabilities.axes = 1;
    c.capabilities.max_force = t.max_force;
    c.capabilities.inherent_delay = t.delay_periods * period;
    c.capabilities.workspace_min = {-0.06, -0.06, -0.06};
    c.capabilities.workspace_max = {0.06, 0.06, 0.06};
    if (t.rotary) {
        c.capabilities.workspace_min = {-2.0, -2.0, -2.0};
        c.capabilities.workspace_max = {2.0, 2.0, 2.0};
    }
    c.plant = {t.mass, t.damping, t.stiffness};
    c.period = period;
    c.position_noise = t.noise;
    c.position_resolution = {t.resolution, t.resolution, t.resolution};
    c.noise_seed = seed;
    c.scenario.kind = Scenario::Hold;  // at rest, no external force
    c.scenario.hold_force = 0.0;
    c.scenario.hold_distance = 0.0;
    return c;
}

ExcitationSettings excitation_for(const TruePlant& t, double design_mass, std::uint64_t seed) {
    ExcitationSettings s;
    s.period = 1e-3;
    s.force_limit = 0.25 * t.max_force;
    s.position_limit = t.rotary ? 0.05 : 0.005;
    s.design_mass = design_mass;
    s.seed = seed;
    s.paced = false;
    return s;
}

ExcitationRecord excite(const TruePlant& t, std::uint64_t noise_seed, std::uint64_t excitation_seed) {
    SimDevice dev(sim_config(t, noise_seed));
    EXPECT_EQ(dev.open(), DeviceStatus::Ok);
    EXPECT_EQ(dev.home(), DeviceStatus::Ok);
    return run_excitation(dev, excitation_for(t, t.mass, excitation_seed));
}

// The plants of the accuracy tests: the paper's ranges at 1 kHz (gamma < 0.001, delta < 0.02), its
// delays (Falcon 6 ms, LWR 5 ms) and fractional ones.
const TruePlant kPlants[] = {
    {"arm with spring, d = 2.4", 0.30, 3.0, 100.0, 2.4, 2e-6, 2e-6, 10.0, false},
    {"Falcon with hand, d = 6", 0.30, 1.5, 0.0, 6.0, 2e-6, 2e-6, 9.0, false},
    {"Falcon free handle, d = 0.5", 0.22, 0.8, 20.0, 0.5, 2e-6, 2e-6, 9.0, false},
    {"LWR joint, d = 5.7", 0.065, 0.4, 30.0, 5.7, 1e-5, 1e-5, 40.0, true},
};

TEST(Identification, SampledModelEqualsSimulatedDevice) {
    // The estimator's model reproduces the simulated device (fractional delay, spring, damping) exactly.
    const TruePlant t{"", 0.3, 2.0, 150.0, 3.35, 0.0, 0.0, 10.0, false};
    const ExcitationRecord rec = excite(t, 1, 3);
    ASSERT_TRUE(rec.completed) << rec.abort_reason;
    PlantEstimate p;
    p.mass = t.mass;
    p.damping = t.damping;
    p.stiffness = t.stiffness;
    p.delay_periods = t.delay_periods;
    const std::vector<double> x = simulate_sampled_plant(p, 1e-3, rec.data.force);
    double worst = 0.0;
    double scale = 0.0;
    for (std::size_t j = 0; j < x.size(); ++j) {
        worst = std::max(worst, std::abs(x[j] - rec.data.position[j]));
        scale = std::max(scale, std::abs(rec.data.position[j]));
    }
    EXPECT_LE(worst, 1e-12 * scale) << "scale " << scale;
}

TEST(Identification, ArxMapIsExactWithoutNoise) {
    const TruePlant t{"", 0.25, 2.5, 80.0, 3.0, 0.0, 0.0, 10.0, false};
    const ExcitationRecord rec = excite(t, 1, 5);
    ASSERT_TRUE(rec.completed);
    IdentificationData data = rec.data;
    const auto fit = fit_arx(data, 3);
    ASSERT_TRUE(fit.has_value());
    const auto p = arx_to_plant(*fit, 1e-3);
    ASSERT_TRUE(p.has_value());
    EXPECT_NEAR(p->mass, t.mass, 1e-6 * t.mass);
    EXPECT_NEAR(p->damping, t.damping, 1e-5 * t.damping);
    EXPECT_NEAR(p->stiffness, t.stiffness, 1e-4 * t.stiffness);
}

TEST(Identification, NoiseFreeDataGiveTheTruth) {
    for (const TruePlant& base : kPlants) {
        TruePlant t = base;
        t.noise = 0.0;
        t.resolution = 0.0;
        const ExcitationRecord rec = excite(t, 1, 11);
        ASSERT_TRUE(rec.completed) << rec.abort_reason;
        const IdentificationResult r = identify_plant(rec.data);
        ASSERT_TRUE(r.ok) << r.message;
        EXPECT_NEAR(r.mass, t.mass, 1e-6 * t.mass) << t.name;
        EXPECT_NEAR(r.damping, t.damping, 1e-6 * t.mass / 1e-3) << t.name;
        EXPECT_NEAR(r.stiffness, t.stiffness, 1e-6 * t.mass / 1e-6) << t.name;
        EXPECT_NEAR(r.delay_periods, t.delay_periods, 2e-4) << t.name;
    }
}

TEST(Identification, NoisyQuantisedSimulatedDeviceMeetsTheIssueTolerances) {
    for (const TruePlant& t : kPlants) {
        double worst_m = 0.0, worst_b = 0.0, worst_d = 0.0, worst_z = 0.0, worst_k = 0.0;
        for (std::uint64_t seed = 1; seed <= 5; ++seed) {
            const ExcitationRecord rec = excite(t, 100 + seed, seed);
            ASSERT_TRUE(rec.completed) << rec.abort_reason;
            const IdentificationResult r = identify_plant(rec.data);
            ASSERT_TRUE(r.ok) << r.message;
            const double em = std::abs(r.mass - t.mass) / t.mass;
            const double eb = std::abs(r.damping - t.damping) / t.damping;
            const double ed = std::abs(r.delay_periods - t.delay_periods);
            EXPECT_LE(em, 0.01) << t.name << " seed " << seed;
            EXPECT_LE(eb, 0.05) << t.name << " seed " << seed;
            EXPECT_LE(ed, 0.1) << t.name << " seed " << seed;
            // Whole periods exact: the integer part of the estimate (for an integer true delay, the
            // nearest integer, since d_hat may fall a hair below it) is the true one.
            const bool integer_truth = std::abs(t.delay_periods - std::round(t.delay_periods)) < 1e-9;
            const double whole = integer_truth ? std::round(r.delay_periods) : static_cast<double>(r.delay_whole);
            EXPECT_EQ(whole, std::floor(t.delay_periods + 1e-9))
                << t.name << " seed " << seed << " d_hat " << r.delay_periods;
            if (!integer_truth) {
                EXPECT_NEAR(r.delay_fraction, t.delay_periods - std::floor(t.delay_periods), 0.1);
            }
            const double z[] = {(r.mass - t.mass) / r.mass_stderr, (r.damping - t.damping) / r.damping_stderr,
                                (r.stiffness - t.stiffness) / r.stiffness_stderr,
                                (r.delay_periods - t.delay_periods) / r.delay_stderr};
            for (double zi : z) {
                EXPECT_LE(std::abs(zi), 4.5) << t.name << " seed " << seed;
                worst_z = std::max(worst_z, std::abs(zi));
            }
            worst_m = std::max(worst_m, em);
            worst_b = std::max(worst_b, eb);
            worst_d = std::max(worst_d, ed);
            worst_k = std::max(worst_k, std::abs(r.stiffness - t.stiffness));
        }
        std::printf(
            "[measured] %s: worst of 5 seeds: mass %.2e rel, damping %.2e rel, stiffness %.3g abs, delay %.2e periods, "
            "max |z| %.2f\n",
            t.name, worst_m, worst_b, worst_k, worst_d, worst_z);
    }
}

TEST(Identification, TunedGainsEqualTheTrueOptimumWithinPropagatedUncertainty) {
    for (const TruePlant& t : kPlants) {
        const ExcitationRecord rec = excite(t, 201, 7);
        ASSERT_TRUE(rec.completed);
        const IdentificationResult r = identify_plant(rec.data);
        ASSERT_TRUE(r.ok) << r.message;
        for (const char* criterion : {"CE2", "CE1"}) {
            const hapticopt::Criterion c = *hapticopt::parse_criterion(criterion);
            const IdentifiedTuning id = tune_identified(c, r, 1e-3, 0.0);
            const TuningResult truth =
                tune_wall(c, TuningPlant{t.mass, t.damping, t.stiffness, 1e-3, t.delay_periods * 1e-3});
            EXPECT_GT(id.K_stderr, 0.0);
            EXPECT_GT(id.B_stderr, 0.0);
            EXPECT_NEAR(id.tuning.K, truth.K, 3.0 * id.K_stderr + 1e-9 * truth.K) << t.name << " " << criterion;
            EXPECT_NEAR(id.tuning.B, truth.B, 3.0 * id.B_stderr + 1e-9 * truth.B) << t.name << " " << criterion;
            std::printf("[measured] %s %s: K %.6g (true %.6g, +- %.2g), B %.6g (true %.6g, +- %.2g)\n", t.name,
                        criterion, id.tuning.K, truth.K, id.K_stderr, id.tuning.B, truth.B, id.B_stderr);
        }
    }
}

// Records every force written, and checks the true position after each read.
class WatchingDevice final : public Device {
  public:
    explicit WatchingDevice(const SimDeviceConfig& c) : sim_(c) {}
    DeviceStatus open() override { return sim_.open(); }
    DeviceStatus home() override { return sim_.home(); }
    void close() noexcept override { sim_.close(); }
    DeviceStatus read_position(AxisVector& p) noexcept override {
        const DeviceStatus s = sim_.read_position(p);
        true_positions.push_back(sim_.true_position(0));
        return s;
    }
    DeviceStatus write_force(const AxisVector& f) noexcept override {
        writes.push_back(f[0]);
        return sim_.write_force(f);
    }
    const DeviceCapabilities& capabilities() const noexcept override { return sim_.capabilities(); }
    std::string_view name() const noexcept override { return "watching"; }
    std::string last_error() const override { return sim_.last_error(); }
    std::vector<double> writes;
    std::vector<double> true_positions;

  private:
    SimDevice sim_;
};

TEST(Excitation, NeverExceedsItsForceAndPositionLimits) {
    const int kCases = 1000;
    std::mt19937_64 rng(20261121);
    std::uniform_real_distribution<double> U(0.0, 1.0);
    int cases = 0;
    double worst_force_ratio = 0.0, worst_position_ratio = 0.0;
    std::string worst_case;
    for (int i = 0; i < kCases; ++i) {
        const double T = 1e-3;
        const double design = 0.02 * std::pow(50.0, U(rng));      // 0.02 .. 1 kg
        const double mass = design * (0.5 + 1.5 * U(rng));        // design/2 .. 2 design
        const double damping = 0.02 * mass / T * U(rng);          // delta < 0.02
        const double stiffness = 1e-3 * mass / (T * T) * U(rng);  // gamma < 0.001
        const double delay = U(rng) < 0.3 ? std::floor(8 * U(rng)) : 8 * U(rng);
        const double max_force = 1.0 + 20.0 * U(rng);
        TruePlant t{"", mass, damping, stiffness, delay, 2e-6 * U(rng), 2e-6 * U(rng), max_force, false};
        SimDeviceConfig c = sim_config(t, 1 + static_cast<std::uint64_t>(i));
        WatchingDevice dev(c);
        ASSERT_EQ(dev.open(), DeviceStatus::Ok);
        ASSERT_EQ(dev.home(), DeviceStatus::Ok);
        ExcitationSettings s;
        s.period = T;
        s.force_limit = max_force * (0.02 + 0.98 * U(rng));
        s.position_limit = 5e-4 * std::pow(40.0, U(rng));  // 0.5 .. 20 mm
        s.design_mass = design;
        s.duration = 0.5 + 2.0 * U(rng);
        s.seed = rng();
        s.paced = false;
        const ExcitationRecord rec = run_excitation(dev, s);
        ASSERT_TRUE(rec.completed) << "case " << i << ": " << rec.abort_reason << "; mass " << mass << " (design "
                                   << design << "), damping " << damping << ", stiffness " << stiffness << ", delay "
                                   << delay << ", force limit " << s.force_limit << ", position limit "
                                   << s.position_limit;
        ASSERT_FALSE(dev.writes.empty());
        for (double f : dev.writes) {
            ASSERT_LE(std::abs(f), s.force_limit) << "case " << i;
            worst_force_ratio = std::max(worst_force_ratio, std::abs(f) / s.force_limit);
        }
        EXPECT_EQ(dev.writes.back(), 0.0) << "case " << i;
        const double start = dev.true_positions.front();
        for (double x : dev.true_positions) {
            ASSERT_LE(std::abs(x - start), s.position_limit) << "case " << i;
            if (std::abs(x - start) / s.position_limit > worst_position_ratio) {
                worst_position_ratio = std::abs(x - start) / s.position_limit;
                worst_case = "mass/design " + std::to_string(mass / design) + ", gamma " +
                             std::to_string(stiffness * T * T / mass) + ", delta " +
                             std::to_string(damping * T / mass) + ", delay " + std::to_string(delay) +
                             ", force limit " + std::to_string(s.force_limit);
            }
        }
        ++cases;
    }
    std::printf("[measured] excitation property test: %d cases, max |u|/limit %.3f, max |x - x0|/limit %.3f (%s)\n",
                cases, worst_force_ratio, worst_position_ratio, worst_case.c_str());
}

TEST(Excitation, GuardAbortsWithZeroForceOnALightDevice) {
    TruePlant t{"", 0.03, 0.0, 0.0, 1.0, 0.0, 0.0, 10.0, false};
    WatchingDevice dev(sim_config(t, 1));
    ASSERT_EQ(dev.open(), DeviceStatus::Ok);
    ASSERT_EQ(dev.home(), DeviceStatus::Ok);
    ExcitationSettings s = excitation_for(t, 0.3, 1);  // designed for 10x the mass
    const ExcitationRecord rec = run_excitation(dev, s);
    EXPECT_FALSE(rec.completed);
    EXPECT_TRUE(rec.guard_tripped);
    EXPECT_NE(rec.abort_reason.find("position guard"), std::string::npos);
    ASSERT_FALSE(dev.writes.empty());
    EXPECT_EQ(dev.writes.back(), 0.0);
}

TEST(Excitation, DeviceFailureAbortsAndEndsAtZeroForce) {
    TruePlant t{"", 0.3, 1.0, 0.0, 0.0, 0.0, 0.0, 10.0, false};
    SimDeviceConfig c = sim_config(t, 1);
    c.fail_at_tick = 500;
    WatchingDevice dev(c);
    ASSERT_EQ(dev.open(), DeviceStatus::Ok);
    ASSERT_EQ(dev.home(), DeviceStatus::Ok);
    const ExcitationRecord rec = run_excitation(dev, excitation_for(t, 0.3, 1));
    EXPECT_FALSE(rec.completed);
    EXPECT_EQ(rec.status, DeviceStatus::Disconnected);
    EXPECT_EQ(dev.writes.back(), 0.0);  // attempted on the way out
    EXPECT_EQ(rec.data.force.size(), 500U);
}

TEST(Excitation, StopRequestAborts) {
    TruePlant t{"", 0.3, 1.0, 0.0, 0.0, 0.0, 0.0, 10.0, false};
    WatchingDevice dev(sim_config(t, 1));
    ASSERT_EQ(dev.open(), DeviceStatus::Ok);
    ASSERT_EQ(dev.home(), DeviceStatus::Ok);
    request_stop(15);
    const ExcitationRecord rec = run_excitation(dev, excitation_for(t, 0.3, 1));
    clear_stop_request();
    EXPECT_FALSE(rec.completed);
    EXPECT_TRUE(rec.stopped);
}

TEST(IdentificationFile, RoundTripAndComparison) {
    const ExcitationRecord rec = excite(kPlants[0], 3, 3);
    const IdentificationResult r = identify_plant(rec.data);
    ASSERT_TRUE(r.ok);
    std::string device;
    const IdentificationResult back =
        identification_from_json(nlohmann::json::parse(identification_to_json(r, "dev").dump()), device);
    EXPECT_EQ(device, "dev");
    EXPECT_EQ(back.mass, r.mass);
    EXPECT_EQ(back.delay_periods, r.delay_periods);
    EXPECT_EQ(back.covariance, r.covariance);
    // Same device, other noise: no change reported.
    const IdentificationResult again = identify_plant(excite(kPlants[0], 4, 9).data);
    EXPECT_TRUE(compare_identifications(r, again).empty());
    // Heavier hand (+5 %) and one more period of delay: both reported.
    TruePlant changed = kPlants[0];
    changed.mass *= 1.05;
    changed.delay_periods += 1.0;
    const auto changes = compare_identifications(r, identify_plant(excite(changed, 5, 9).data));
    ASSERT_EQ(changes.size(), 2U);
    EXPECT_NE(changes[0].find("mass changed"), std::string::npos);
    EXPECT_NE(changes[1].find("delay changed"), std::string::npos);
    EXPECT_THROW(identification_from_json(nlohmann::json{{"format", "x"}}, device), std::runtime_error);
    EXPECT_THROW(
        identification_from_json(nlohmann::json{{"format", "hapticd-identification"}, {"period", 1e-3}}, device),
        std::runtime_error);
}

// hapticd in-process: --identify writes the file and the summary; a restart reuses it; a changed device warns.
struct Captured {
    int code = -1;
    std::string out, err;
};

Captured run_hapticd(std::vector<std::string> args) {
    args.insert(args.begin(), "hapticd");
    std::vector<const char*> argv;
    for (const auto& a : args) argv.push_back(a.c_str());
    std::ostringstream out, err;
    auto* old_out = std::cout.rdbuf(out.rdbuf());
    auto* old_err = std::cerr.rdbuf(err.rdbuf());
    Captured c;
    c.code = hapticd_main(static_cast<int>(argv.size()), argv.data());
    std::cout.rdbuf(old_out);
    std::cerr.rdbuf(old_err);
    c.out = out.str();
    c.err = err.str();
    return c;
}

void write_profile(const std::string& path, double mass) {
    std::ofstream f(path);
    f << "name = \"idtest\"\ndriver = \"sim\"\nmass = " << mass
      << "\ndamping = 2.0\nstiffness = 50.0\ninherent_delay = 0.0031\nmax_force = 10.0\naxes = 1\n"
         "workspace_min = [-0.06]\nworkspace_max = [0.06]\nposition_noise = 2e-6\nposition_resolution = "
         "2e-6\nnoise_seed = 3\n";
}

nlohmann::json read_json(const std::string& path) {
    std::ifstream f(path);
    return nlohmann::json::parse(f);
}

TEST(HapticdIdentify, WritesReusesAndWarnsOnChange) {
    namespace fs = std::filesystem;
    const fs::path dir = fs::temp_directory_path() / ("hapticd_ident_" + std::to_string(::getpid()));
    fs::create_directories(dir);
    const std::string profile = (dir / "idtest.toml").string();
    const std::string file = (dir / "ident.json").string();
    const std::string summary = (dir / "summary.json").string();
    write_profile(profile, 0.30);
    const std::vector<std::string> common{
        "--config",       "",      "--device",   profile, "--lockstep", "--identification-file", file,
        "--summary-json", summary, "--bilateral"};

    auto args = common;
    args.insert(args.end(), {"--identify", "--duration", "0.2"});
    Captured c = run_hapticd(args);
    ASSERT_EQ(c.code, 0) << c.err;
    EXPECT_NE(c.out.find("identified (excitation"), std::string::npos) << c.out;
    ASSERT_TRUE(fs::exists(file));
    nlohmann::json s = read_json(summary);
    ASSERT_TRUE(s.contains("identified"));
    const auto& id = s["identified"];
    EXPECT_EQ(id["source"], "excitation");
    EXPECT_NEAR(id["mass"].get<double>(), 0.30, 0.003);
    EXPECT_NEAR(id["damping"].get<double>(), 2.0, 0.1);
    EXPECT_NEAR(id["delay_periods"].get<double>(), 3.1, 0.1);
    EXPECT_EQ(id["delay_whole_periods"].get<long long>(), 3);
    EXPECT_EQ(id["configured"]["mass"].get<double>(), 0.30);
    EXPECT_EQ(s["K"].get<double>(), id["K"].get<double>());  // the wall uses the identified tuning
    EXPECT_LE(id["excitation"]["max_abs_force"].get<double>(), id["excitation"]["force_limit"].get<double>());
    const double K_first = s["K"].get<double>();

    // Restart without --identify: reused, no excitation, same gains.
    args = common;
    args.insert(args.end(), {"--dry-run"});
    c = run_hapticd(args);
    ASSERT_EQ(c.code, 0) << c.err;
    s = read_json(summary);
    EXPECT_EQ(s["identified"]["source"], "file");
    EXPECT_EQ(s["K"].get<double>(), K_first);

    // --robust after an identification: the box is the identified values +- 3 standard errors;
    // its bounds are checked against the identified values in the file (relative 1e-12: the same
    // doubles, one multiply-add).
    args = common;
    args.insert(args.end(), {"--robust", "--dry-run"});
    c = run_hapticd(args);
    ASSERT_EQ(c.code, 0) << c.err;
    s = read_json(summary);
    ASSERT_TRUE(s.contains("robust")) << s.dump(2);
    {
        const nlohmann::json f = read_json(file);
        const double m = f["mass"].get<double>(), sm = f["mass_stderr"].get<double>();
        ASSERT_GT(sm, 0.0);
        EXPECT_NEAR(s["robust"]["mass"][0].get<double>(), m - 3 * sm, 1e-12 * m);
        EXPECT_NEAR(s["robust"]["mass"][1].get<double>(), m + 3 * sm, 1e-12 * m);
        const double d = f["delay_periods"].get<double>() * 1e-3;
        EXPECT_LT(s["robust"]["delay"][0].get<double>(), d);
        EXPECT_GT(s["robust"]["delay"][1].get<double>(), d);
        EXPECT_LE(s["robust"]["worst_case"].get<double>(),
                  s["robust"]["nominal_worst_case"].get<double>() * (1 + 1e-12));
    }

    // The device got 10 % heavier: --identify warns and rewrites the file.
    write_profile(profile, 0.33);
    args = common;
    args.insert(args.end(), {"--identify", "--dry-run"});
    c = run_hapticd(args);
    ASSERT_EQ(c.code, 0) << c.err;
    EXPECT_NE(c.err.find("the device changed"), std::string::npos) << c.err;
    EXPECT_NE(c.err.find("mass changed"), std::string::npos) << c.err;
    EXPECT_NEAR(read_json(file)["mass"].get<double>(), 0.33, 0.0033);

    // A broken file is a config error (exit 3).
    {
        std::ofstream f(file);
        f << "{ not json";
    }
    args = common;
    args.insert(args.end(), {"--dry-run"});
    c = run_hapticd(args);
    EXPECT_EQ(c.code, 3) << c.err;
    fs::remove_all(dir);
}

// An identified mass outside the profile's mass_range (the shipped sim profile: [0.22, 0.30] kg, and the identified
// mass of its 0.30 kg handle lands either side of 0.30 by the noise): the plant set the walls are certified over
// holds the identified mass too, and the run starts (it was an internal error).
TEST(HapticdIdentify, AnIdentifiedMassOutsideTheMassRangeWidensTheSet) {
    namespace fs = std::filesystem;
    const fs::path dir = fs::temp_directory_path() / ("hapticd_ident_range_" + std::to_string(::getpid()));
    fs::create_directories(dir);
    const std::string profile = (dir / "ranged.toml").string();
    const std::string summary = (dir / "summary.json").string();
    {
        std::ofstream f(profile);
        f << "name = \"ranged\"\ndriver = \"sim\"\nmass = 0.30\nmass_range = [0.22, 0.30]\ndamping = 2.0\n"
             "inherent_delay = 0.0031\nmax_force = 10.0\naxes = 1\nworkspace_min = [-0.06]\nworkspace_max = [0.06]\n"
             "position_noise = 2e-6\nposition_resolution = 2e-6\nnoise_seed = 3\n";
    }
    const Captured c = run_hapticd({"--config", "", "--device", profile, "--lockstep", "--identify", "--hand-mass",
                                    "0.01", "--duration", "0.1", "--summary-json", summary, "--bilateral"});
    ASSERT_EQ(c.code, 0) << c.err;
    const nlohmann::json s = read_json(summary);
    const double m = s["identified"]["mass"].get<double>();
    EXPECT_GT(m, 0.30) << "the case needs an identified mass above the range";
    ASSERT_TRUE(s.contains("plant_set")) << s.dump();
    EXPECT_LE(s["plant_set"]["mass"][0].get<double>(), 0.22 / 1.1 + 1e-12);
    EXPECT_GE(s["plant_set"]["mass"][1].get<double>(), m * 1.1 - 1e-12);
    fs::remove_all(dir);
}

}  // namespace
}  // namespace hapticd
