// SPDX-License-Identifier: Apache-2.0
// hapticopt optimum: the optimal point of one criterion, normalised or physical; the collision
// criteria CI0..2; the robust optimum over a box of physical parameters (--robust, ranges MIN:MAX);
// every answer reports the delay-aware Colgate-Schenkel passivity margin (passivity.hpp, with --velocity
// estimator_passivity.hpp; null for a fractional delay, which it does not cover). --noise-budget G (normalised g_max)
// or --force-noise-budget N [N] with --position-resolution q: the criterion's optimum with g_F <= g_max
// (noise_budget.hpp; g_max = N T^2/(m q)); with --robust, the budget met over the box (robust_optimum.hpp).
#include <cstdio>
#include <iostream>
#include <memory>

#include <hapticopt/criterion.hpp>
#include <hapticopt/estimator_impulse.hpp>
#include <hapticopt/estimator_passivity.hpp>
#include <hapticopt/impulse_optimum.hpp>
#include <hapticopt/noise_budget.hpp>
#include <hapticopt/optimal_wall.hpp>
#include <hapticopt/passivity.hpp>
#include <hapticopt/robust_optimum.hpp>

#include "cli_output.hpp"
#include "commands.hpp"
#include "criterion_option.hpp"

namespace hapticopt::cli {

namespace {

bool parse_range(const std::string& text, ParameterRange& out) {
    auto number = [](const std::string& s, double& v) {
        if (s.empty()) return false;
        std::size_t used = 0;
        try {
            v = std::stod(s, &used);
        } catch (const std::exception&) {
            return false;
        }
        return used == s.size();
    };
    const std::size_t colon = text.find(':');
    if (colon == std::string::npos) {
        double v = 0;
        if (!number(text, v)) return false;
        out = {v, v};
        return true;
    }
    return number(text.substr(0, colon), out.min) && number(text.substr(colon + 1), out.max);
}

/// Prints the passivity fields (normalised margin; physical margin when a plant is known).
void add_passivity(nlohmann::json& out, double margin) {
    out["passive"] = margin > 0;
    out["passivity_margin"] = margin;
}

/// The passivity fields when the delay is fractional (passivity.hpp does not cover it).
void add_passivity_not_covered(nlohmann::json& out) {
    out["passive"] = nullptr;
    out["passivity_margin"] = nullptr;
    out["passivity_note"] = kPassivityNotCovered;
}

/// The text lines of a verdict on passivity (the margin, or why it is not covered) and of the physical gains, when
/// a plant is known (`gains` not null).
void print_passivity_and_gains(bool covered, double margin, const WallGains* gains) {
    if (covered) {
        std::printf("passive    %s (margin delta - max_theta R(theta) = %.6g)\n", margin > 0 ? "yes" : "no", margin);
    } else {
        std::printf("passive    not covered (%s)\n", kPassivityNotCovered);
    }
    if (gains) std::printf("K          %.6g N/m\nB          %.6g N s/m\n", gains->stiffness, gains->damping);
}

int run_robust(const StepOrCollisionCriterion& criterion, const UncertainPlant& box, const RobustOptions& options,
               bool json) {
    const std::string name = criterion_name(criterion);
    RobustOptimum r = std::visit([&](auto c) { return robust_optimum(c, box, options); }, criterion);
    // Passivity over the box: the physical margin b - max_theta R(theta; K T, B) (passivity.hpp) does not
    // depend on m and is smallest at b = b_min; the normalised margin (T/m) * that is smallest at m_min when
    // negative (m_max when positive). Covered for one integer delay (t_d fixed), else reported as null.
    const double d_min = box.time_delay.min / box.period, d_max = box.time_delay.max / box.period;
    const bool covered = d_min == d_max && passivity_is_covered(NormalizedPlant{0, 0, d_min});
    double phys = 0, margin = 0;
    if (covered) {
        phys =
            passivity_margin(PhysicalPlant{box.mass.min, box.damping.min, 0, box.period, box.time_delay.min}, r.gains);
        margin = phys * box.period / (phys < 0 ? box.mass.min : box.mass.max);
    }
    auto where = [](const BoxWorstCase& w) {
        nlohmann::json o;
        o["cost"] = number_or_null(w.cost);
        o["mass"] = w.where.mass;
        o["damping"] = w.where.damping;
        o["stiffness"] = w.where.stiffness;
        o["time_delay"] = w.where.time_delay;
        return o;
    };
    if (json) {
        nlohmann::json out;
        out["criterion"] = name;
        out["robust"] = true;
        out["K"] = r.gains.stiffness;
        out["B"] = r.gains.damping;
        out["worst_case"] = number_or_null(r.worst.cost);
        out["worst_case_at"] = where(r.worst);
        out["stable_over_box"] = r.stability.stable;
        out["mass_segments_certified"] = r.stability.mass_segments_certified;
        out["K_max"] = r.K_max;
        out["velocity_estimator"] = velocity_json(options.estimator);
        if (options.force_noise_budget > 0) {
            out["force_noise_budget"] = options.force_noise_budget;
            out["force_noise_max"] = r.force_noise_max;
        }
        if (covered) {
            add_passivity(out, margin);
            out["passivity_margin_physical"] = phys;
        } else {
            add_passivity_not_covered(out);
        }
        nlohmann::json nominal;
        nominal["mass"] = r.nominal.mass;
        nominal["damping"] = r.nominal.damping;
        nominal["stiffness"] = r.nominal.stiffness;
        nominal["time_delay"] = r.nominal.time_delay;
        nominal["K"] = r.nominal_gains.stiffness;
        nominal["B"] = r.nominal_gains.damping;
        nominal["worst_case"] = number_or_null(r.nominal_worst.cost);
        nominal["worst_case_at"] = where(r.nominal_worst);
        nominal["stable_over_box"] = r.nominal_stability.stable;
        out["nominal"] = nominal;
        std::cout << out.dump() << '\n';
        return int{kOk};
    }
    std::printf("criterion  %s (robust over the box)\nK          %.6g N/m\nB          %.6g N s/m\n", name.c_str(),
                r.gains.stiffness, r.gains.damping);
    std::printf("worst case %.10g at m = %.6g kg, b = %.6g, k = %.6g, t_d = %.6g s\n", r.worst.cost, r.worst.where.mass,
                r.worst.where.damping, r.worst.where.stiffness, r.worst.where.time_delay);
    std::printf("stable over the box: %s (mass segments certified: %s)\n", r.stability.stable ? "yes" : "no",
                r.stability.mass_segments_certified ? "yes" : "no");
    std::printf("nominal optimum (box centre) K %.6g, B %.6g: worst case %.10g at m = %.6g kg\n",
                r.nominal_gains.stiffness, r.nominal_gains.damping, r.nominal_worst.cost, r.nominal_worst.where.mass);
    std::printf("velocity   %s\n", velocity_text(options.estimator).c_str());
    if (options.force_noise_budget > 0) {
        std::printf("sigma_F    at most %.6g N over the box (budget %.6g N)\n", r.force_noise_max,
                    options.force_noise_budget);
    }
    if (covered) {
        std::printf("passive    %s (margin %.4g)\n", margin > 0 ? "yes" : "no", margin);
    } else {
        std::printf("passive    not covered (%s)\n", kPassivityNotCovered);
    }
    return int{kOk};
}

}  // namespace

CommandRunner add_optimum_command(CLI::App& app) {
    struct Args {
        StepOrCollisionCriterion criterion;  // parsed by its option (criterion_option.hpp)
        PlantOptions plant;
        std::string mass, damping = "0", stiffness = "0", time_delay = "0";
        double period = 0;
        double tolerance = 1e-12;
        bool json = false;
        bool robust = false;
        bool passive = false;
        VelocityOption velocity;
        double noise_budget = 0, force_noise_budget = 0, resolution = 0;
    };
    auto args = std::make_shared<Args>();
    CLI::App* sub = app.add_subcommand("optimum", "optimal (alpha, beta) of a criterion, and (K, B) with --mass");
    add_criterion_option(*sub, "--criterion", args->criterion,
                         joined_names(criterion_names(kAllCriteria)) +
                             "; collision: " + joined_names(criterion_names(kAllImpulseCriteria)))
        ->required();
    args->plant.add_to(*sub);
    CLI::Option* mass = sub->add_option("--mass", args->mass,
                                        "moving mass m [kg] (device + arm); physical mode; MIN:MAX with --robust");
    CLI::Option* period = sub->add_option("--period", args->period, "sampling period T [s]");
    CLI::Option* time_delay = sub->add_option("--time-delay", args->time_delay, "loop delay t_d [s] (or MIN:MAX)");
    CLI::Option* damping = sub->add_option("--damping", args->damping, "physical damping b [N s/m] (or MIN:MAX)");
    CLI::Option* stiffness = sub->add_option("--stiffness", args->stiffness, "physical stiffness k [N/m] (or MIN:MAX)");
    mass->needs(period);
    period->needs(mass);
    for (CLI::Option* o : {time_delay, damping, stiffness}) o->needs(mass);
    for (const char* name : {"--gamma", "--delta", "--delay"}) mass->excludes(sub->get_option(name));
    sub->add_option("--overshoot-tol", args->tolerance, "relative overshoot counted as none, (0, 1]")
        ->capture_default_str();
    CLI::Option* robust = sub->add_flag("--robust", args->robust,
                                        "minimise the worst case over the box of --mass/--damping/--stiffness/"
                                        "--time-delay ranges (MIN:MAX) for the loop with the --velocity estimator; "
                                        "CE0..2 (with --force-noise-budget: met over the box), CI0..2 (backward)");
    robust->needs(mass);
    CLI::Option* passive =
        sub->add_flag("--passive", args->passive,
                      "best gains within the Colgate-Schenkel passive set with the delay and the --velocity estimator "
                      "(delta > max_theta R(theta), "
                      "integer delays of 0..1000 periods only); CE0..2, CI0..2 only");
    passive->excludes(robust);
    args->velocity.add_to(*sub);
    CLI::Option* noise_budget = sub->add_option(
        "--noise-budget", args->noise_budget,
        "the criterion under a force-noise budget: g_F <= G (normalised, sigma_F = (m q / T^2) g_F; noise_budget.hpp)");
    CLI::Option* force_budget = sub->add_option("--force-noise-budget", args->force_noise_budget,
                                                "the budget as sigma_F [N] (needs --mass, --period, "
                                                "--position-resolution): g_max = N T^2 / (m q)");
    CLI::Option* resolution =
        sub->add_option("--position-resolution", args->resolution, "encoder step q [m] of --force-noise-budget");
    force_budget->needs(mass);
    force_budget->needs(resolution);
    resolution->needs(force_budget);
    force_budget->excludes(noise_budget);
    noise_budget->excludes(robust);
    for (CLI::Option* o : {noise_budget, force_budget}) {
        o->excludes(passive);
    }
    sub->add_flag("--json", args->json, "print one JSON object");
    return [args, mass, noise_budget, force_budget]() {
        const bool physical = mass->count() > 0;
        UncertainPlant box;
        if (physical) {
            const std::pair<const char*, std::pair<const std::string*, ParameterRange*>> ranges[] = {
                {"--mass", {&args->mass, &box.mass}},
                {"--damping", {&args->damping, &box.damping}},
                {"--stiffness", {&args->stiffness, &box.stiffness}},
                {"--time-delay", {&args->time_delay, &box.time_delay}}};
            for (const auto& [flag, target] : ranges) {
                if (!parse_range(*target.first, *target.second)) {
                    std::cerr << "hapticopt optimum: " << flag << " = " << *target.first
                              << " is not a number or a range MIN:MAX\n";
                    return int{kUsage};
                }
                if (!args->robust && target.second->min != target.second->max) {
                    std::cerr << "hapticopt optimum: " << flag << " = " << *target.first
                              << " is a range; ranges need --robust\n";
                    return int{kUsage};
                }
            }
            box.period = args->period;
        }
        const std::string name = criterion_name(args->criterion);
        const Criterion* const step = std::get_if<Criterion>(&args->criterion);
        const ImpulseCriterion* const impulse = std::get_if<ImpulseCriterion>(&args->criterion);
        const VelocityEstimator estimator = args->velocity.parse(physical ? box.period : 0.0);
        if ((noise_budget->count() > 0 || force_budget->count() > 0) && !args->robust) {
            if (!step) {
                std::cerr << "hapticopt optimum: --noise-budget and --force-noise-budget support the step criteria "
                          << joined_names(criterion_names(kAllCriteria)) << " (not " << name << ")\n";
                return int{kUsage};
            }
            const PhysicalPlant plant{box.mass.min, box.damping.min, box.stiffness.min, box.period, box.time_delay.min};
            const NormalizedPlant np = physical ? normalize(plant) : args->plant.normalized();
            double g_max = args->noise_budget;
            if (force_budget->count() > 0) {
                detail::require_positive("hapticopt optimum", "position_resolution", args->resolution);
                detail::require_in_range("hapticopt optimum", "force_noise_budget", args->force_noise_budget, 0.0, true,
                                         HUGE_VAL, "finite and > 0 [N]");
                g_max = args->force_noise_budget * plant.period * plant.period / (plant.mass * args->resolution);
            }
            NoiseBudgetOptions nbo;
            nbo.unconstrained.overshoot_tolerance = args->tolerance;
            const NoiseBudgetOptimum o = optimal_point_under_noise_budget(*step, np, estimator, g_max, nbo);
            WallGains g{0, 0};
            if (physical) g = to_physical(NormalizedGains{o.alpha, o.beta}, plant.mass, plant.period);
            const double to_newton =
                force_budget->count() > 0 ? plant.mass * args->resolution / (plant.period * plant.period) : 0;
            if (args->json) {
                nlohmann::json out;
                out["criterion"] = name;
                out["alpha"] = o.alpha;
                out["beta"] = o.beta;
                out["cost"] = number_or_null(o.cost);
                out["alpha_max"] = o.alpha_max;
                out["velocity_estimator"] = velocity_json(estimator);
                out["noise_budget"] = o.noise_budget;
                out["force_noise_gain"] = number_or_null(o.force_noise_gain);
                out["budget_active"] = o.budget_active;
                out["unconstrained_cost"] = number_or_null(o.unconstrained_cost);
                out["unconstrained_force_noise_gain"] = number_or_null(o.unconstrained_force_noise_gain);
                if (force_budget->count() > 0) {
                    out["force_noise_budget"] = args->force_noise_budget;
                    out["force_noise_std"] = to_newton * o.force_noise_gain;
                    out["position_resolution"] = args->resolution;
                }
                if (physical) {
                    out["K"] = g.stiffness;
                    out["B"] = g.damping;
                }
                std::cout << out.dump() << '\n';
                return int{kOk};
            }
            std::printf(
                "criterion  %s\nvelocity   %s\nbudget     g_F <= %.6g%s\nalpha      %.10f\nbeta       %.10f\n"
                "cost       %.10g\nnoise gain g_F   %.6g\nalpha_max  %.10f\n",
                name.c_str(), velocity_text(estimator).c_str(), o.noise_budget,
                o.budget_active ? " (active)" : " (met by the unconstrained optimum)", o.alpha, o.beta, o.cost,
                o.force_noise_gain, o.alpha_max);
            std::printf("unconstrained    cost %.10g, g_F %.6g\n", o.unconstrained_cost,
                        o.unconstrained_force_noise_gain);
            if (force_budget->count() > 0)
                std::printf("sigma_F    %.6g N (budget %.6g N)\n", to_newton * o.force_noise_gain,
                            args->force_noise_budget);
            if (physical) std::printf("K          %.6g N/m\nB          %.6g N s/m\n", g.stiffness, g.damping);
            return int{kOk};
        }
        if (args->robust) {
            if (!impulse && !(step && energy_index(*step) && !requires_no_overshoot(*step))) {
                std::cerr << "hapticopt optimum: --robust supports CE0, CE1, CE2, CI0, CI1, CI2 (not " << name << ")\n";
                return int{kUsage};
            }
            RobustOptions ro;
            ro.estimator = estimator;
            if (force_budget->count() > 0) {
                ro.force_noise_budget = args->force_noise_budget;
                ro.position_resolution = args->resolution;
            }
            return run_robust(args->criterion, box, ro, args->json);
        }
        if (estimator.kind != VelocityEstimatorKind::backward && !args->passive) {
            const PhysicalPlant plant{box.mass.min, box.damping.min, box.stiffness.min, box.period, box.time_delay.min};
            const NormalizedPlant np = physical ? normalize(plant) : args->plant.normalized();
            const bool covered = passivity_is_covered(np);
            if (impulse) {
                const ImpulseOptimum o = optimal_point(*impulse, np, estimator);
                const NormalizedGains og{o.alpha, o.beta};
                const double margin = covered ? passivity_margin(np, og, estimator) : 0.0;
                WallGains g{0, 0};
                if (physical) g = to_physical(og, plant.mass, plant.period);
                if (args->json) {
                    nlohmann::json out;
                    out["criterion"] = name;
                    out["alpha"] = o.alpha;
                    out["beta"] = o.beta;
                    out["cost"] = number_or_null(o.cost);
                    out["alpha_max"] = o.alpha_max;
                    out["penetration"] = number_or_null(o.penetration);
                    out["penetration_converged"] = o.penetration_converged;
                    out["on_region_edge"] = o.on_region_edge;
                    out["velocity_estimator"] = velocity_json(estimator);
                    out["force_noise_gain"] = number_or_null(force_noise_gain(np, og, estimator));
                    if (covered)
                        add_passivity(out, margin);
                    else
                        add_passivity_not_covered(out);
                    if (physical) {
                        out["K"] = g.stiffness;
                        out["B"] = g.damping;
                    }
                    std::cout << out.dump() << '\n';
                    return int{kOk};
                }
                std::printf("criterion  %s\nvelocity   %s\nalpha      %.10f\nbeta       %.10f\ncost       %.10g\n",
                            name.c_str(), velocity_text(estimator).c_str(), o.alpha, o.beta, o.cost);
                std::printf("penetration %.10g v0 T%s\n", o.penetration,
                            o.penetration_converged ? "" : " (not proven final within the period cap)");
                if (o.on_region_edge) std::printf("note       the infimum lies on the region's edge alpha -> 0\n");
                std::printf("alpha/alpha_max  %.4f (alpha_max %.10f)\n", o.alpha / o.alpha_max, o.alpha_max);
                print_passivity_and_gains(covered, margin, physical ? &g : nullptr);
                return int{kOk};
            }
            EstimatorOptimumOptions eo;
            eo.overshoot_tolerance = args->tolerance;
            const EstimatorOptimum o = estimator_optimum(*step, np, estimator, eo);  // OV too (noise_budget.hpp)
            const EstimatorStabilityRegion region(np, estimator);
            const double noise = force_noise_gain(np, NormalizedGains{o.alpha, o.beta}, estimator);
            WallGains g{0, 0};
            if (physical) g = to_physical(NormalizedGains{o.alpha, o.beta}, plant.mass, plant.period);
            const double margin = covered ? passivity_margin(np, NormalizedGains{o.alpha, o.beta}, estimator) : 0.0;
            if (args->json) {
                nlohmann::json out;
                out["criterion"] = name;
                out["alpha"] = o.alpha;
                out["beta"] = o.beta;
                out["cost"] = o.cost ? nlohmann::json(*o.cost) : nlohmann::json(nullptr);
                out["alpha_max"] = o.alpha_max;
                out["beta_at_alpha_max"] = o.beta_at_alpha_max;
                out["stable_islands"] = islands_json(region);
                if (covered)
                    add_passivity(out, margin);
                else
                    add_passivity_not_covered(out);
                out["velocity_estimator"] = velocity_json(estimator);
                out["force_noise_gain"] = number_or_null(noise);
                if (physical) {
                    out["K"] = g.stiffness;
                    out["B"] = g.damping;
                }
                std::cout << out.dump() << '\n';
                return int{kOk};
            }
            std::printf("criterion  %s\nvelocity   %s\nalpha      %.10f\nbeta       %.10f\n", name.c_str(),
                        velocity_text(estimator).c_str(), o.alpha, o.beta);
            if (o.cost) std::printf("cost       %.10g\n", *o.cost);
            std::printf("alpha_max  %.10f (main region, beta %.10f)\n", o.alpha_max, o.beta_at_alpha_max);
            for (const StableIsland& i : region.islands()) {
                std::printf("island     alpha %.4g..%.4g, beta %.4g..%.4g (not connected to the main region)\n",
                            i.alpha_min, i.alpha_max, i.beta_min, i.beta_max);
            }
            std::printf("alpha/alpha_max  %.4f\nnoise gain g_F   %.6g\n", o.alpha / o.alpha_max, noise);
            print_passivity_and_gains(covered, margin, physical ? &g : nullptr);
            return int{kOk};
        }
        if (args->passive) {
            if (!impulse && !(step && energy_index(*step) && !requires_no_overshoot(*step))) {
                std::cerr << "hapticopt optimum: --passive supports CE0, CE1, CE2, CI0, CI1, CI2 (not " << name
                          << ")\n";
                return int{kUsage};
            }
        }
        OptimumOptions options;
        options.overshoot_tolerance = args->tolerance;
        const PhysicalPlant plant{box.mass.min, box.damping.min, box.stiffness.min, box.period, box.time_delay.min};
        const NormalizedPlant np = physical ? normalize(plant) : args->plant.normalized();
        double alpha = 0, beta = 0, alpha_max = 0;
        std::optional<double> cost, depth;
        bool on_edge = false;
        if (args->passive) {
            const int k = impulse ? energy_index(*impulse) : *energy_index(*step);
            const auto po = impulse ? passive_impulse_optimum(k, np, estimator) : passive_optimum(k, np, estimator);
            if (!po) {
                if (args->json) {
                    nlohmann::json out;
                    out["criterion"] = name;
                    out["passive_constraint"] = true;
                    out["cost"] = nullptr;
                    out["passive"] = false;
                    out["note"] = "no stable gains satisfy delta > max_theta R(theta) (e.g. delta = 0)";
                    std::cout << out.dump() << '\n';
                } else {
                    std::printf("no stable gains satisfy delta > max_theta R(theta) (delta = %g)\n", np.delta);
                }
                return int{kOk};
            }
            alpha = po->alpha;
            beta = po->beta;
            cost = po->cost;
            alpha_max = estimator.kind == VelocityEstimatorKind::backward
                            ? StabilityRegion(np).alpha_max()
                            : EstimatorStabilityRegion(np, estimator).alpha_max();
        } else if (impulse) {
            const ImpulseOptimum o = optimal_point(*impulse, np);
            alpha = o.alpha;
            beta = o.beta;
            cost = o.cost;
            alpha_max = o.alpha_max;
            depth = o.penetration;
            on_edge = o.on_region_edge;
        } else {
            const Optimum o = optimal_point(*step, np, options);
            alpha = o.alpha;
            beta = o.beta;
            cost = o.cost;
            alpha_max = o.alpha_max;
        }
        const bool covered = passivity_is_covered(np);
        const double margin = covered ? passivity_margin(np, NormalizedGains{alpha, beta}, estimator) : 0.0;
        WallGains g{0, 0};
        if (physical) g = to_physical(NormalizedGains{alpha, beta}, plant.mass, plant.period);
        if (args->json) {
            nlohmann::json out;
            out["criterion"] = name;
            out["alpha"] = alpha;
            out["beta"] = beta;
            out["cost"] = cost ? nlohmann::json(*cost) : nlohmann::json(nullptr);
            out["alpha_max"] = alpha_max;
            out["velocity_estimator"] = velocity_json(estimator);
            out["force_noise_gain"] = number_or_null(force_noise_gain(np, NormalizedGains{alpha, beta}, estimator));
            if (args->passive) out["passive_constraint"] = true;
            if (depth) {
                out["penetration"] = *depth;
                out["on_region_edge"] = on_edge;
            }
            if (covered)
                add_passivity(out, margin);
            else
                add_passivity_not_covered(out);
            if (physical) {
                out["K"] = g.stiffness;
                out["B"] = g.damping;
                if (covered) out["passivity_margin_physical"] = margin * plant.mass / plant.period;
            }
            std::cout << out.dump() << '\n';
            return int{kOk};
        }
        std::printf("criterion  %s\n", name.c_str());
        if (estimator.kind != VelocityEstimatorKind::backward)
            std::printf("velocity   %s\n", velocity_text(estimator).c_str());
        std::printf("alpha      %.10f\nbeta       %.10f\n", alpha, beta);
        if (cost) std::printf("cost       %.10g\n", *cost);
        if (depth) std::printf("penetration %.10g v0 T\n", *depth);
        if (on_edge) std::printf("note       the infimum lies on the region's edge alpha -> -gamma (pure damper)\n");
        std::printf("alpha/alpha_max  %.4f\n", alpha / alpha_max);
        print_passivity_and_gains(covered, margin, physical ? &g : nullptr);
        return int{kOk};
    };
}

}  // namespace hapticopt::cli
