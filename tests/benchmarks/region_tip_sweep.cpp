// SPDX-License-Identifier: Apache-2.0
// alpha_max of the main stable region with the estimator (EstimatorStabilityRegion) on three scan grids, 16 x 16
// (kFastOptimumRegionGrid), 40 x 40 and the default 160 x 160, over the 180 cases of estimator_optimum_sweep.cpp
// (low-pass nu = 0.002 .. 0.5 and windows 1 .. 60, d = 0 .. 10, (gamma, delta) = (0, 0), (0.01, 0), (0, 0.05)).
// One line per case (kind 1 low-pass, 2 window; its parameter; d, gamma, delta; the three alpha_max),
// then a summary line: the cases where the grids differ by more than 1e-10 relative and the largest difference.
// Built as hapticopt_region_tip_sweep (not run by the build); against another revision's headers:
//   git archive REV include | tar -x -C /tmp/base
//   g++ -std=c++20 -O2 -DNDEBUG -I/tmp/base/include -isystem /usr/include/eigen3
//       tests/benchmarks/region_tip_sweep.cpp -o /tmp/region_tip_sweep
//   /tmp/region_tip_sweep
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <utility>
#include <vector>

#include <hapticopt/hapticopt.hpp>

int main() {
    using namespace hapticopt;
    std::vector<VelocityEstimator> estimators;
    for (double nu : {0.002, 0.005, 0.02, 0.1, 0.5}) estimators.push_back(VelocityEstimator::low_pass(nu));
    for (int n : {1, 2, 4, 8, 15, 30, 60}) estimators.push_back(VelocityEstimator::moving_window(n));
    int differing = 0;
    double largest = 0;
    for (const VelocityEstimator& e : estimators) {
        for (double d : {0.0, 1.0, 2.5, 6.0, 10.0}) {
            for (const auto& [gamma, delta] : {std::pair{0.0, 0.0}, std::pair{0.01, 0.0}, std::pair{0.0, 0.05}}) {
                const NormalizedPlant plant{gamma, delta, d};
                double a[3] = {0, 0, 0};
                int k = 0;
                for (const EstimatorRegionOptions& grid :
                     {kFastOptimumRegionGrid, EstimatorRegionOptions{40, 40, false}, EstimatorRegionOptions{}}) {
                    a[k++] = EstimatorStabilityRegion(plant, e, grid).alpha_max();
                }
                const double hi = std::max({a[0], a[1], a[2]}), lo = std::min({a[0], a[1], a[2]});
                const double spread = hi > 0 ? (hi - lo) / hi : 0;
                if (spread > 1e-10) ++differing;
                largest = std::max(largest, spread);
                const bool lowpass = e.kind == VelocityEstimatorKind::lowpass;
                std::printf("%d %g %g %g %g %.15g %.15g %.15g\n", lowpass ? 1 : 2,
                            lowpass ? e.cutoff : static_cast<double>(e.window), d, gamma, delta, a[0], a[1], a[2]);
            }
        }
    }
    std::printf("grids differ by more than 1e-10 in %d of 180 cases, by up to %.3g relative\n", differing, largest);
}
