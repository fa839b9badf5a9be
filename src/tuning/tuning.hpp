// SPDX-License-Identifier: Apache-2.0
// The daemon's adapter to hapticopt: optimal wall gains for a criterion and a device, or the check of
// explicit gains against the stability region. Runs at start-up only.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include <hapticopt/criterion.hpp>

#include "common/velocity_estimator_spec.hpp"

namespace hapticopt {
struct PhysicalPlant;
struct VelocityEstimator;
}  // namespace hapticopt

namespace hapticd {

struct TuningPlant {
    double mass = 0.0;                 // kg (kg m^2)
    double damping = 0.0;              // N s/m
    double stiffness = 0.0;            // N/m
    double period = 1e-3;              // s
    double time_delay = 0.0;           // s, total: device's inherent delay + delay buffer
    VelocityEstimatorSpec velocity{};  // the loop's velocity estimator (the analysis's: the same difference equation)
    // The profile's force_noise_budget (N, N m; none: no budget) and the encoder step q of the wall's axis (m, rad;
    // 0: none): tune_wall minimises the energy criterion subject to sigma_F <= budget (needs q > 0).
    std::optional<double> force_noise_budget{};
    double position_resolution = 0.0;
};

// A box of uncertain plant parameters for --robust, physical units (min == max: the value is exact).
struct TuningBox {
    double mass_min = 0.0, mass_max = 0.0;            // kg (kg m^2)
    double damping_min = 0.0, damping_max = 0.0;      // N s/m
    double stiffness_min = 0.0, stiffness_max = 0.0;  // N/m
    double delay_min = 0.0, delay_max = 0.0;          // s, total loop delay (device + buffer)
    double period = 1e-3;                             // s
    // The loop's velocity estimator (the caller sets it from the profile's velocity_estimator): the robust optimum
    // analyses the loop with it.
    VelocityEstimatorSpec velocity{};
    // The profile's force_noise_budget (N; none: no budget) and the encoder step it is judged with (m, > 0 with a
    // budget): the robust gains meet sigma_F <= budget at every plant of the optimisation grid.
    std::optional<double> force_noise_budget{};
    double position_resolution = 0.0;
};

// What --robust adds to a tuning: the box, the worst case of the gains over it and where it occurs, and
// the worst case of the nominal optimum (the box centre's) for comparison.
struct RobustSummary {
    TuningBox box;
    double worst_case = 0.0;
    double worst_mass = 0.0, worst_damping = 0.0, worst_stiffness = 0.0, worst_delay = 0.0;
    double nominal_worst_case = 0.0;        // +inf: the nominal optimum is unstable somewhere in the box
    bool mass_certified = false;            // stability over the mass range proven (not only sampled)
    std::optional<double> force_noise_max;  // with a budget: the largest sigma_F over the verification grid, N
};

// What the encoder step does at rest in contact (docs/limit-cycles.md), for the profile's plant with the profile's
// Coulomb friction f_c on the wall's axis: each count the measured position crosses steps the backward difference's
// force by B q / T for one period; a sticking rest holds every push only with f_c >= K q / 2 (Abbott & Okamura's
// bound 2 f_c / q on K, exact for the rest: hapticopt::quantised_rest_exists, asked for a push half-way between two
// counts, the worst one), so below it the handle keeps moving between counts; the describing function's cycle for
// that push (the largest: the relay case) with the friction as its equivalent damping. Where a rest exists the
// cycle is at most a possibility that depends on the initial state (docs/limit-cycles.md, "Where it does not").
struct EncoderChatter {
    // The force step of one count on the first tick, B b_0 q / T, b_0 the estimator's weight on the newest sample
    // (backward 1, low-pass 1 - lambda, window 1 / N), N (N m). The rest condition below holds for every estimator
    // (at rest every estimate is 0), and so does the describing function's cycle (with the loop's estimator); the
    // Abbott-Okamura bound is a condition on a spring wall (B = 0) and is given only with the backward difference
    // (backward_difference).
    double count_kick = 0.0;
    bool backward_difference = true;
    double friction_for_rest = 0.0;    // K q / 2, N (N m)
    double coulomb_friction = 0.0;     // the profile's f_c on the wall's axis, N (N m)
    bool rest_for_every_push = false;  // f_c >= K q / 2: a sticking rest holds every push
    // hapticopt::abbott_okamura_passivity(K, b, f_c, q, T): K <= max(2 b / T, 2 f_c / q). Their condition is for a
    // spring wall (B = 0) without delay (d = 0); the wall here has a damper and the device's delay, so it is
    // reported as the paper's bound, not as a proof of passivity.
    bool abbott_okamura_passive = false;
    double abbott_okamura_bound = 0.0;  // max(2 b / T, 2 f_c / q), N/m (N m/rad)
    bool cycle_predicted = false;       // a stable describing-function cycle
    double cycle_amplitude = 0.0;       // m (rad), of the position's fundamental
    double cycle_frequency = 0.0;       // Hz
};

// A wall's certificate over the profile's plant set (docs/robust-stability.md): stable for every moving mass in
// [mass_min, mass_max] (the profile's mass_range widened by its mass_margin), decided exactly (free-mass plant) or at
// GainChecker::kSampledMasses masses; `derating`: the fraction of the criterion's optimum the wall renders (1: the
// optimum itself is stable over the set; less: the largest fraction of it that is, cost then not predicted).
struct PlantSetCertificate {
    double mass_min = 0.0, mass_max = 0.0;  // kg
    // With every mass, the arms k_H / m <= arm_stiffness_per_mass (s^-2), b_H / m <= arm_damping_per_mass (s^-1).
    double arm_stiffness_per_mass = 0.0, arm_damping_per_mass = 0.0;
    double derating = 1.0;
    bool exact = true;  // exact along the mass
    // The arm box certified, else sampled at its grid (docs/robust-stability.md, "The arm").
    bool arm_certified = false;
    // With every mass and arm, every total delay in [delay_min, delay_max] (s; the wall's delay twice without
    // inherent_delay_range); delay_exact: certified (docs/robust-stability.md, "The delay").
    double delay_min = 0.0, delay_max = 0.0;
    bool delay_exact = true;
};

struct TuningResult {
    hapticopt::Criterion criterion = hapticopt::Criterion::CE2;
    bool explicit_gains = false;          // K, B given by the user (then `criterion` only names the reported cost)
    double K = 0.0;                       // N/m
    double B = 0.0;                       // N s/m
    double alpha = 0.0;                   // K T^2 / m
    double beta = 0.0;                    // B T / m
    std::optional<double> cost;           // predicted cost of `criterion` at (alpha, beta)
    double alpha_max = 0.0;               // largest stable alpha of the plant
    std::optional<RobustSummary> robust;  // --robust: alpha, beta, alpha_max of the box centre; cost = worst case
    // The profile's encoder step q (position_resolution, m or rad; 0: not given) and the steady-state standard
    // deviation of the commanded force that its rounding causes through the loop's velocity estimator,
    // sigma_F = (m q / T^2) g_F (hapticopt::force_noise_std), N (N m); empty when q = 0 or unstable.
    double position_resolution = 0.0;
    std::optional<double> force_noise_std;
    std::optional<EncoderChatter> chatter;         // with q > 0, stable gains and the backward difference
    std::optional<PlantSetCertificate> plant_set;  // set by the daemon's certification of its walls
    bool force_noise_budget_active = false;        // the force-noise budget moved the optimum (tune_wall)
    [[nodiscard]] double stability_margin() const { return alpha_max > 0.0 ? alpha / alpha_max : 0.0; }
};

// The plant in hapticopt's terms (the same five numbers).
hapticopt::PhysicalPlant to_hapticopt(const TuningPlant& plant);

// The loop's velocity estimator in hapticopt's terms, the one every stability decision of src/tuning/ uses:
// backward -> the backward difference, lowpass:F Hz -> low_pass(nu = F T), window:N -> moving_window(N).
// Throws StartupError(ErrorKind::InvalidParameter) when hapticopt refuses it (nu not finite and > 0).
hapticopt::VelocityEstimator to_hapticopt_estimator(const VelocityEstimatorSpec& velocity, double period);
// Whether the estimator is the paper's backward difference (the analyses without an estimator then apply).
[[nodiscard]] bool is_backward(const hapticopt::VelocityEstimator& e);

// amax as rendered: alpha = alpha_max (1 - kAlphaMaxBackOff) at the tip's beta (the tip itself is on the
// stability boundary). 1e-3: K 0.1 % below the largest stable stiffness.
inline constexpr double kAlphaMaxBackOff = 1e-3;

// Optimal gains for the criterion (computes only that criterion; amax as above) for the loop with the plant's
// velocity estimator: the backward difference by hapticopt::optimal_wall, any other by hapticopt::optimal_point with
// the estimator (its main stable region's alpha_max; OV by hapticopt::estimator_overshoot_point). Throws StartupError
// (ErrorKind::InvalidParameter) when hapticopt rejects a parameter or the criterion with the estimator,
// (ErrorKind::UnstableGains) when the gains are not strictly inside the stability region of the loop with the
// estimator (hapticopt::is_stable, or the estimator's Schur-Cohn verdict).
// With plant.force_noise_budget: the criterion's optimum subject to sigma_F <= budget
// (hapticopt::optimal_point_under_noise_budget with the estimator and g_max = budget T^2 / (m q), q =
// plant.position_resolution: CE0..2 minimised on the budget's set, the unconstrained optimum when it meets the budget;
// amax the stiffest wall that meets it, rendered as found (inside the region, no back-off); OV and CEx+OV the
// largest alpha without overshoot on the budget's set); StartupError (ErrorKind::InvalidParameter) for q = 0 and
// when no stable gains meet the budget.
TuningResult tune_wall(hapticopt::Criterion criterion, const TuningPlant& plant);

// Sets t.position_resolution, t.force_noise_std and t.chatter for the plant the gains act on. sigma_F: the
// white-noise model of rounding (error uniform over one step, variance q^2 / 12, independent from tick to tick),
// which holds while the handle moves over many steps (docs/velocity-estimation.md). At rest in contact it does not:
// the measured position sits on one or two levels and the force steps between them (t.chatter). q = 0: nothing
// predicted. coulomb_friction: the profile's f_c on the wall's axis (>= 0; t.chatter with it). sigma_F is the loop's
// with the plant's velocity estimator, and so is the describing function's cycle in t.chatter. Cost: one Stein
// equation and one describing-function search (backward difference: up to about 0.1 s at d = 6; the shipped Falcon's
// 15-period window at d = 6 with friction: about 0.4 s; docs/limit-cycles.md, "Cost").
void predict_encoder_effects(TuningResult& t, const TuningPlant& plant, double position_resolution,
                             double coulomb_friction = 0.0);

// Robust gains for CE0, CE1 or CE2: minimise the criterion's worst case over the box for the loop with the box's
// velocity estimator, stable over the whole box and within its force-noise budget
// (hapticopt/robust_optimum.hpp says how stability is guaranteed). Throws StartupError: ErrorKind::Usage for
// another criterion, ErrorKind::InvalidParameter for a bad box or when no gains are stable over the whole box (or
// meet the budget there).
TuningResult tune_wall_robust(hapticopt::Criterion criterion, const TuningBox& box);

// Explicit gains: accepted when inside the stability region of the loop with the plant's velocity estimator (cost
// of `criterion` predicted with it when it is an energy or overshoot criterion); refused with
// StartupError(ErrorKind::UnstableGains) naming K, B, alpha, beta and alpha_max (the estimator's main region's)
// otherwise. `allow_unstable` (--passivity-control: the controller is what keeps such a wall bounded): unstable
// gains are accepted without a predicted cost; it models the backward difference, so with another estimator
// `allow_unstable` is refused with StartupError(ErrorKind::Usage).
TuningResult check_explicit_gains(double K, double B, hapticopt::Criterion criterion, const TuningPlant& plant,
                                  bool allow_unstable = false);

}  // namespace hapticd
