// SPDX-License-Identifier: Apache-2.0
// The estimator optimum over a sweep of 180 cases (scripts/estimator-optimum-sweep.sh builds and compares it; not
// a CMake target): low-pass nu = 0.002 .. 0.5 and windows 1 .. 60, d = 0 .. 10, (gamma, delta) = (0, 0),
// (0.01, 0), (0, 0.05). One line per case: the case, alpha_max on the fast optimum's grid (kFastOptimumRegionGrid)
// and on the default one, the CE2 point and cost by OptimumMethod::newton, the CE2 cost by OptimumMethod::brent
// (nan where a call throws).
#include <cmath>
#include <cstdio>
#include <exception>
#include <utility>
#include <vector>

#include <hapticopt/hapticopt.hpp>

int main() {
    using namespace hapticopt;
    std::vector<VelocityEstimator> estimators;
    for (double nu : {0.002, 0.005, 0.02, 0.1, 0.5}) estimators.push_back(VelocityEstimator::low_pass(nu));
    for (int n : {1, 2, 4, 8, 15, 30, 60}) estimators.push_back(VelocityEstimator::moving_window(n));
    const double nan = std::nan("");
    std::printf(
        "kind parameter d gamma delta amax_fast amax_default newton_alpha newton_beta newton_cost brent_cost\n");
    for (const VelocityEstimator& e : estimators) {
        for (double d : {0.0, 1.0, 2.5, 6.0, 10.0}) {
            for (const auto& [gamma, delta] : {std::pair{0.0, 0.0}, std::pair{0.01, 0.0}, std::pair{0.0, 0.05}}) {
                const NormalizedPlant plant{gamma, delta, d};
                double fast = nan, slow = nan, alpha = nan, beta = nan, cost = nan, brent = nan;
                try {
                    fast = EstimatorStabilityRegion(plant, e, kFastOptimumRegionGrid).alpha_max();
                    slow = EstimatorStabilityRegion(plant, e).alpha_max();
                    const EstimatorOptimum n = optimal_point(Criterion::CE2, plant, e);
                    alpha = n.alpha;
                    beta = n.beta;
                    cost = n.cost.value_or(nan);
                } catch (const std::exception&) {
                }
                try {
                    EstimatorOptimumOptions o;
                    o.method = OptimumMethod::brent;
                    brent = optimal_point(Criterion::CE2, plant, e, o).cost.value_or(nan);
                } catch (const std::exception&) {
                }
                const bool lowpass = e.kind == VelocityEstimatorKind::lowpass;
                std::printf("%s %g %g %g %g %.17g %.17g %.17g %.17g %.17g %.17g\n", lowpass ? "lowpass" : "window",
                            lowpass ? e.cutoff : e.window, d, gamma, delta, fast, slow, alpha, beta, cost, brent);
            }
        }
    }
}
