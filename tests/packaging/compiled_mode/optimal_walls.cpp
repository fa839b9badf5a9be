// SPDX-License-Identifier: Apache-2.0
// The README's example extended to every criterion, printed to full precision (%.17g). Built twice by
// tests/packaging/CMakeLists.txt, header-only and against hapticopt::compiled, and the two outputs must be
// identical (packaging.compiled_mode_same_numbers): the same source compiled with the same flags.
#include <hapticopt/hapticopt.hpp>

#include <cstdio>
#include <string>

int main() {
    // Falcon with a hand on it (Table II): 0.30 kg, 1 kHz, 1 ms of delay; and a fractional delay.
    const hapticopt::PhysicalPlant plants[] = {{0.30, 0.0, 0.0, 0.001, 0.001}, {0.30, 0.5, 0.0, 0.001, 0.0025}};
    for (const hapticopt::PhysicalPlant& plant : plants) {
        for (const hapticopt::Criterion c : hapticopt::kAllCriteria) {
            const hapticopt::WallTuning wall = hapticopt::optimal_wall(c, plant);
            std::printf("%s K = %.17g B = %.17g K_max = %.17g\n", std::string(hapticopt::to_string(c)).c_str(), wall.K,
                        wall.B, wall.K_max);
        }
        const hapticopt::StabilityReport s =
            hapticopt::stability(hapticopt::normalize(plant), hapticopt::NormalizedGains{0.5, 0.2});
        std::printf("stable %d margin %.17g radius %.17g\n", s.stable ? 1 : 0, s.margin, s.spectral_radius);
        const hapticopt::ImpulseCosts ic =
            hapticopt::impulse_costs(hapticopt::normalize(plant), hapticopt::NormalizedGains{0.5, 0.2});
        std::printf("CI %.17g %.17g %.17g\n", ic.ci0, ic.ci1, ic.ci2);
        // Velocity estimators (velocity_estimator.hpp).
        for (const hapticopt::VelocityEstimator& e :
             {hapticopt::VelocityEstimator::low_pass(0.02), hapticopt::VelocityEstimator::moving_window(15)}) {
            const hapticopt::NormalizedPlant np = hapticopt::normalize(plant);
            const hapticopt::NormalizedGains g{0.004, 0.09};
            const hapticopt::StabilityReport es = hapticopt::stability(np, g, e);
            const hapticopt::EnergyCosts ec = hapticopt::energy_costs(np, g, e);
            const hapticopt::EstimatorOptimum o = hapticopt::optimal_point(hapticopt::Criterion::CE2, np, e);
            std::printf("estimator stable %d radius %.17g CE %.17g %.17g %.17g OV %.17g g %.17g sigma %.17g\n",
                        es.stable ? 1 : 0, es.spectral_radius, ec.ce0, ec.ce1, ec.ce2,
                        hapticopt::overshoot(np, g, e).value, hapticopt::force_noise_gain(np, g, e),
                        hapticopt::force_noise_std(plant, hapticopt::WallGains{1000, 20}, 2e-5, e));
            std::printf("estimator CE2 alpha %.17g beta %.17g cost %.17g alpha_max %.17g\n", o.alpha, o.beta, *o.cost,
                        o.alpha_max);
        }
    }
    return 0;
}
