// SPDX-License-Identifier: Apache-2.0
// The daemon against the analysis: hapticd in lockstep on the simulated device, step scenario,
// bilateral wall, must reproduce hapticopt's step response and energy costs.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include <hapticopt/hapticopt.hpp>
#include <nlohmann/json.hpp>

#include "common/test_paths.hpp"
#include "devices/zoh_plant.hpp"
#include "daemon/hapticd_main.hpp"

namespace hapticd {
namespace {

struct Row {
    double x, wall, external;
};

struct Case {
    const char* name;
    double mass, damping, stiffness;  // physical plant
    double inherent_delay_periods;    // simulated device delay
    int buffer;                       // --delay-buffer
    std::vector<std::string> gains;   // e.g. {"--criterion", "CE2"} or {"--stiffness", .., "--damping", ..}
    double duration_s;
    std::string profile_lines{};  // more device-profile keys, "key = value\n" each
};

struct RunOutput {
    std::vector<Row> rows;
    nlohmann::json summary;
    // The rows of the rendered run: every tick before the stop window (the last `stop_ticks` ticks, whose
    // target force is zero: docs/hapticd.md, "Safety"), and the first window tick, whose position the window's
    // force has not reached yet. The linear analysis describes these. (The runs that count ticks up to 5999 last
    // 6.01 s: their stop window comes after.)
    [[nodiscard]] std::size_t rendered() const {
        const std::size_t window = summary["force_limiter"]["stop_ticks"].get<std::size_t>();
        return rows.size() >= window ? rows.size() - window + 1 : 0;
    }
};

std::filesystem::path dir() {
    auto d = std::filesystem::temp_directory_path() / ("hapticd_analysis_" + std::to_string(::getpid()));
    std::filesystem::create_directories(d);
    return d;
}

RunOutput run_hapticd(const std::vector<std::string>& args, const std::string& trace, const std::string& summary);

RunOutput run_daemon(const Case& c) {
    const double T = 1e-3;
    const auto profile = dir() / (std::string(c.name) + "_device.toml");
    {
        std::ofstream p(profile);
        p.precision(17);
        p << "mass = " << c.mass << "\ndamping = " << c.damping << "\nstiffness = " << c.stiffness
          << "\ninherent_delay = " << c.inherent_delay_periods * T << "\nmax_force = 1000.0\n"
          << c.profile_lines;
    }
    const std::string trace = (dir() / (std::string(c.name) + ".csv")).string();
    const std::string summary = (dir() / (std::string(c.name) + ".json")).string();
    std::vector<std::string> args{"hapticd",
                                  "--config",
                                  "",
                                  "--device",
                                  profile.string(),
                                  "--lockstep",
                                  "--quiet",
                                  "--scenario",
                                  "step",
                                  "--hand-damping",
                                  "0",
                                  "--hand-stiffness",
                                  "0",
                                  "--bilateral",
                                  "--rate",
                                  "1000",
                                  "--delay-buffer",
                                  std::to_string(c.buffer),
                                  "--duration",
                                  std::to_string(c.duration_s),
                                  "--trace",
                                  trace,
                                  "--summary-json",
                                  summary};
    args.insert(args.end(), c.gains.begin(), c.gains.end());
    return run_hapticd(args, trace, summary);
}

// hapticd_main with `args` (which name `trace` and `summary`); the trace's rows in tick order and the summary.
RunOutput run_hapticd(const std::vector<std::string>& args, const std::string& trace, const std::string& summary) {
    std::vector<const char*> argv;
    for (const auto& a : args) argv.push_back(a.c_str());
    const int code = hapticd_main(static_cast<int>(argv.size()), argv.data());
    EXPECT_EQ(code, 0);
    RunOutput out;
    std::ifstream in(trace);
    std::string line;
    std::getline(in, line);
    while (std::getline(in, line)) {
        unsigned long long tick = 0;
        double t = 0, lat = 0;
        Row r{};
        if (std::sscanf(line.c_str(), "%llu,%lf,%lf,%lf,%lf,%lf", &tick, &t, &r.x, &r.wall, &r.external, &lat) != 6) {
            ADD_FAILURE() << line;
            break;
        }
        EXPECT_EQ(tick, out.rows.size());
        out.rows.push_back(r);
    }
    out.summary = nlohmann::json::parse(std::ifstream(summary));
    return out;
}

// Sampled positions: both sides are exact zero-order-hold discretisations of the same continuous loop
// (the daemon's in physical units through Eigen's matrix exponential, hapticopt's in normalised units),
// so they differ only by rounding, ~1e-16 per operation, accumulated over a few thousand stable steps:
// relative 1e-9 of the response's scale (x_inf; a pointwise relative error is meaningless at zero
// crossings) leaves a margin of about 1e4 over the observed differences.
void expect_step_response(const Case& c, const RunOutput& out) {
    const double T = 1e-3;
    const double F = 1.0;
    const auto& s = out.summary;
    const hapticopt::NormalizedPlant plant{c.stiffness * T * T / c.mass, c.damping * T / c.mass,
                                           c.inherent_delay_periods + c.buffer};
    const hapticopt::NormalizedGains gains{s["alpha"].get<double>(), s["beta"].get<double>()};
    const auto x = hapticopt::sampled_step_response(plant, gains, out.rendered());
    const double scale = F / (c.stiffness + s["K"].get<double>());
    double worst = 0.0;
    for (std::size_t j = 0; j < out.rendered(); ++j) {
        const double expected = x[j] * F * T * T / c.mass;
        worst = std::max(worst, std::abs(out.rows[j].x - expected) / scale);
    }
    EXPECT_LE(worst, 1e-9) << c.name;
    std::printf("[ %s ] alpha %.6g beta %.6g: max |x_daemon - x_analysis| / x_inf = %.3g over %zu samples\n", c.name,
                gains.alpha, gains.beta, worst, out.rendered());
    EXPECT_EQ(out.rows.back().wall, 0.0);  // the last tick writes zero force
}

// Gauss-Legendre nodes/weights on [0, 1].
std::vector<std::array<double, 2>> gauss_legendre(int n) {
    std::vector<std::array<double, 2>> nw;
    for (int i = 1; i <= n; ++i) {
        double z = std::cos(M_PI * (i - 0.25) / (n + 0.5));
        double dp = 0.0;
        for (int it = 0; it < 100; ++it) {
            double p0 = 1.0, p1 = z;
            for (int k = 2; k <= n; ++k) {
                const double p2 = ((2.0 * k - 1.0) * z * p1 - (k - 1.0) * p0) / k;
                p0 = p1;
                p1 = p2;
            }
            dp = n * (z * p1 - p0) / (z * z - 1.0);
            const double dz = p1 / dp;
            z -= dz;
            if (std::abs(dz) < 1e-16) break;
        }
        nw.push_back({0.5 * (1.0 - z), 1.0 / ((1.0 - z * z) * dp * dp)});
    }
    return nw;
}

// C_E0..2 from the trace: the continuous motion between samples is reconstructed exactly (the forces
// acting in each period are in the trace, the plant is known, the device starts at rest), and
// E(t) t^p is integrated with an n-point Gauss-Legendre rule on every piece of constant force. E is
// analytic on each piece, so the rule converges like (omega h)^(2n) / (2n)!; with omega h < 1 rad per
// period the 8-point rule is exact to rounding. The tolerance is the larger of 1e-9 relative and ten
// times the difference between the 4- and 8-point results (the quadrature's own error estimate).
std::array<double, 3> energy_costs_from_trace(const Case& c, const RunOutput& out, int nodes) {
    const double T = 1e-3;
    const double F = 1.0;
    const double K = out.summary["K"].get<double>();
    const PlantParameters plant{c.mass, c.damping, c.stiffness};
    const double x_inf = F / (c.stiffness + K);
    const double e0 = F * F / (2.0 * (c.stiffness + K));
    const int n_int = static_cast<int>(std::floor(c.inherent_delay_periods + 1e-12));
    const double phi = c.inherent_delay_periods - n_int;
    struct Segment {
        double start, length;
        int force_age;
        ZohStep whole;
        std::vector<ZohStep> to_node;
        std::vector<double> node_offset, weight;
    };
    std::vector<Segment> segments;
    auto add = [&](double start, double length, int age) {
        Segment s{start, length, age, discretize(plant, length), {}, {}, {}};
        for (const auto& [z, w] : gauss_legendre(nodes)) {
            s.to_node.push_back(discretize(plant, z * length));
            s.node_offset.push_back(z * length);
            s.weight.push_back(w * length);
        }
        segments.push_back(std::move(s));
    };
    if (phi > 1e-12) {
        add(0.0, phi * T, n_int + 1);
        add(phi * T, (1.0 - phi) * T, n_int);
    } else {
        add(0.0, T, n_int);
    }
    auto wall = [&](long j) { return j < 0 ? 0.0 : out.rows[static_cast<std::size_t>(j)].wall; };
    double x = out.rows[0].x;
    double v = 0.0;
    std::array<double, 3> integral{0.0, 0.0, 0.0};
    for (std::size_t j = 0; j + 1 < out.rendered(); ++j) {
        for (const auto& s : segments) {
            const double u = out.rows[j].external + wall(static_cast<long>(j) - s.force_age);
            for (std::size_t i = 0; i < s.to_node.size(); ++i) {
                double xn = x, vn = v;
                s.to_node[i].apply(xn, vn, u);
                const double t = static_cast<double>(j) * T + s.start + s.node_offset[i];
                const double e = 0.5 * (c.stiffness + K) * (xn - x_inf) * (xn - x_inf) + 0.5 * c.mass * vn * vn;
                integral[0] += s.weight[i] * e;
                integral[1] += s.weight[i] * e * t;
                integral[2] += s.weight[i] * e * t * t;
            }
            s.whole.apply(x, v, u);
        }
        EXPECT_NEAR(x, out.rows[j + 1].x, 1e-9 * x_inf) << "reconstruction drifted at " << j;
    }
    const double end_energy = 0.5 * (c.stiffness + K) * (x - x_inf) * (x - x_inf) + 0.5 * c.mass * v * v;
    EXPECT_LT(end_energy / e0, 1e-20) << c.name << ": run not long enough for the integrals to converge";
    return {integral[0] / (T * e0), integral[1] / (T * T * e0), integral[2] / (T * T * T * e0)};
}

void expect_energy_costs(const Case& c, const RunOutput& out) {
    const double T = 1e-3;
    const hapticopt::NormalizedPlant plant{c.stiffness * T * T / c.mass, c.damping * T / c.mass,
                                           c.inherent_delay_periods + c.buffer};
    const hapticopt::NormalizedGains gains{out.summary["alpha"].get<double>(), out.summary["beta"].get<double>()};
    const auto analysis = hapticopt::energy_costs(plant, gains);
    const auto c4 = energy_costs_from_trace(c, out, 4);
    const auto c8 = energy_costs_from_trace(c, out, 8);
    const double expected[3] = {analysis.ce0, analysis.ce1, analysis.ce2};
    for (int p = 0; p < 3; ++p) {
        const double quadrature_error = std::abs(c8[p] - c4[p]);
        const double tol = std::max(1e-9 * expected[p], 10.0 * quadrature_error);
        EXPECT_NEAR(c8[p], expected[p], tol) << c.name << " C_E" << p;
        std::printf("[ %s ] C_E%d trace %.12g analysis %.12g (GL4-GL8 %.2g)\n", c.name, p, c8[p], expected[p],
                    quadrature_error);
    }
    if (out.summary["predicted_cost"].is_number() && out.summary["criterion"] == "CE2") {
        EXPECT_NEAR(out.summary["predicted_cost"].get<double>(), analysis.ce2, 1e-9 * analysis.ce2);
    }
}

void PrintTo(const Case& c, std::ostream* os) { *os << c.name; }

class DaemonMatchesAnalysis : public ::testing::TestWithParam<Case> {};

TEST_P(DaemonMatchesAnalysis, StepResponseAndEnergyCosts) {
    const Case& c = GetParam();
    const RunOutput out = run_daemon(c);
    ASSERT_GT(out.rows.size(), 100U);
    EXPECT_EQ(out.summary["fault"], "none");
    EXPECT_DOUBLE_EQ(out.summary["delay"].get<double>(), (c.inherent_delay_periods + c.buffer) * 1e-3);
    expect_step_response(c, out);
    expect_energy_costs(c, out);
}

// (gamma, delta) = (0, 0) and (0.001, 0.02) (the paper's range at 1 kHz for m = 0.3 kg: k = 300 N/m,
// b = 6 N s/m).
INSTANTIATE_TEST_SUITE_P(
    Cases, DaemonMatchesAnalysis,
    ::testing::Values(Case{"d0_CE2", 0.3, 0.0, 0.0, 0.0, 0, {"--criterion", "CE2"}, 2.0},
                      Case{"d1_CE2_human_arm", 0.3, 6.0, 300.0, 0.0, 1, {"--criterion", "CE2"}, 3.0},
                      Case{"d4_buffer_CE1", 0.3, 0.0, 0.0, 0.0, 4, {"--criterion", "CE1"}, 8.0},
                      Case{"d3_device1_buffer2_CE0", 0.065, 0.0, 0.0, 1.0, 2, {"--criterion", "CE0"}, 6.0},
                      Case{"d1p5_fractional_device_delay", 0.22, 0.0, 0.0, 0.5, 1, {"--criterion", "CE2"}, 4.0},
                      // The paper's C_E0 point for d = 0 as explicit gains: alpha 0.3220, beta 0.9800 (cost 2.583).
                      Case{"d0_paper_CE0_point",
                           0.3,
                           0.0,
                           0.0,
                           0.0,
                           0,
                           {"--criterion", "CE0", "--stiffness", "96600", "--damping", "294"},
                           2.0}),
    [](const ::testing::TestParamInfo<Case>& info) { return std::string(info.param.name); });

TEST(DaemonMatchesAnalysis, PaperCE0PointCost) {
    // alpha = 96600 * 1e-6 / 0.3 = 0.322, beta = 294 * 1e-3 / 0.3 = 0.98: Table III, C_E0 = 2.583.
    const Case c{"paper_ce0", 0.3, 0.0, 0.0, 0.0, 0, {"--criterion", "CE0", "--stiffness", "96600", "--damping", "294"},
                 2.0};
    const RunOutput out = run_daemon(c);
    const auto costs = energy_costs_from_trace(c, out, 8);
    EXPECT_NEAR(costs[0], 2.583, 0.0005);
    EXPECT_NEAR(out.summary["predicted_cost"].get<double>(), 2.583, 0.0005);
}

// The loop with each velocity estimator against the analysis of that loop: hapticopt::make_estimator_loop's state
// (the plant's exact ZOH per delay segment, the estimator's difference equation; estimator_loop.hpp) iterated
// from the step's rest state, against hapticd in lockstep with velocity_estimator in the profile. The gains are
// the estimator's CE2 optimum (optimal_point with the estimator), given explicitly. Both sides are exact
// discretisations of the same loop and differ by rounding only: ~eps per operation, carried by a contracting loop
// over 3000 steps, at most ~3000 x 2.2e-16 = 7e-13 of x_inf if no error ever decayed; tolerance 1e-12 of x_inf.
TEST(DaemonMatchesAnalysis, StepResponseWithEachVelocityEstimator) {
    struct EstimatorCase {
        const char* name;
        const char* profile_value;
        hapticopt::VelocityEstimator estimator;
        double mass, damping, stiffness, device_delay;
        int buffer;
    };
    const double T = 1e-3, F = 1.0;
    const EstimatorCase cases[] = {
        {"d0_lowpass_50Hz", "lowpass:50Hz", hapticopt::VelocityEstimator::low_pass(0.05), 0.3, 0.0, 0.0, 0.0, 0},
        {"d1_window_5_human_arm", "window:5", hapticopt::VelocityEstimator::moving_window(5), 0.3, 6.0, 300.0, 0.0, 1},
        {"d6_lowpass_100Hz", "lowpass:100Hz", hapticopt::VelocityEstimator::low_pass(0.1), 0.3, 0.0, 0.0, 6.0, 0},
        {"d2p5_window_3", "window:3", hapticopt::VelocityEstimator::moving_window(3), 0.22, 0.0, 0.0, 1.5, 1},
    };
    for (const EstimatorCase& e : cases) {
        const hapticopt::NormalizedPlant plant{e.stiffness * T * T / e.mass, e.damping * T / e.mass,
                                               e.device_delay + e.buffer};
        const hapticopt::EstimatorOptimum optimum =
            hapticopt::optimal_point(hapticopt::Criterion::CE2, plant, e.estimator);
        std::ostringstream K, B;
        K.precision(17);
        B.precision(17);
        K << optimum.alpha * e.mass / (T * T);
        B << optimum.beta * e.mass / T;
        const Case c{e.name,
                     e.mass,
                     e.damping,
                     e.stiffness,
                     e.device_delay,
                     e.buffer,
                     {"--criterion", "CE2", "--stiffness", K.str(), "--damping", B.str()},
                     3.0,
                     std::string("velocity_estimator = \"") + e.profile_value + "\"\n"};
        const RunOutput out = run_daemon(c);
        ASSERT_GT(out.rows.size(), 100U) << e.name;
        EXPECT_EQ(out.summary["fault"], "none") << e.name;
        EXPECT_EQ(out.summary["velocity_estimator"], e.profile_value) << e.name;
        const double alpha = out.summary["alpha"].get<double>(), beta = out.summary["beta"].get<double>();
        const hapticopt::EstimatorLoop<double> loop = hapticopt::make_estimator_loop<double>(
            hapticopt::SampledPlant<double>(plant), e.estimator, alpha, beta, false);
        Eigen::VectorXd state = loop.loop.initial_state;
        const double scale = F / (e.stiffness + out.summary["K"].get<double>());
        double worst = 0.0;
        for (std::size_t j = 0; j < out.rendered(); ++j) {
            const double expected = (loop.loop.final_position + state(0)) * F * T * T / e.mass;
            worst = std::max(worst, std::abs(out.rows[j].x - expected) / scale);
            state = loop.loop.transition * state;
        }
        std::printf("[ %s ] alpha %.6g beta %.6g: max |x_daemon - x_analysis| / x_inf = %.3g over %zu samples\n",
                    e.name, alpha, beta, worst, out.rendered());
        EXPECT_LE(worst, 1e-12) << e.name;
        // The backward difference's response differs: the estimator is what the daemon rendered.
        const auto backward = hapticopt::sampled_step_response(plant, hapticopt::NormalizedGains{alpha, beta}, 400);
        double apart = 0.0;
        for (std::size_t j = 0; j < 400; ++j) {
            apart = std::max(apart, std::abs(out.rows[j].x - backward[j] * F * T * T / e.mass) / scale);
        }
        EXPECT_GT(apart, 1e-3) << e.name;
    }
}

// The force noise that the encoder's rounding causes, predicted (hapticopt::force_noise_std, the white-noise model
// of docs/velocity-estimation.md) against the daemon in lockstep on the simulated device with real rounding. The
// simulated position carries Gaussian noise of standard deviation q before it is rounded to the step q: by Widrow's
// quantisation theorem the rounding error is then uniform over one step and independent from tick to tick up to
// terms of order exp(-2 pi^2 sigma^2 / q^2) = 3e-9 (Widrow & Kollar, Quantization Noise, 2008, ch. 4 and 8),
// whatever the handle does; here it rests in a bilateral wall under a 1 N step. The loop is linear (bilateral
// wall, no saturation), and the run without rounding draws the same Gaussian noise (same seed), so the force of
// the run with rounding less that of the run without it is exactly the loop's response to the rounding error.
// Its standard deviation over ticks 2000..41999 against sigma_F: tolerance 4 standard errors of the batch
// estimate (20 batches of 2000 ticks, each far longer than the loop's correlation time of tens of ticks).
TEST(DaemonMatchesAnalysis, ForceNoiseFromTheEncoderStepMatchesTheWhiteNoiseModel) {
    const double T = 1e-3, mass = 0.3, q = 1e-6;
    auto run_with = [&](double resolution, const char* name) {
        std::ostringstream lines;
        lines.precision(17);
        lines << "position_noise = " << q << "\nnoise_seed = 11\nposition_resolution = " << resolution << "\n";
        return run_daemon(Case{name, mass, 0.0, 0.0, 0.0, 1, {"--criterion", "CE2"}, 42.02, lines.str()});
    };
    const RunOutput exact = run_with(0.0, "noise_exact");
    const RunOutput rounded = run_with(q, "noise_rounded");
    ASSERT_EQ(exact.rows.size(), rounded.rows.size());
    const std::size_t first = 2000, batches = 20, batch = 2000;
    ASSERT_GE(rounded.rendered(), first + batches * batch);  // the stop window after them
    std::vector<double> batch_std;
    double max_force = 0.0;
    for (std::size_t k = 0; k < batches; ++k) {
        double sum = 0.0, sum_sq = 0.0;
        for (std::size_t j = first + k * batch; j < first + (k + 1) * batch; ++j) {
            const double e = rounded.rows[j].wall - exact.rows[j].wall;
            sum += e;
            sum_sq += e * e;
            max_force = std::max(max_force, std::abs(rounded.rows[j].wall));
        }
        const double n = static_cast<double>(batch);
        batch_std.push_back(std::sqrt(std::max(0.0, sum_sq / n - (sum / n) * (sum / n))));
    }
    double mean = 0.0, spread = 0.0;
    for (double v : batch_std) mean += v / static_cast<double>(batches);
    for (double v : batch_std) spread += (v - mean) * (v - mean) / static_cast<double>(batches - 1);
    const double standard_error = std::sqrt(spread / static_cast<double>(batches));
    const hapticopt::WallGains gains{rounded.summary["K"].get<double>(), rounded.summary["B"].get<double>()};
    const double predicted = hapticopt::force_noise_std(hapticopt::PhysicalPlant{mass, 0.0, 0.0, T, T}, gains, q);
    std::printf(
        "K %.6g N/m, B %.6g N s/m, q %.3g m: force noise measured %.6g +- %.2g N, predicted %.6g N "
        "(peak force %.3g N)\n",
        gains.stiffness, gains.damping, q, mean, standard_error, predicted, max_force);
    EXPECT_LT(max_force, 10.0);
    EXPECT_NEAR(mean, predicted, 4.0 * standard_error);
    // What the start-up line and the summary give is that prediction.
    EXPECT_DOUBLE_EQ(rounded.summary["force_noise_std"].get<double>(), predicted);
    EXPECT_EQ(rounded.summary["position_resolution"].get<double>(), q);
    EXPECT_TRUE(exact.summary["force_noise_std"].is_null());
}

// The shipped Falcon profile with the paper's backward difference, no force-noise budget and its 6 ms alone (its
// velocity_estimator, force_noise_budget and inherent_delay_range lines left out: the walls are the CE2 optimum for
// that loop, which the analyses below are made for), plus `extra` lines: the loop the tests below analyse.
std::string falcon_with_the_backward_difference(const std::string& tag, const std::string& extra = "") {
    const auto profile = dir() / (tag + ".toml");
    std::ifstream in(HAPTICD_SOURCE_CONFIG_DIR + "/devices/falcon.toml");
    std::ofstream out(profile);
    std::string line;
    int dropped = 0;
    while (std::getline(in, line)) {
        if (line.rfind("velocity_estimator", 0) == 0 || line.rfind("force_noise_budget", 0) == 0 ||
            line.rfind("inherent_delay_range", 0) == 0) {
            ++dropped;
            continue;
        }
        out << line << "\n";
    }
    out << extra;
    EXPECT_EQ(dropped, 3)
        << "config/devices/falcon.toml: expected its velocity_estimator, force_noise_budget and inherent_delay_range";
    return profile.string();
}

// The chatter at rest in contact on the simulated Falcon with the backward difference (`--device falcon --simulate`,
// falcon_with_the_backward_difference: 0.30 kg, 6 ms, the shipped encoder step q = 48.5 um along x, the CE2 wall, the
// default hand b_H 4 N s/m, k_H 200 N/m pressing 1 N): the rounded loop does not settle, the measured position keeps
// changing between neighbouring counts. Its rate against the describing-function cycle of
// hapticopt::predict_limit_cycle for the simulated plant (mass with the hand's spring and damper, no Coulomb friction,
// the 1 N push): the frequency of upward count changes over ticks 1000..5999. Tolerance 10 %: the describing function
// neglects the harmonics and the sampling of the quantiser's input; its frequency was within 6 % of the simulated one
// for the same kind of wall at d = 6 without friction (docs/limit-cycles.md), and counting over 5 s resolves 0.2 Hz.
// The summary's encoder_chatter is the cycle for the profile's plant (no hand), a push half-way between two counts, as
// printed at start-up.
TEST(DaemonMatchesAnalysis, TheSimulatedFalconChattersAtTheDescribingFunctionsFrequency) {
    const std::string trace = (dir() / "falcon_chatter.csv").string();
    const std::string summary = (dir() / "falcon_chatter.json").string();
    const RunOutput out =
        run_hapticd({"hapticd", "--config", "", "--device", falcon_with_the_backward_difference("falcon_backward"),
                     "--simulate", "--lockstep", "--quiet", "--hand-damping", "4", "--hand-stiffness", "200",
                     "--duration", "6.01", "--trace", trace, "--summary-json", summary},
                    trace, summary);
    const double T = 1e-3, q = 4.85e-5;
    ASSERT_GE(out.rows.size(), 6000U);
    int upward = 0;
    for (std::size_t j = 1000; j < 6000; ++j) upward += out.rows[j].x > out.rows[j - 1].x ? 1 : 0;
    const double measured = upward / 5.0;
    const hapticopt::WallGains gains{out.summary["K"].get<double>(), out.summary["B"].get<double>()};
    const hapticopt::LimitCyclePrediction simulated = hapticopt::predict_limit_cycle(
        hapticopt::LimitCycleLoop{hapticopt::PhysicalPlant{0.30, 4.0, 200.0, T, 0.006}, gains, 0.0, q, 1.0});
    ASSERT_TRUE(simulated.predicted && simulated.cycle.stable);
    std::printf(
        "simulated Falcon at rest in the CE2 wall: %.4g count changes upwards per s, describing function "
        "%.4g Hz (amplitude %.3g um)\n",
        measured, simulated.cycle.frequency, 1e6 * simulated.cycle.amplitude);
    EXPECT_NEAR(measured, simulated.cycle.frequency, 0.10 * simulated.cycle.frequency);

    const auto& chatter = out.summary["encoder_chatter"];
    ASSERT_TRUE(chatter.is_object()) << out.summary.dump();
    EXPECT_DOUBLE_EQ(chatter["count_kick"].get<double>(), gains.damping * q / T);
    EXPECT_DOUBLE_EQ(chatter["friction_for_rest"].get<double>(), gains.stiffness * q / 2.0);
    const hapticopt::LimitCyclePrediction profile = hapticopt::predict_limit_cycle(hapticopt::LimitCycleLoop{
        hapticopt::PhysicalPlant{0.30, 0.0, 0.0, T, 0.006}, gains, 0.0, q, gains.stiffness * q * 20.5});
    EXPECT_DOUBLE_EQ(chatter["cycle_frequency"].get<double>(), profile.cycle.frequency);
    EXPECT_DOUBLE_EQ(chatter["cycle_amplitude"].get<double>(), profile.cycle.amplitude);
}

// Coulomb friction on the simulated Falcon (the backward-difference profile above plus `coulomb_friction`; the
// setup of the test above): the step intent pushes with F = (K + k_H) q (12 + 1/2), so the balance F / (K + k_H) lies
// half-way between the encoder levels 12 q and 13 q, the push farthest from every rest. A sticking rest then exists iff
// f_c >= K q / 2 = 0.034 N (hapticopt::quantised_rest_exists with the hand's spring; docs/limit-cycles.md, item 3).
// Below it (f_c = 0.02 N) no rest exists and the loop must keep moving: the measured position takes two levels and the
// wall force keeps changing over ticks 2000..5998. Above it (f_c = 0.05 N) the handle comes to rest, which a rest's
// existence alone does not guarantee (measured, docs/limit-cycles.md, "Coulomb friction in the simulated
// device"): one level and one constant force over those ticks, the force of the rest's level, -K n q. The
// summary's encoder_chatter carries the profile's friction, the rest verdict for every push (f_c >= K q / 2), the
// Abbott-Okamura bound for the profile's plant (b = 0: 2 f_c / q) and the describing function's cycle with that
// friction, each compared with the library's function on the same numbers (the same computation: exact equality).
TEST(DaemonMatchesAnalysis, TheSimulatedFalconComesToRestWithCoulombFrictionAboveHalfACountsForce) {
    const double T = 1e-3, q = 4.85e-5, k_hand = 200.0;
    const hapticopt::WallTuning tuning =
        hapticopt::optimal_wall(hapticopt::Criterion::CE2, hapticopt::PhysicalPlant{0.30, 0.0, 0.0, T, 0.006});
    const hapticopt::WallGains gains{tuning.K, tuning.B};
    const double push = (gains.stiffness + k_hand) * q * 12.5;
    for (const double friction : {0.02, 0.05}) {
        const std::string tag = "falcon_friction_" + std::to_string(static_cast<int>(friction * 1000));
        std::ostringstream friction_line;
        friction_line << "coulomb_friction = " << friction << "\n";
        const std::string profile = falcon_with_the_backward_difference(tag, friction_line.str());
        const std::string trace = (dir() / (tag + ".csv")).string();
        const std::string summary = (dir() / (tag + ".json")).string();
        std::ostringstream force;
        force.precision(17);
        force << push;
        const RunOutput out = run_hapticd({"hapticd",
                                           "--config",
                                           "",
                                           "--device",
                                           profile,
                                           "--simulate",
                                           "--lockstep",
                                           "--quiet",
                                           "--hand-damping",
                                           "4",
                                           "--hand-stiffness",
                                           std::to_string(k_hand),
                                           "--step-force",
                                           force.str(),
                                           "--duration",
                                           "6.01",
                                           "--trace",
                                           trace,
                                           "--summary-json",
                                           summary},
                                          trace, summary);
        ASSERT_GE(out.rows.size(), 6000U);
        const bool rest = hapticopt::quantised_rest_exists(push, gains.stiffness, friction, q, k_hand);
        EXPECT_EQ(rest, friction >= gains.stiffness * q / 2) << friction;
        double lo = HUGE_VAL, hi = -HUGE_VAL;
        int changes = 0;
        std::vector<double> levels;
        for (std::size_t j = 2000; j < 5999; ++j) {
            lo = std::min(lo, out.rows[j].wall);
            hi = std::max(hi, out.rows[j].wall);
            changes += out.rows[j].wall != out.rows[j - 1].wall ? 1 : 0;
            if (std::find(levels.begin(), levels.end(), out.rows[j].x) == levels.end()) levels.push_back(out.rows[j].x);
        }
        std::printf(
            "coulomb_friction %.3g N (K q / 2 = %.4g N), push %.6g N: rest exists %d; ticks 2000..5998: %zu "
            "levels, %d force changes, force %.6g .. %.6g N\n",
            friction, gains.stiffness * q / 2, push, rest ? 1 : 0, levels.size(), changes, lo, hi);
        if (rest) {
            EXPECT_EQ(levels.size(), 1U) << friction;
            EXPECT_EQ(changes, 0) << friction;
            const double n = std::round(levels.front() / q);
            EXPECT_NEAR(lo, -gains.stiffness * n * q, 1e-9) << friction;
        } else {
            EXPECT_EQ(levels.size(), 2U) << friction;
            EXPECT_GT(changes, 100) << friction;
        }
        const auto& chatter = out.summary["encoder_chatter"];
        ASSERT_TRUE(chatter.is_object()) << out.summary.dump();
        EXPECT_EQ(chatter["coulomb_friction"].get<double>(), friction);
        EXPECT_EQ(chatter["rest_for_every_push"].get<bool>(), friction >= gains.stiffness * q / 2);
        const hapticopt::AbbottOkamuraPassivity ao =
            hapticopt::abbott_okamura_passivity(out.summary["K"].get<double>(), 0.0, friction, q, T);
        EXPECT_EQ(chatter["abbott_okamura_passive"].get<bool>(), ao.passive);
        EXPECT_DOUBLE_EQ(chatter["abbott_okamura_bound"].get<double>(), 2 * friction / q);
        const double K = out.summary["K"].get<double>();
        const hapticopt::LimitCyclePrediction predicted =
            hapticopt::predict_limit_cycle(hapticopt::LimitCycleLoop{hapticopt::PhysicalPlant{0.30, 0.0, 0.0, T, 0.006},
                                                                     {K, out.summary["B"].get<double>()},
                                                                     friction,
                                                                     q,
                                                                     K * q * 20.5});
        if (predicted.predicted && predicted.cycle.stable) {
            EXPECT_DOUBLE_EQ(chatter["cycle_amplitude"].get<double>(), predicted.cycle.amplitude);
            EXPECT_DOUBLE_EQ(chatter["cycle_frequency"].get<double>(), predicted.cycle.frequency);
        } else {
            EXPECT_TRUE(chatter["cycle_amplitude"].is_null());
        }
    }
}

// The shipped Falcon profile's 15-period window against the buzz (the setup of the chatter test above, the profile as
// shipped: velocity_estimator = "window:15", its CE2 wall). At rest on the two encoder levels next to the balance,
// |x_j - x_{j-N}| <= q, so the force K y_{j-d} + B (y_{j-d} - y_{j-d-N}) / (N T) ranges over at most
// K q + 2 B q / (N T) (0.1125 N with the CE2 wall over the plant set, K 359.07 N/m, B 14.706 N s/m), where the backward
// difference with its own CE2 gains has K q + 2 B q / T (3.33 N; measured 2.52 N). Checked over ticks 1000..5998: the
// measured position takes at most two adjacent levels, and the force's range is within that bound (plus 1e-12 N of
// rounding). The summary says what was rendered and predicted: the window, its CE2 optimum (optimal_point with the
// estimator) times the summary's plant_set.derating (the largest fraction of it stable over the profile's plant set,
// its delays 5 .. 7 ms included; < 1) and sigma_F with it.
TEST(DaemonMatchesAnalysis, TheShippedFalconWindowBoundsTheBuzzToOneCountsForce) {
    const double T = 1e-3, q = 4.85e-5, m = 0.30;
    const int N = 15;
    const std::string trace = (dir() / "falcon_window.csv").string();
    const std::string summary = (dir() / "falcon_window.json").string();
    const RunOutput out =
        run_hapticd({"hapticd", "--config", "", "--device", HAPTICD_SOURCE_CONFIG_DIR + "/devices/falcon.toml",
                     "--simulate", "--lockstep", "--quiet", "--hand-damping", "4", "--hand-stiffness", "200",
                     "--duration", "6.01", "--trace", trace, "--summary-json", summary},
                    trace, summary);
    ASSERT_GE(out.rows.size(), 6000U);
    EXPECT_EQ(out.summary["velocity_estimator"], "window:15");
    const hapticopt::EstimatorOptimum optimum =
        hapticopt::optimal_point(hapticopt::Criterion::CE2, hapticopt::NormalizedPlant{0.0, 0.0, 6.0},
                                 hapticopt::VelocityEstimator::moving_window(N));
    const double K = out.summary["K"].get<double>(), B = out.summary["B"].get<double>();
    const double f = out.summary["plant_set"]["derating"].get<double>();
    EXPECT_GT(f, 0.5);
    EXPECT_LE(f, 1.0);
    EXPECT_NEAR(K, f * optimum.alpha * m / (T * T), 1e-12 * K);
    EXPECT_NEAR(B, f * optimum.beta * m / T, 1e-12 * B);
    EXPECT_DOUBLE_EQ(
        out.summary["force_noise_std"].get<double>(),
        hapticopt::force_noise_std(hapticopt::PhysicalPlant{m, 0.0, 0.0, T, 0.006}, hapticopt::WallGains{K, B}, q,
                                   hapticopt::VelocityEstimator::moving_window(N)));
    // The start-up limit-cycle prediction is the describing function with the loop's window (docs/limit-cycles.md,
    // "With a velocity estimator"): the profile's plant, its Coulomb friction (none), a push half-way between two
    // counts; no Abbott-Okamura bound (a condition on a spring wall, B = 0).
    const auto& chatter = out.summary["encoder_chatter"];
    ASSERT_TRUE(chatter.is_object()) << out.summary.dump();
    EXPECT_TRUE(chatter["abbott_okamura_bound"].is_null());
    hapticopt::LimitCycleLoop cycle_loop{hapticopt::PhysicalPlant{m, 0.0, 0.0, T, 0.006}, hapticopt::WallGains{K, B},
                                         0.0, q, K * q * 20.5};
    cycle_loop.estimator = hapticopt::VelocityEstimator::moving_window(N);
    const hapticopt::LimitCyclePrediction cycle = hapticopt::predict_limit_cycle(cycle_loop);
    ASSERT_TRUE(cycle.predicted && cycle.cycle.stable);
    EXPECT_DOUBLE_EQ(chatter["cycle_amplitude"].get<double>(), cycle.cycle.amplitude);
    EXPECT_DOUBLE_EQ(chatter["cycle_frequency"].get<double>(), cycle.cycle.frequency);
    double x_lo = HUGE_VAL, x_hi = -HUGE_VAL, f_lo = HUGE_VAL, f_hi = -HUGE_VAL;
    for (std::size_t j = 1000; j < 5999; ++j) {
        x_lo = std::min(x_lo, out.rows[j].x);
        x_hi = std::max(x_hi, out.rows[j].x);
        f_lo = std::min(f_lo, out.rows[j].wall);
        f_hi = std::max(f_hi, out.rows[j].wall);
    }
    const double bound = K * q + 2.0 * B * q / (N * T);
    std::printf(
        "simulated Falcon at rest, window 15: positions %.4g .. %.4g counts, force range %.4g N (bound %.4g N)\n",
        x_lo / q, x_hi / q, f_hi - f_lo, bound);
    EXPECT_LE(x_hi - x_lo, q * (1.0 + 1e-9));
    EXPECT_LE(f_hi - f_lo, bound + 1e-12);
}

// Removes this process's scratch files at the end.
class ScratchCleanup : public ::testing::Environment {
  public:
    void TearDown() override {
        std::error_code ec;
        std::filesystem::remove_all(dir(), ec);
    }
};
[[maybe_unused]] ::testing::Environment* const kScratchCleanup =
    ::testing::AddGlobalTestEnvironment(new ScratchCleanup);

}  // namespace
}  // namespace hapticd
