// SPDX-License-Identifier: Apache-2.0
// The collision criteria C_I0..2, the penetration depth and their optimum (impulse_costs.hpp,
// impulse_optimum.hpp) with the wall's velocity estimator (velocity_estimator.hpp): backward difference,
// low-pass (nu) or window (N). Beyond Hulin et al. 2011, whose conclusion leaves the impulse response open.
//
// Initial conditions (normalised units m = T = 1, positions in units of v0 T; linear in v0): as in
// impulse_costs.hpp, the device is at the surface x(0) = 0 with x'(0) = v0 = 1 and no external force; before
// contact it moved at the constant velocity v0, so the estimator's inputs are those of that motion:
//  - the position history y_{-k} = -k (k = 1 .. N): a window of N periods sees v0 at once;
//  - the low-pass state v_{-1} = v0 = 1: it has been tracking the constant velocity (its steady state);
//  - the delay buffer holds zero forces (the wall was not engaged).
// Hence v_0 = 1 for every estimator and the first force is f_0 = alpha x_0 + beta v_0 = beta v0.
//
// Realisation (the force-buffer form of impulse_costs.hpp, with the estimator's states): zero force before
// contact is not expressible through past positions, so the buffer carries the forces:
//   z_j = (x_j, x'_j, y_{j-1}, ..., y_{j-Hy}, [v_{j-1}], f_{j-1}, ..., f_{j-A}),
// Hy = nb - 1 (N for the window, 1 otherwise), v_{j-1} for the low-pass only, A the oldest force age of
// SampledPlant's segments (0 .. A forces act within a period); f_j = alpha x_j + beta v_j with
// v_j = sum_i b_i y_{j-i} + a_1 v_{j-1} (velocity_estimator.hpp). z_0 = (0, 1, -1, ..., -Hy, [1], 0, ..., 0).
// For the backward difference z_j is exactly make_impulse_loop's state and the matrices are the same.
// M' realises the loop's transfer function with its own states, so its eigenvalues are the roots of p_est
// (estimator_stability.hpp) up to extra zeros; stability is tested by the spectral radius of M' (and, in the
// convenience functions, by EstimatorStabilityTest's Schur-Cohn verdict first).
//
// C_Ip: the Stein equations of energy_costs.hpp on the complex Schur form of M' (detail::energy_costs_from_schur,
// exact per-period Gramians), C_Ip = J_p since E(0) = 1/2. Penetration: detail::continuous_maximum of
// overshoot.hpp with P from M'^T P M' = P - I (stop proven by kappa sqrt(z_j^T P z_j) <= maximum found). Both
// exist exactly when the loop is stable (+inf otherwise). Cost O(N^3), N = 2 + Hy + [1] + A, plus O(N^2) per
// period scanned for the penetration. The optimum: minimize_on_region (region_minimum.hpp) over the main
// stable region of EstimatorStabilityRegion (alpha in (0, alpha_max), beta in beta_interval(alpha)).
// Tests: tests/beyond/test_estimator_beyond.cpp (time-stepping with exact ZOH and the estimator's difference
// equation written out, Simpson quadrature; the backward difference, window 1 and a low-pass with a large
// cutoff against impulse_costs.hpp).
#pragma once

#include <cmath>
#include <limits>
#include <optional>

#include "config.hpp"
#include "criterion.hpp"
#include "energy_costs.hpp"
#include "estimator_region.hpp"
#include "estimator_stability.hpp"
#include "impulse_costs.hpp"
#include "impulse_optimum.hpp"
#include "overshoot.hpp"
#include "region_minimum.hpp"
#include "estimator_types.hpp"

namespace hapticopt {

/// The collision loop with the estimator (header comment): M', z_0 and the segment maps R'_s (xi = R'_s z_j =
/// (x, x', acting force) at the segment start); final_position = 0. Cost O(N^2).
template <typename Scalar>
ClosedLoop<Scalar> make_estimator_impulse_loop(const SampledPlant<Scalar>& plant, const VelocityEstimator& estimator,
                                               Scalar alpha, Scalar beta) {
    const EstimatorCoefficients<Scalar> co = estimator_coefficients<Scalar>(estimator);
    const int nb = static_cast<int>(co.b.size());
    const int na = static_cast<int>(co.a.size());  // 0 or 1
    const int hy = nb - 1;
    const int ages = plant.history_length() - 1;   // oldest force age A
    const int v_index = na > 0 ? 2 + hy : -1;      // v_{j-1}
    const int f_base = 2 + hy + (na > 0 ? 1 : 0);  // f_{j-age} at f_base + age - 1
    const int n = f_base + ages;
    using Row = DynamicMatrix<Scalar>;
    auto position = [&](int i) {  // y_{j-i}, i = 0 .. hy
        Row r = Row::Zero(1, n);
        r(0, i == 0 ? 0 : 1 + i) = 1;
        return r;
    };
    auto force_row = [&](int age) {
        Row r = Row::Zero(1, n);
        if (age == 0) {  // f_j = alpha x_j + beta (sum_i b_i y_{j-i} + a_1 v_{j-1})
            r = alpha * position(0);
            for (int i = 0; i < nb; ++i) r += beta * co.b[static_cast<std::size_t>(i)] * position(i);
            if (na > 0) r(0, v_index) += beta * co.a[0];
        } else {
            r(0, f_base + age - 1) = 1;
        }
        return r;
    };
    ClosedLoop<Scalar> loop;
    loop.alpha = alpha;
    loop.beta = beta;
    loop.total_stiffness = alpha + Scalar(plant.parameters().gamma);
    loop.final_position = 0;
    Row plant_rows = Row::Zero(2, n);
    plant_rows(0, 0) = 1;
    plant_rows(1, 1) = 1;
    for (int s = 0; s < plant.segment_count(); ++s) {
        const auto& seg = plant.segment(s);
        Row r(3, n);
        r.topRows(2) = plant_rows;
        r.row(2) = force_row(seg.force_age);
        plant_rows = seg.exp.template topRows<2>() * r;
        loop.segment_map[static_cast<std::size_t>(s)] = r;
    }
    Row& m = loop.transition;
    m = Row::Zero(n, n);
    m.topRows(2) = plant_rows;
    m(2, 0) = 1;                                    // y_j becomes y_{(j+1)-1}
    for (int i = 2; i <= hy; ++i) m(1 + i, i) = 1;  // y_{j-i+1} becomes y_{(j+1)-i}
    if (na > 0) {                                   // v_j = sum_i b_i y_{j-i} + a_1 v_{j-1}
        for (int i = 0; i < nb; ++i) m.row(v_index) += co.b[static_cast<std::size_t>(i)] * position(i);
        m(v_index, v_index) += co.a[0];
    }
    if (ages >= 1) m.row(f_base) = force_row(0);  // f_j becomes f_{(j+1)-1}
    for (int age = 2; age <= ages; ++age) m(f_base + age - 1, f_base + age - 2) = 1;
    loop.initial_state = DynamicVector<Scalar>::Zero(n);
    loop.initial_state(1) = 1;                                             // x'(0) = v0
    for (int i = 1; i <= hy; ++i) loop.initial_state(1 + i) = -Scalar(i);  // y_{-i} = -i v0 T
    if (na > 0) loop.initial_state(v_index) = 1;                           // the low-pass has tracked v0
    return loop;
}

/// C_I0..2 with the estimator for a precomputed plant; +inf when the loop is unstable (spectral radius of M'
/// >= 1) or rounding at the boundary makes a cost non-positive. Every kind goes through the estimator's loop.
template <typename Scalar>
ImpulseCostsT<Scalar> estimator_impulse_costs(const SampledPlant<Scalar>& plant, const VelocityEstimator& estimator,
                                              Scalar alpha, Scalar beta) {
    const Scalar inf = std::numeric_limits<Scalar>::infinity();
    if (!(alpha + Scalar(plant.parameters().gamma) > Scalar(0))) return {inf, inf, inf};
    const ClosedLoop<Scalar> loop = make_estimator_impulse_loop(plant, estimator, alpha, beta);
    const LoopSchurForm<Scalar> schur = loop_schur_form(loop.transition);
    if (!(schur.spectral_radius < Scalar(1))) return {inf, inf, inf};
    const EnergyCostsT<Scalar> e = detail::energy_costs_from_schur(plant, loop, schur);
    const Scalar k = loop.total_stiffness;  // e = k J_p; C_Ip = J_p because E(0) = 1/2
    const ImpulseCostsT<Scalar> out{e.ce0 / k, e.ce1 / k, e.ce2 / k};
    for (Scalar v : {out.ci0, out.ci1, out.ci2}) {
        if (!(v > Scalar(0)) || !std::isfinite(static_cast<double>(v))) return {inf, inf, inf};
    }
    return out;
}

/// C_I0..2 with the estimator at (gamma, delta, d) and (alpha, beta); +inf when EstimatorStabilityTest finds
/// the loop unstable. The backward difference is impulse_costs(plant, gains). Throws InvalidParameter for
/// non-finite gains, invalid plant parameters or an invalid estimator.
HAPTICOPT_FUNC ImpulseCosts impulse_costs(const NormalizedPlant& plant, const NormalizedGains& gains,
                                          const VelocityEstimator& estimator)
#if HAPTICOPT_DEFINITIONS
{
    validate(gains, "hapticopt::impulse_costs");
    validate(estimator, "hapticopt::impulse_costs");
    if (estimator.kind == VelocityEstimatorKind::backward) return impulse_costs(plant, gains);
    if (!EstimatorStabilityTest(plant, estimator).stable(gains.alpha, gains.beta)) {
        return {HUGE_VAL, HUGE_VAL, HUGE_VAL};
    }
    return estimator_impulse_costs(SampledPlant<double>(plant), estimator, gains.alpha, gains.beta);
}
#else
    ;
#endif

/// Penetration depth max_t x(t) / (v0 T) of the collision with the estimator (header comment), for a
/// precomputed plant; depth +inf when unstable. Throws InvalidParameter for max_periods < 1.
template <typename Scalar>
PenetrationResultT<Scalar> estimator_penetration(const SampledPlant<Scalar>& plant, const VelocityEstimator& estimator,
                                                 Scalar alpha, Scalar beta, long long max_periods = 100000000) {
    detail::require_in_range("hapticopt::estimator_penetration", "max_periods", static_cast<double>(max_periods), 1.0,
                             false, 1e18, "1 <= max_periods");
    PenetrationResultT<Scalar> result;
    result.depth = std::numeric_limits<Scalar>::infinity();
    if (!(alpha + Scalar(plant.parameters().gamma) > Scalar(0))) return result;
    const ClosedLoop<Scalar> loop = make_estimator_impulse_loop(plant, estimator, alpha, beta);
    const LoopSchurForm<Scalar> schur = loop_schur_form(DynamicMatrix<Scalar>(loop.transition.transpose()));
    if (!(schur.spectral_radius < Scalar(1))) return result;
    const Eigen::Index n = loop.transition.rows();
    const ComplexMatrix<Scalar> x =
        solve_triangular_stein<Scalar>(schur.t, ComplexMatrix<Scalar>::Identity(n, n));  // M'^T P M' + I = P
    DynamicMatrix<Scalar> p = (schur.u * x * schur.u.adjoint()).real();
    p = (p + p.transpose()) / Scalar(2);
    for (Eigen::Index k = 0; k < n; ++k) {  // P >= I for a Schur-stable M'; else rounding at the boundary
        if (!(p(k, k) >= Scalar(1) - Scalar(1e-9)) || !std::isfinite(static_cast<double>(p(k, k)))) return result;
    }
    const detail::ContinuousMaximum<Scalar> scan =
        detail::continuous_maximum(plant, loop, p, Scalar(0), Scalar(0), max_periods);
    result.depth = scan.value;
    result.time = scan.time;
    result.periods = scan.periods;
    result.converged = scan.converged;
    return result;
}

/// Penetration depth with the estimator at (gamma, delta, d) and (alpha, beta); the backward difference is
/// penetration(plant, gains). Depth +inf when EstimatorStabilityTest finds the loop unstable.
HAPTICOPT_FUNC PenetrationResult penetration(const NormalizedPlant& plant, const NormalizedGains& gains,
                                             const VelocityEstimator& estimator)
#if HAPTICOPT_DEFINITIONS
{
    validate(gains, "hapticopt::penetration");
    validate(estimator, "hapticopt::penetration");
    if (estimator.kind == VelocityEstimatorKind::backward) return penetration(plant, gains);
    if (!EstimatorStabilityTest(plant, estimator).stable(gains.alpha, gains.beta)) {
        PenetrationResult r;
        r.depth = HUGE_VAL;
        return r;
    }
    return estimator_penetration(SampledPlant<double>(plant), estimator, gains.alpha, gains.beta);
}
#else
    ;
#endif

/// The optimum of one collision criterion with the estimator: the global minimum of C_Ip over the main stable
/// region (EstimatorStabilityRegion), by minimize_on_region (region_minimum.hpp: coarse grid over
/// (0, alpha_max) x beta_interval(alpha), then Brent over alpha with Brent over beta inside); the penetration at
/// the point (at most ImpulseOptimum::kPenetrationPeriods periods). on_region_edge: alpha < 1e-6 alpha_max (the
/// C_I0 infimum lies on the soft edge, impulse_optimum.hpp). The backward difference is optimal_point(criterion,
/// plant, options) of impulse_optimum.hpp. The default search grid is 96 x 96 (not region_minimum.hpp's 24 x 16):
/// with a heavy low-pass the cost has a valley in beta that narrows towards alpha -> 0, which the coarse grid misses
/// (measured: nu = 0.02, d = 0, C_I2: a local minimum 1767 at alpha = 0.0052 on 24 x 16, the edge infimum 487 on
/// 96 x 96; tests/beyond/test_estimator_beyond.cpp); without `options` the backward difference keeps its own default.
/// An empty main region (alpha_max = 0, e.g. a low-pass so slow that lambda rounds to 1): cost and penetration
/// +inf at (0, 0). Throws InvalidParameter for an invalid estimator or options.
HAPTICOPT_FUNC ImpulseOptimum optimal_point(ImpulseCriterion criterion, const NormalizedPlant& plant,
                                            const VelocityEstimator& estimator,
                                            const std::optional<RegionSearchOptions>& options = std::nullopt)
#if HAPTICOPT_DEFINITIONS
{
    validate(estimator, "hapticopt::optimal_point");
    if (estimator.kind == VelocityEstimatorKind::backward)
        return options ? optimal_point(criterion, plant, *options) : optimal_point(criterion, plant);
    const EstimatorStabilityRegion region(plant, estimator);
    ImpulseOptimum out;
    out.criterion = criterion;
    out.alpha_max = region.alpha_max();
    if (!(out.alpha_max > 0)) {
        out.cost = HUGE_VAL;
        out.penetration = HUGE_VAL;
        return out;
    }
    const SampledPlant<double> sampled(plant);
    const int index = energy_index(criterion);
    auto cost = [&](double a, double b) { return estimator_impulse_costs(sampled, estimator, a, b)[index]; };
    auto interval = [&](double a) { return region.beta_interval(a); };
    const RegionMinimum m =
        minimize_on_region(cost, 0.0, region.alpha_max(), interval, options.value_or(RegionSearchOptions{96, 96}));
    out.alpha = m.alpha;
    out.beta = m.beta;
    out.cost = m.value;
    const PenetrationResult pen =
        estimator_penetration(sampled, estimator, m.alpha, m.beta, ImpulseOptimum::kPenetrationPeriods);
    out.penetration = pen.depth;
    out.penetration_converged = pen.converged;
    out.on_region_edge = m.alpha < 1e-6 * region.alpha_max();
    return out;
}
#else
    ;
#endif

}  // namespace hapticopt
