// SPDX-License-Identifier: Apache-2.0
#include "tuning/tuning.hpp"

#include <algorithm>
#include <cmath>
#include <sstream>

#include <hapticopt/hapticopt.hpp>

#include "common/startup_error.hpp"

namespace hapticd {

hapticopt::PhysicalPlant to_hapticopt(const TuningPlant& p) {
    hapticopt::PhysicalPlant plant{};
    plant.mass = p.mass;
    plant.damping = p.damping;
    plant.stiffness = p.stiffness;
    plant.period = p.period;
    plant.time_delay = p.time_delay;
    return plant;
}

hapticopt::VelocityEstimator to_hapticopt_estimator(const VelocityEstimatorSpec& velocity, double period) {
    try {
        switch (velocity.kind) {
            case hapticopt::VelocityEstimatorKind::lowpass:
                return hapticopt::VelocityEstimator::low_pass(velocity.cutoff_hz * period);
            case hapticopt::VelocityEstimatorKind::window:
                return hapticopt::VelocityEstimator::moving_window(velocity.window);
            case hapticopt::VelocityEstimatorKind::backward:
                break;
        }
    } catch (const hapticopt::InvalidParameter& e) {
        throw StartupError(ErrorKind::InvalidParameter,
                           "velocity_estimator = " + to_string(velocity) + ": " + std::string(e.what()));
    }
    return hapticopt::VelocityEstimator::backward_difference();
}

bool is_backward(const hapticopt::VelocityEstimator& e) { return e.kind == hapticopt::VelocityEstimatorKind::backward; }

namespace {

std::string g(double v) {
    std::ostringstream s;
    s.precision(6);
    s << v;
    return s.str();
}

// The decisions with the loop's estimator: the backward difference by the library's paper paths (unchanged), any
// other by the estimator's Schur-Cohn verdict and its main stable region.
bool stable_with(const hapticopt::NormalizedPlant& plant, const hapticopt::NormalizedGains& gains,
                 const hapticopt::VelocityEstimator& e) {
    if (is_backward(e)) return hapticopt::is_stable(plant, gains);
    hapticopt::validate(gains, "hapticopt::is_stable");
    return hapticopt::EstimatorStabilityTest(plant, e).stable(gains.alpha, gains.beta);
}

double alpha_max_with(const hapticopt::NormalizedPlant& plant, const hapticopt::VelocityEstimator& e) {
    if (is_backward(e)) return hapticopt::StabilityRegion(plant).alpha_max();
    return hapticopt::EstimatorStabilityRegion(plant, e).alpha_max();
}

}  // namespace

TuningResult tune_wall(hapticopt::Criterion c, const TuningPlant& plant) {
    const hapticopt::VelocityEstimator estimator = to_hapticopt_estimator(plant.velocity, plant.period);
    try {
        const hapticopt::PhysicalPlant physical = to_hapticopt(plant);
        const hapticopt::NormalizedPlant normalized = hapticopt::normalize(physical);
        TuningResult r;
        r.criterion = c;
        // A normalised optimum (alpha, beta) and its cost, scaled back to K = alpha m / T^2, B = beta m / T.
        auto take_normalised = [&](double alpha, double beta, std::optional<double> cost, double alpha_max) {
            r.alpha = alpha;
            r.beta = beta;
            r.cost = cost;
            r.alpha_max = alpha_max;
            r.K = alpha * plant.mass / (plant.period * plant.period);
            r.B = beta * plant.mass / plant.period;
        };
        if (plant.force_noise_budget) {
            // sigma_F = (m q / T^2) g_F: the budget in normalised units is g_max = budget T^2 / (m q).
            const double budget = *plant.force_noise_budget, q = plant.position_resolution;
            if (!(q > 0.0)) {
                throw StartupError(ErrorKind::InvalidParameter,
                                   "tuning: force_noise_budget = " + g(budget) +
                                       " N needs the encoder step of the wall's axis (position_resolution > 0); "
                                       "accepted: a profile with position_resolution > 0 on that axis, or no "
                                       "force_noise_budget");
            }
            const double g_max = budget * plant.period * plant.period / (plant.mass * q);
            hapticopt::NoiseBudgetOptimum t;
            try {
                t = hapticopt::optimal_point_under_noise_budget(c, normalized, estimator, g_max);
            } catch (const hapticopt::InvalidParameter& e) {
                throw StartupError(ErrorKind::InvalidParameter,
                                   "tuning: force_noise_budget = " + g(budget) + " N with position_resolution = " +
                                       g(q) + " (normalised g_max = " + g(g_max) + "): " + e.what() +
                                       "; accepted: a larger force_noise_budget or a finer position_resolution");
            }
            take_normalised(t.alpha, t.beta, t.cost, t.alpha_max);
            r.force_noise_budget_active = t.budget_active;
        } else if (is_backward(estimator)) {
            const hapticopt::WallTuning t = hapticopt::optimal_wall(c, physical);
            r.K = t.K;
            r.B = t.B;
            r.alpha = t.alpha;
            r.beta = t.beta;
            r.cost = t.cost;
            r.alpha_max = t.alpha_max;
        } else {
            // The optimum of the loop with the estimator over its main stable region (hapticopt::estimator_optimum:
            // optimal_point, and the OV point by estimator_overshoot_point).
            const hapticopt::EstimatorOptimum t = hapticopt::estimator_optimum(c, normalized, estimator);
            take_normalised(t.alpha, t.beta, t.cost, t.alpha_max);
        }
        if (c == hapticopt::Criterion::AlphaMax && !plant.force_noise_budget) {
            // amax is the region's tip (alpha_max, the beta there), on its boundary: marginally stable. What is
            // rendered is the tip moved inwards along alpha, alpha_max (1 - kAlphaMaxBackOff) at the tip's beta:
            // the stable beta interval at that alpha has a half-width of order sqrt(kAlphaMaxBackOff) around a
            // centre within O(kAlphaMaxBackOff) of the tip's beta, so the point is strictly inside (checked below).
            r.alpha = r.alpha_max * (1.0 - kAlphaMaxBackOff);
            r.K = r.alpha * plant.mass / (plant.period * plant.period);
            r.cost = r.alpha;
        }
        // amax under a force-noise budget is the stiffest wall meeting it: inside the region (g_F finite there),
        // no back-off from the boundary (hapticopt::optimal_point_under_noise_budget).
        // Every tuned wall is checked as explicit gains are: an optimum on or outside the boundary is refused.
        const hapticopt::NormalizedGains gains{r.alpha, r.beta};
        if (!stable_with(normalized, gains, estimator)) {
            throw StartupError(
                ErrorKind::UnstableGains,
                "tuning: the " + std::string(hapticopt::to_string(c)) + " optimum K = " + g(r.K) +
                    " N/m, B = " + g(r.B) + " N s/m (alpha = " + g(r.alpha) + ", beta = " + g(r.beta) +
                    ") is not strictly inside the stability region (velocity_estimator = " + to_string(plant.velocity) +
                    "); accepted: a criterion whose optimum is, or explicit --stiffness/--damping");
        }
        return r;
    } catch (const hapticopt::InvalidParameter& e) {
        throw StartupError(ErrorKind::InvalidParameter, std::string("tuning: ") + e.what());
    }
}

void predict_encoder_effects(TuningResult& t, const TuningPlant& plant, double position_resolution,
                             double coulomb_friction) {
    t.position_resolution = position_resolution;
    t.force_noise_std.reset();
    t.chatter.reset();
    if (!(position_resolution > 0.0)) return;
    const hapticopt::VelocityEstimator estimator = to_hapticopt_estimator(plant.velocity, plant.period);
    try {
        const hapticopt::PhysicalPlant physical = to_hapticopt(plant);
        const hapticopt::WallGains gains{t.K, t.B};
        const double q = position_resolution;
        const double sigma = hapticopt::force_noise_std(physical, gains, q, estimator);
        if (!std::isfinite(sigma)) return;  // unstable gains (--passivity-control): no steady state
        t.force_noise_std = sigma;
        // The rest condition is the same for every estimator (at rest the estimate is 0), and the describing function
        // (hapticopt::predict_limit_cycle) takes the loop's estimator; the Abbott-Okamura bound is a condition on the
        // spring wall (B = 0), given with the backward difference only.
        EncoderChatter c;
        c.backward_difference = is_backward(estimator);
        c.count_kick =
            std::abs(t.B) * hapticopt::estimator_coefficients<double>(estimator).b.front() * q / plant.period;
        c.friction_for_rest = t.K * q / 2.0;
        c.coulomb_friction = coulomb_friction;
        if (c.backward_difference) {
            const hapticopt::AbbottOkamuraPassivity ao = hapticopt::abbott_okamura_passivity(
                std::max(t.K, 0.0), plant.damping, coulomb_friction, q, plant.period);
            c.abbott_okamura_passive = t.K >= 0.0 && ao.passive;
            c.abbott_okamura_bound = ao.stiffness_bound;
        }
        if (t.K > 0.0) {
            // A push 20.5 counts deep: half-way between two levels whatever the plant's spring does to the mean,
            // the push farthest from every rest (quantised_rest_exists holds there iff it holds for every push).
            const double push = (t.K + plant.stiffness) * q * 20.5;
            c.rest_for_every_push = hapticopt::quantised_rest_exists(push, t.K, coulomb_friction, q, plant.stiffness);
            hapticopt::LimitCycleLoop loop{physical, gains, coulomb_friction, q, push};
            loop.estimator = estimator;
            const hapticopt::LimitCyclePrediction p = hapticopt::predict_limit_cycle(loop);
            if (p.predicted && p.cycle.stable) {
                c.cycle_predicted = true;
                c.cycle_amplitude = p.cycle.amplitude;
                c.cycle_frequency = p.cycle.frequency;
            }
        }
        t.chatter = c;
    } catch (const hapticopt::InvalidParameter& e) {
        throw StartupError(ErrorKind::InvalidParameter, std::string("tuning: ") + e.what());
    }
}

TuningResult tune_wall_robust(hapticopt::Criterion c, const TuningBox& box) {
    if (!hapticopt::energy_index(c) || hapticopt::requires_no_overshoot(c)) {
        throw StartupError(ErrorKind::Usage, "criterion = " + std::string(hapticopt::to_string(c)) +
                                                 " is invalid with --robust; accepted: CE0, CE1, CE2 "
                                                 "(a robust OV or CEx+OV optimum is not defined)");
    }
    hapticopt::UncertainPlant u;
    u.mass = {box.mass_min, box.mass_max};
    u.damping = {box.damping_min, box.damping_max};
    u.stiffness = {box.stiffness_min, box.stiffness_max};
    u.time_delay = {box.delay_min, box.delay_max};
    u.period = box.period;
    hapticopt::RobustOptions options;
    options.estimator = to_hapticopt_estimator(box.velocity, box.period);
    if (box.force_noise_budget) {
        options.force_noise_budget = *box.force_noise_budget;
        options.position_resolution = box.position_resolution;
    }
    try {
        const hapticopt::RobustOptimum r = hapticopt::robust_optimum(c, u, options);
        if (!r.stability.stable || !std::isfinite(r.worst.cost)) {
            throw StartupError(ErrorKind::InvalidParameter,
                               "robust tuning: no wall gains are stable over the whole parameter box (mass " +
                                   g(box.mass_min) + " .. " + g(box.mass_max) + ", delay " + g(box.delay_min) + " .. " +
                                   g(box.delay_max) +
                                   " s); accepted: a box that some (K, B) stabilises, e.g. "
                                   "narrower ranges or a shorter delay");
        }
        const hapticopt::NormalizedPlant nominal = hapticopt::normalize(r.nominal);
        const hapticopt::NormalizedGains gains = hapticopt::normalize(r.gains, r.nominal.mass, r.nominal.period);
        TuningResult t;
        t.criterion = c;
        t.K = r.gains.stiffness;
        t.B = r.gains.damping;
        t.alpha = gains.alpha;
        t.beta = gains.beta;
        t.cost = r.worst.cost;
        t.alpha_max = alpha_max_with(nominal, options.estimator);
        RobustSummary s;
        s.box = box;
        s.worst_case = r.worst.cost;
        s.worst_mass = r.worst.where.mass;
        s.worst_damping = r.worst.where.damping;
        s.worst_stiffness = r.worst.where.stiffness;
        s.worst_delay = r.worst.where.time_delay;
        s.nominal_worst_case = r.nominal_worst.cost;
        s.mass_certified = r.stability.mass_segments_certified;
        if (box.force_noise_budget) {
            s.force_noise_max = r.force_noise_max;
            // The budget is met on the optimisation grid; what is reported holds on the finer verification grid too.
            if (!(r.force_noise_max <= *box.force_noise_budget)) {
                throw StartupError(
                    ErrorKind::InvalidParameter,
                    "robust tuning: the robust " + std::string(hapticopt::to_string(c)) + " gains K = " + g(t.K) +
                        " N/m, B = " + g(t.B) + " N s/m exceed force_noise_budget = " + g(*box.force_noise_budget) +
                        " N between the optimisation grid's masses (sigma_F up to " + g(r.force_noise_max) +
                        " N); accepted: a larger force_noise_budget or a narrower mass range");
            }
        }
        t.robust = s;
        return t;
    } catch (const hapticopt::InvalidParameter& e) {
        throw StartupError(ErrorKind::InvalidParameter, std::string("robust tuning: ") + e.what());
    }
}

TuningResult check_explicit_gains(double K, double B, hapticopt::Criterion c, const TuningPlant& plant,
                                  bool allow_unstable) {
    TuningResult r;
    r.criterion = c;
    r.explicit_gains = true;
    r.K = K;
    r.B = B;
    const hapticopt::VelocityEstimator estimator = to_hapticopt_estimator(plant.velocity, plant.period);
    if (allow_unstable && !is_backward(estimator)) {
        throw StartupError(ErrorKind::Usage,
                           "--passivity-control with velocity_estimator = " + to_string(plant.velocity) +
                               " is invalid: the passivity controller and its acceptance of "
                               "unstable gains model the backward difference; accepted: "
                               "velocity_estimator = backward with --passivity-control");
    }
    try {
        const hapticopt::PhysicalPlant physical = to_hapticopt(plant);
        const hapticopt::NormalizedPlant normalized = hapticopt::normalize(physical);
        const hapticopt::NormalizedGains gains =
            hapticopt::normalize(hapticopt::WallGains{K, B}, plant.mass, plant.period);
        r.alpha = gains.alpha;
        r.beta = gains.beta;
        r.alpha_max = alpha_max_with(normalized, estimator);
        if (!stable_with(normalized, gains, estimator)) {
            if (allow_unstable) return r;  // no predicted cost: the loop without the controller diverges
            throw StartupError(ErrorKind::UnstableGains,
                               "explicit gains stiffness K = " + g(K) + " N/m, damping B = " + g(B) +
                                   " N s/m (alpha = " + g(gains.alpha) + ", beta = " + g(gains.beta) +
                                   ") are outside the stability region for mass = " + g(plant.mass) +
                                   ", period = " + g(plant.period) + " s, delay = " + g(plant.time_delay) +
                                   " s, velocity_estimator = " + to_string(plant.velocity) +
                                   "; accepted: a stable (K, B), which needs alpha < alpha_max = " + g(r.alpha_max) +
                                   " (K < " + g(r.alpha_max * plant.mass / (plant.period * plant.period)) +
                                   " N/m) and a matching B; omit --stiffness/--damping to use the optimal gains");
        }
        switch (c) {
            case hapticopt::Criterion::CE0:
            case hapticopt::Criterion::CE0_OV:
                r.cost = hapticopt::energy_costs(normalized, gains, estimator).ce0;
                break;
            case hapticopt::Criterion::CE1:
            case hapticopt::Criterion::CE1_OV:
                r.cost = hapticopt::energy_costs(normalized, gains, estimator).ce1;
                break;
            case hapticopt::Criterion::CE2:
            case hapticopt::Criterion::CE2_OV:
                r.cost = hapticopt::energy_costs(normalized, gains, estimator).ce2;
                break;
            case hapticopt::Criterion::Overshoot:
                r.cost = hapticopt::overshoot(normalized, gains, estimator).value;
                break;
            default:
                break;
        }
    } catch (const hapticopt::InvalidParameter& e) {
        throw StartupError(ErrorKind::InvalidParameter, std::string("explicit gains: ") + e.what());
    }
    return r;
}

}  // namespace hapticd
