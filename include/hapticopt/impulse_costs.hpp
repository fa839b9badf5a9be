// SPDX-License-Identifier: Apache-2.0
// Collision (impulse-response) criteria of the sampled-data wall, beyond Hulin et al. 2011 (whose
// conclusion leaves the impulse response to future work): the device hits the wall with velocity v0.
//
// Initial conditions (normalised units m = T = 1, positions in units of v0 T; the response is linear
// in v0, so every criterion below is independent of v0):
//  - t = 0 is the first sampling instant at which the wall is engaged; the device is exactly at the
//    wall surface, x(0) = 0, moving into the wall, x'(0) = v0 = 1;
//  - no external force (F = 0): the rest position is x = 0, there is no constant input;
//  - the derivative history the controller sees is that of the constant velocity before contact:
//    x_{-1} = x(-T) = -v0 T = -1, so the first wall force is f_0 = alpha x_0 + beta (x_0 - x_{-1})
//    = beta v0 (the damper sees the impact velocity at once; the spring starts from zero);
//  - the delay buffer holds zero forces: f_j = 0 for j < 0, because the wall was not engaged. With
//    delay d the device therefore flies on freely (up to its own b, k) until f_0 arrives at t = d.
//
// Energy (eq. 4 with x_inf = 0) and criteria, normalised like eqs. 6-8 but by the initial kinetic
// energy E(0) = 1/2 m v0^2:
//   E(t) = 1/2 (alpha + gamma) x(t)^2 + 1/2 x'(t)^2,    C_Ip = (1 / (T^(p+1) E(0))) int_0^inf t^p E dt.
// Penetration depth: P = max_t x(t) / (v0 T) (continuous-time maximum), i.e. x_max = P v0 T.
//
// Closed form. A second state-space realisation of the same loop carries the wall forces in the
// delay buffer instead of past positions (past positions cannot express "zero force before
// contact" when beta = 0): z_j = (x_j, x'_j, x_{j-1}, f_{j-1}, ..., f_{j-H+1}), N = H + 2 as in
// closed_loop.hpp, z_{j+1} = M' z_j, z_0 = (0, 1, -1, 0, ..., 0). M' has the characteristic
// polynomial of M (same loop), so the stability test is unchanged. The infinite sums over periods
// are then exactly those of energy_costs.hpp (three Stein equations on M' 's Schur form, exact
// per-period Gramians), called with this loop: C_Ip = J_p (E(0) = 1/2), where energy_costs_from_schur
// returns (alpha + gamma) J_p. The penetration uses the in-period maximum and the Lyapunov-proven
// stop of overshoot.hpp on the same realisation (stop when kappa sqrt(V_j) <= maximum found).
// Exists exactly when the loop is stable (+infinity otherwise). Cost: as energy_costs / overshoot,
// O(N^3) plus O(N^2) per period examined for the penetration.
// Tests: tests/beyond/test_beyond.cpp compares with independent time-stepping (exact ZOH by Eigen's
// matrix exponential, Simpson quadrature, sampled maximum).
#pragma once

#include <algorithm>
#include <cmath>
#include <limits>

#include "config.hpp"
#include "criterion.hpp"
#include "energy_costs.hpp"
#include "overshoot.hpp"

namespace hapticopt {

template <typename Scalar>
struct ImpulseCostsT {
    Scalar ci0;  ///< (1/E(0)) int E dt
    Scalar ci1;  ///< (1/E(0)) int t E dt
    Scalar ci2;  ///< (1/E(0)) int t^2 E dt
    Scalar operator[](int p) const { return p == 0 ? ci0 : p == 1 ? ci1 : ci2; }
};
using ImpulseCosts = ImpulseCostsT<double>;

/// The collision loop (force-buffer realisation, see the header comment): transition M', initial
/// state z_0, segment maps R'_s with xi = R'_s z_j = (x, x', acting force) at the segment start.
/// final_position = 0 (no constant input). Cost O(N^2).
template <typename Scalar>
ClosedLoop<Scalar> make_impulse_loop(const SampledPlant<Scalar>& plant, Scalar alpha, Scalar beta) {
    const int n = plant.state_dimension();
    const int history = plant.history_length();          // forces f_{j-1} .. f_{j-H+1} are buffered
    auto force_index = [](int age) { return 2 + age; };  // f_{j-age}, age >= 1
    ClosedLoop<Scalar> loop;
    loop.alpha = alpha;
    loop.beta = beta;
    loop.total_stiffness = alpha + Scalar(plant.parameters().gamma);
    loop.final_position = 0;

    auto force_row = [&](int age) {
        DynamicMatrix<Scalar> row = DynamicMatrix<Scalar>::Zero(1, n);
        if (age == 0) {  // f_j = (alpha + beta) x_j - beta x_{j-1}
            row(0, 0) = alpha + beta;
            row(0, 2) = -beta;
        } else {
            row(0, force_index(age)) = 1;
        }
        return row;
    };

    DynamicMatrix<Scalar> plant_rows = DynamicMatrix<Scalar>::Zero(2, n);
    plant_rows(0, 0) = 1;
    plant_rows(1, 1) = 1;
    for (int s = 0; s < plant.segment_count(); ++s) {
        const auto& seg = plant.segment(s);
        DynamicMatrix<Scalar> r(3, n);
        r.topRows(2) = plant_rows;
        r.row(2) = force_row(seg.force_age);
        plant_rows = seg.exp.template topRows<2>() * r;
        loop.segment_map[static_cast<std::size_t>(s)] = r;
    }
    DynamicMatrix<Scalar>& m = loop.transition;
    m = DynamicMatrix<Scalar>::Zero(n, n);
    m.topRows(2) = plant_rows;
    m(2, 0) = 1;                                             // x_{(j+1)-1} = x_j
    if (history >= 2) m.row(force_index(1)) = force_row(0);  // f_{(j+1)-1} = f_j
    for (int age = 2; age <= history - 1; ++age) {           // f_{(j+1)-age} = f_{j-(age-1)}
        m(force_index(age), force_index(age - 1)) = 1;
    }
    loop.initial_state = DynamicVector<Scalar>::Zero(n);
    loop.initial_state(1) = 1;   // x'(0) = v0
    loop.initial_state(2) = -1;  // x_{-1} = -v0 T
    return loop;
}

/// C_I0, C_I1, C_I2 at (alpha, beta) for the precomputed plant; +infinity when unstable.
template <typename Scalar>
ImpulseCostsT<Scalar> impulse_costs(const SampledPlant<Scalar>& plant, Scalar alpha, Scalar beta) {
    const Scalar inf = std::numeric_limits<Scalar>::infinity();
    if (!loop_is_stable(plant, alpha, beta)) return {inf, inf, inf};
    const ClosedLoop<Scalar> loop = make_impulse_loop(plant, alpha, beta);
    const LoopSchurForm<Scalar> schur = loop_schur_form(loop.transition);
    if (!(schur.spectral_radius < Scalar(1))) return {inf, inf, inf};
    const EnergyCostsT<Scalar> e = detail::energy_costs_from_schur(plant, loop, schur);
    const Scalar k = loop.total_stiffness;  // e = k J_p; C_Ip = J_p because E(0) = 1/2
    return {e.ce0 / k, e.ce1 / k, e.ce2 / k};
}

/// Convenience: C_I0..2 at (gamma, delta, d) and (alpha, beta). Throws InvalidParameter for NaN or
/// infinite gains and invalid plant parameters.
HAPTICOPT_FUNC ImpulseCosts impulse_costs(const NormalizedPlant& plant, const NormalizedGains& gains)
#if HAPTICOPT_DEFINITIONS
{
    validate(gains, "hapticopt::impulse_costs");
    return impulse_costs(SampledPlant<double>(plant), gains.alpha, gains.beta);
}
#else
    ;
#endif

template <typename Scalar>
struct PenetrationResultT {
    Scalar depth = 0;        ///< max_t x(t) / (v0 T) > 0; +inf when unstable
    Scalar time = 0;         ///< time of the maximum (in periods)
    bool converged = false;  ///< the Lyapunov-proven stop was reached
    long long periods = 0;   ///< periods examined
};
using PenetrationResult = PenetrationResultT<double>;

/// Penetration depth of the collision response (header comment). `max_periods` is a safety cap
/// (reaching it leaves converged = false). Throws InvalidParameter for max_periods < 1.
template <typename Scalar>
PenetrationResultT<Scalar> penetration(const SampledPlant<Scalar>& plant, Scalar alpha, Scalar beta,
                                       long long max_periods = 100000000) {
    detail::require_in_range("hapticopt::penetration", "max_periods", static_cast<double>(max_periods), 1.0, false,
                             1e18, "1 <= max_periods");
    PenetrationResultT<Scalar> result;
    const Scalar inf = std::numeric_limits<Scalar>::infinity();
    if (!loop_is_stable(plant, alpha, beta)) {
        result.depth = inf;
        return result;
    }
    const ClosedLoop<Scalar> loop = make_impulse_loop(plant, alpha, beta);
    const LoopSchurForm<Scalar> schur = loop_schur_form(loop.transition);
    if (!(schur.spectral_radius < Scalar(1))) {
        result.depth = inf;
        return result;
    }
    // Lyapunov matrix P (M'^T P M' = P - I), as in overshoot.hpp.
    const Eigen::Index n = loop.transition.rows();
    const ComplexMatrix<Scalar> flipped = solve_triangular_stein<Scalar>(
        flip<Scalar>(ComplexMatrix<Scalar>(schur.t.adjoint())), ComplexMatrix<Scalar>::Identity(n, n));
    const DynamicMatrix<Scalar> p = (schur.u * flip<Scalar>(flipped) * schur.u.adjoint()).real();
    const detail::ContinuousMaximum<Scalar> scan =
        detail::continuous_maximum(plant, loop, p, Scalar(0), Scalar(0), max_periods);
    result.periods = scan.periods;
    result.converged = scan.converged;
    const Scalar best = scan.value, best_time = scan.time;
    result.depth = best;
    result.time = best_time;
    return result;
}

/// Convenience: penetration depth at (gamma, delta, d) and (alpha, beta).
HAPTICOPT_FUNC PenetrationResult penetration(const NormalizedPlant& plant, const NormalizedGains& gains)
#if HAPTICOPT_DEFINITIONS
{
    validate(gains, "hapticopt::penetration");
    return penetration(SampledPlant<double>(plant), gains.alpha, gains.beta);
}
#else
    ;
#endif

}  // namespace hapticopt
