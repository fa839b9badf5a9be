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
  }
  return 0;
}
