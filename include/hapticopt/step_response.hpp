// SPDX-License-Identifier: Apache-2.0
// The continuous-time unit step response x(t), x'(t), E(t) of the loop, exact at any t >= 0
// (normalised units: m = T = 1, F = 1; physical x = x_n F T^2/m, x' = x'_n F T/m,
// E = E_n F^2 T^2/m, t = t_n T).
//
// Method: the loop state e_j at the sample before t by the exact loop map (closed_loop.hpp), then
// exp(A tau) on the segment containing t. Cost O(N^2 floor(t)) for one time; a sorted batch of
// times costs one pass. The response is defined for unstable gains too (it then grows).
#pragma once

#include <algorithm>
#include <cmath>
#include <numeric>
#include <vector>

#include "config.hpp"
#include "closed_loop.hpp"

namespace hapticopt {

template <typename Scalar>
struct StepResponsePointT {
    Scalar time = 0;
    Scalar position = 0;  ///< x(t)
    Scalar velocity = 0;  ///< x'(t)
    Scalar energy = 0;    ///< E(t) = 1/2 (alpha + gamma) (x - x_inf)^2 + 1/2 x'^2  (eq. 4)
};
using StepResponsePoint = StepResponsePointT<double>;

/// x, x', E at each of `times` (any order, each >= 0 and finite).
template <typename Scalar>
std::vector<StepResponsePointT<Scalar>> step_response(const SampledPlant<Scalar>& plant, Scalar alpha, Scalar beta,
                                                      const std::vector<Scalar>& times) {
    for (const Scalar t : times) {
        detail::require_non_negative("hapticopt::step_response", "time", static_cast<double>(t));
    }
    const ClosedLoop<Scalar> loop = make_closed_loop(plant, alpha, beta);
    std::vector<std::size_t> order(times.size());
    std::iota(order.begin(), order.end(), std::size_t{0});
    std::sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) { return times[a] < times[b]; });
    std::vector<StepResponsePointT<Scalar>> out(times.size());
    DynamicVector<Scalar> e = loop.initial_state;
    long long period = 0;
    for (const std::size_t i : order) {
        const Scalar t = times[i];
        const auto j = static_cast<long long>(std::floor(static_cast<double>(t)));
        for (; period < j; ++period) e = loop.transition * e;
        const Scalar tau = t - Scalar(j);
        int s = plant.segment_count() - 1;
        while (s > 0 && tau < plant.segment(s).start) --s;
        const auto& seg = plant.segment(s);
        const Eigen::Matrix<Scalar, 3, 1> xi = exponential<Scalar>(plant.augmented_matrix(), tau - seg.start) *
                                               (loop.segment_map[static_cast<std::size_t>(s)] * e);
        StepResponsePointT<Scalar>& p = out[i];
        p.time = t;
        p.position = loop.final_position + xi(0);
        p.velocity = xi(1);
        p.energy = (loop.total_stiffness * xi(0) * xi(0) + xi(1) * xi(1)) / 2;
    }
    return out;
}

/// x at t (normalised); see step_response above.
HAPTICOPT_FUNC StepResponsePoint step_response_at(const NormalizedPlant& plant, const NormalizedGains& gains,
                                                  double time)
#if HAPTICOPT_DEFINITIONS
{
    validate(gains, "hapticopt::step_response_at");
    return step_response(SampledPlant<double>(plant), gains.alpha, gains.beta, std::vector<double>{time}).front();
}
#else
    ;
#endif

/// x_j = x(j), j = 0 .. samples-1 (normalised; physical x_j F T^2 / m).
HAPTICOPT_FUNC std::vector<double> sampled_step_response(const NormalizedPlant& plant, const NormalizedGains& gains,
                                                         std::size_t samples)
#if HAPTICOPT_DEFINITIONS
{
    validate(gains, "hapticopt::sampled_step_response");
    const SampledPlant<double> sampled(plant);
    const ClosedLoop<double> loop = make_closed_loop(sampled, gains.alpha, gains.beta);
    std::vector<double> x(samples);
    DynamicVector<double> e = loop.initial_state;
    for (std::size_t j = 0; j < samples; ++j) {
        x[j] = loop.final_position + e(0);
        e = loop.transition * e;
    }
    return x;
}
#else
    ;
#endif

}  // namespace hapticopt
