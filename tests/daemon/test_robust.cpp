// SPDX-License-Identifier: Apache-2.0
// hapticd --robust as a process: the gains it renders are the library's robust optimum for the profile's
// box, stable over the whole box, and their worst case is no worse than the nominal optimum's.
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <random>
#include <nlohmann/json.hpp>

#include <hapticopt/hapticopt.hpp>

#include "daemon/exit_codes.hpp"
#include "process_runner.hpp"

namespace hapticd {
namespace {

using test::run;

nlohmann::json read_json(const std::string& path) {
    std::ifstream in(path);
    return nlohmann::json::parse(in);
}

double cost_at(const hapticopt::PhysicalPlant& plant, double K, double B, int index) {
    const auto gains = hapticopt::normalize(hapticopt::WallGains{K, B}, plant.mass, plant.period);
    const auto c = hapticopt::energy_costs(hapticopt::normalize(plant), gains);
    return index == 0 ? c.ce0 : index == 1 ? c.ce1 : c.ce2;
}

TEST(HapticdRobust, RendersTheLibrarysRobustOptimumForTheProfileBox) {
    // The shipped sim profile: 0.30 kg nominal, mass_range [0.22, 0.30] (Table II), no delay; buffer of 1.
    const std::string summary = (test::scratch_dir() / "robust.json").string();
    const auto r = run({"--config", "", "--robust", "--criterion", "CE2", "--delay-buffer", "1", "--dry-run",
                        "--summary-json", summary},
                       "robust");
    ASSERT_EQ(r.code, kExitOk) << r.err;
    EXPECT_NE(r.out.find("robust over mass 0.22..0.3"), std::string::npos) << r.out;
    const nlohmann::json j = read_json(summary);
    ASSERT_TRUE(j.contains("robust")) << j.dump(2);
    const double K = j["K"].get<double>(), B = j["B"].get<double>();

    hapticopt::UncertainPlant box;
    box.mass = {0.22, 0.30};
    box.period = 1e-3;
    box.time_delay = {1e-3, 1e-3};
    const hapticopt::RobustOptimum expected = hapticopt::robust_optimum(hapticopt::Criterion::CE2, box);
    // Same deterministic computation in the daemon and here: equal up to the JSON round trip (17 digits).
    EXPECT_NEAR(K, expected.gains.stiffness, 1e-12 * expected.gains.stiffness);
    EXPECT_NEAR(B, expected.gains.damping, 1e-12 * expected.gains.damping);

    // Independent of the optimiser: stable at both ends and at random masses of the box (Schur-Cohn on the
    // normalised plant), and no sampled mass has a cost above the reported worst case (relative slack 1e-9:
    // the worst case is refined by Brent to ~1e-10 in the mass, so a sampled point can match it to rounding).
    const double worst = j["robust"]["worst_case"].get<double>();
    std::mt19937 rng(7);
    std::uniform_real_distribution<double> mass(0.22, 0.30);
    std::vector<double> masses{0.22, 0.30};
    for (int i = 0; i < 50; ++i) masses.push_back(mass(rng));
    for (double m : masses) {
        hapticopt::PhysicalPlant plant{};
        plant.mass = m;
        plant.period = 1e-3;
        plant.time_delay = 1e-3;
        const auto gains = hapticopt::normalize(hapticopt::WallGains{K, B}, m, plant.period);
        ASSERT_TRUE(hapticopt::is_stable(hapticopt::normalize(plant), gains)) << "m = " << m;
        EXPECT_LE(cost_at(plant, K, B, 2), worst * (1 + 1e-9)) << "m = " << m;
    }
    // The reported worst case is the cost at the reported place.
    hapticopt::PhysicalPlant at{};
    at.mass = j["robust"]["worst_at"]["mass"].get<double>();
    at.period = 1e-3;
    at.time_delay = j["robust"]["worst_at"]["delay"].get<double>();
    EXPECT_NEAR(cost_at(at, K, B, 2), worst, 1e-9 * worst);
    // Robust is no worse than the nominal optimum over the box.
    ASSERT_FALSE(j["robust"]["nominal_worst_case"].is_null());
    EXPECT_LE(worst, j["robust"]["nominal_worst_case"].get<double>() * (1 + 1e-12));
}

}  // namespace
}  // namespace hapticd
