// SPDX-License-Identifier: Apache-2.0
// hapticopt cost: stability and the criteria C_E0, C_E1, C_E2, C_OV at one gain pair; with --velocity the
// estimator's loop (estimator_stability.hpp, estimator_costs.hpp: stability, C_E0..2 and C_OV; estimator_impulse.hpp:
// C_I0..2 and the penetration; estimator_passivity.hpp: the passivity margin). Always the quantisation force-noise gain
// g_F (sigma_F = (m q / T^2) g_F), and sigma_F in N with --mass, --period and --position-resolution.
#include <cmath>
#include <cstdio>
#include <iostream>
#include <memory>

#include <hapticopt/energy_costs.hpp>
#include <hapticopt/estimator_costs.hpp>
#include <hapticopt/estimator_impulse.hpp>
#include <hapticopt/estimator_noise.hpp>
#include <hapticopt/estimator_passivity.hpp>
#include <hapticopt/estimator_stability.hpp>
#include <hapticopt/impulse_costs.hpp>
#include <hapticopt/overshoot.hpp>
#include <hapticopt/passivity.hpp>
#include <hapticopt/stability.hpp>
#include <hapticopt/estimator_types.hpp>

#include "cli_output.hpp"
#include "commands.hpp"

namespace hapticopt::cli {

namespace {

// The fields every `cost --json` answer starts with: stability, the energy costs and the overshoot.
nlohmann::json step_response_json(const StabilityReport& report, const EnergyCosts& costs, const OvershootResult& ov) {
    nlohmann::json out;
    out["stable"] = report.stable;
    out["CE0"] = number_or_null(costs.ce0);
    out["CE1"] = number_or_null(costs.ce1);
    out["CE2"] = number_or_null(costs.ce2);
    out["OV"] = number_or_null(ov.value);
    out["no_overshoot"] = report.stable ? nlohmann::json(ov.within_tolerance) : nlohmann::json(nullptr);
    out["spectral_radius"] = report.spectral_radius;
    return out;
}

}  // namespace

CommandRunner add_cost_command(CLI::App& app) {
    struct Args {
        double alpha = 0, beta = 0, tolerance = 1e-12;
        PlantOptions plant;
        VelocityOption velocity;
        double mass = 0, period = 0, resolution = 0;
        bool json = false;
    };
    auto args = std::make_shared<Args>();
    CLI::App* sub = app.add_subcommand("cost", "stability and step-response criteria at (alpha, beta)");
    sub->add_option("--alpha", args->alpha, "normalised wall stiffness K T^2/m")->required();
    sub->add_option("--beta", args->beta, "normalised wall damping B T/m")->required();
    args->plant.add_to(*sub);
    args->velocity.add_to(*sub);
    CLI::Option* mass = sub->add_option("--mass", args->mass, "moving mass m [kg], for sigma_F in N");
    CLI::Option* period =
        sub->add_option("--period", args->period, "sampling period T [s], for sigma_F and lowpass:FHz");
    CLI::Option* resolution =
        sub->add_option("--position-resolution", args->resolution, "encoder step q [m], for sigma_F = (m q / T^2) g_F");
    resolution->needs(mass);
    resolution->needs(period);
    mass->needs(resolution);
    sub->add_option("--overshoot-tol", args->tolerance, "relative overshoot counted as none, (0, 1]")
        ->capture_default_str();
    sub->add_flag("--json", args->json, "print one JSON object");
    return [args, resolution]() {
        const NormalizedPlant plant = args->plant.normalized();
        const NormalizedGains gains{args->alpha, args->beta};
        const VelocityEstimator estimator = args->velocity.parse(args->period);
        const double noise_gain = force_noise_gain(plant, gains, estimator);
        const bool physical_noise = resolution->count() > 0;
        if (physical_noise) {
            detail::require_positive("hapticopt cost", "mass", args->mass);
            detail::require_positive("hapticopt cost", "period", args->period);
            detail::require_positive("hapticopt cost", "position_resolution", args->resolution);
        }
        const double noise_std = args->mass * args->resolution / (args->period * args->period) * noise_gain;
        // The estimator's functions send the backward difference to the paper's loop (estimator_costs.hpp,
        // estimator_impulse.hpp, estimator_passivity.hpp).
        const bool backward = estimator.kind == VelocityEstimatorKind::backward;
        const StabilityReport report = stability(plant, gains, estimator);
        const EnergyCosts costs = energy_costs(plant, gains, estimator);
        OvershootOptions options;
        options.tolerance = args->tolerance;
        const OvershootResult ov = overshoot(plant, gains, estimator, options);
        const ImpulseCosts ic = impulse_costs(plant, gains, estimator);
        const SampledPlant<double> sampled(plant);
        const double depth = !report.stable ? HUGE_VAL
                             : backward
                                 ? penetration(sampled, gains.alpha, gains.beta, 1000000LL).depth
                                 : estimator_penetration(sampled, estimator, gains.alpha, gains.beta, 1000000LL).depth;
        const bool covered = passivity_is_covered(plant);
        const double margin = covered ? passivity_margin(plant, gains, estimator) : 0.0;
        if (args->json) {
            nlohmann::json out = step_response_json(report, costs, ov);
            out["CI0"] = number_or_null(ic.ci0);
            out["CI1"] = number_or_null(ic.ci1);
            out["CI2"] = number_or_null(ic.ci2);
            out["penetration"] = number_or_null(depth);
            if (covered) {
                out["passive"] = margin > 0;
                out["passivity_margin"] = margin;
            } else {
                out["passive"] = nullptr;
                out["passivity_margin"] = nullptr;
                out["passivity_note"] = kPassivityNotCovered;
            }
            out["velocity_estimator"] = velocity_json(estimator);
            out["force_noise_gain"] = number_or_null(noise_gain);
            if (physical_noise) out["force_noise_std"] = number_or_null(noise_std);
            std::cout << out.dump() << '\n';
            return int{kOk};
        }
        std::printf("alpha %.10g  beta %.10g  gamma %.10g  delta %.10g  d %.10g\n", gains.alpha, gains.beta,
                    plant.gamma, plant.delta, plant.delay);
        std::printf("velocity         %s\n", velocity_text(estimator).c_str());
        std::printf("stable           %s (spectral radius %.12f)\n", report.stable ? "yes" : "no",
                    report.spectral_radius);
        if (!report.stable) return int{kOk};
        std::printf("C_E0             %.12g\nC_E1             %.12g\nC_E2             %.12g\n", costs.ce0, costs.ce1,
                    costs.ce2);
        std::printf("C_OV             %.6g%s\n", ov.value,
                    ov.within_tolerance ? "  (no overshoot within tolerance)" : "");
        std::printf("C_I0             %.12g\nC_I1             %.12g\nC_I2             %.12g\n", ic.ci0, ic.ci1, ic.ci2);
        std::printf("penetration      %.12g v0 T\n", depth);
        if (covered) {
            std::printf("passive          %s (margin delta - max_theta R(theta) = %.6g)\n", margin > 0 ? "yes" : "no",
                        margin);
        } else {
            std::printf("passive          not covered (%s)\n", kPassivityNotCovered);
        }
        std::printf("noise gain g_F   %.12g (sigma_F = m q / T^2 g_F)\n", noise_gain);
        if (physical_noise) std::printf("sigma_F          %.6g N\n", noise_std);
        return int{kOk};
    };
}

}  // namespace hapticopt::cli
