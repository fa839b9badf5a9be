// SPDX-License-Identifier: Apache-2.0
// hapticopt limit-cycle: Coulomb friction and encoder quantisation at one gain pair (limit_cycles.hpp): whether a
// sticking rest holds the push, the Abbott-Okamura and Colgate-Schenkel passivity verdicts, and the
// describing-function prediction of the chatter (amplitude, frequency, stability of the cycle). With --velocity
// other than backward the describing function takes the estimator; Colgate-Schenkel (the backward difference's
// passivity) is then not reported, and Abbott-Okamura is covered only with beta = 0, where no estimator enters.
#include <cmath>
#include <cstdio>
#include <iostream>
#include <memory>

#include <hapticopt/limit_cycles.hpp>
#include <hapticopt/passivity.hpp>

#include "cli_output.hpp"
#include "commands.hpp"

namespace hapticopt::cli {

namespace {

nlohmann::json cycle_json(const PredictedLimitCycle& c) {
    return {{"amplitude", c.amplitude},
            {"frequency", c.frequency},
            {"theta", c.theta},
            {"mean_position", c.mean_position},
            {"describing_gain", c.describing_gain},
            {"equivalent_damping", c.equivalent_damping},
            {"stable", c.stable}};
}

}  // namespace

CommandRunner add_limit_cycle_command(CLI::App& app) {
    struct Args {
        double alpha = 0, beta = 0;
        PlantOptions plant;
        double mass = 0, period = 0, resolution = 0, friction = 0, push = 0;
        VelocityOption velocity;
        bool json = false;
    };
    auto args = std::make_shared<Args>();
    CLI::App* sub = app.add_subcommand(
        "limit-cycle", "Coulomb friction and quantisation: rest, passivity and the describing-function limit cycle");
    sub->add_option("--alpha", args->alpha, "normalised wall stiffness K T^2/m (> 0)")->required();
    sub->add_option("--beta", args->beta, "normalised wall damping B T/m")->required();
    args->plant.add_to(*sub);
    sub->add_option("--mass", args->mass, "moving mass m [kg]")->required();
    sub->add_option("--period", args->period, "sampling period T [s]")->required();
    sub->add_option("--position-resolution", args->resolution, "encoder step q [m]")->required();
    sub->add_option("--coulomb-friction", args->friction, "Coulomb friction f_c [N] (>= 0)")->capture_default_str();
    sub->add_option("--push", args->push, "constant push F [N] that sets the mean position")->capture_default_str();
    args->velocity.add_to(*sub);
    sub->add_flag("--json", args->json, "print one JSON object");
    return [args]() {
        const char* self = "hapticopt limit-cycle";
        detail::require_positive(self, "--mass", args->mass);
        detail::require_positive(self, "--period", args->period);
        detail::require_positive(self, "--position-resolution", args->resolution);
        detail::require_non_negative(self, "--coulomb-friction", args->friction);
        detail::require_in_range(self, "--alpha", args->alpha, 0.0, true, HUGE_VAL, "finite and > 0");
        detail::require_finite(self, "--beta", args->beta);
        detail::require_finite(self, "--push", args->push);
        const NormalizedPlant np = args->plant.normalized();
        LimitCycleLoop loop;
        loop.plant = to_physical(np, args->mass, args->period);
        loop.gains = to_physical(NormalizedGains{args->alpha, args->beta}, args->mass, args->period);
        loop.coulomb_friction = args->friction;
        loop.position_step = args->resolution;
        loop.external_force = args->push;
        loop.estimator = args->velocity.parse(args->period);
        const bool backward = loop.estimator.kind == VelocityEstimatorKind::backward;
        const LimitCyclePrediction p = predict_limit_cycle(loop);  // validates every parameter
        const AbbottOkamuraPassivity ao = abbott_okamura_passivity(
            loop.gains.stiffness, loop.plant.damping, loop.coulomb_friction, loop.position_step, loop.plant.period);
        const bool ao_covered = args->beta == 0 && np.delay == 0;
        const bool cs_covered = backward && passivity_is_covered(np);
        const bool cs_passive = cs_covered && is_passive(np, NormalizedGains{args->alpha, args->beta});
        if (args->json) {
            nlohmann::json out;
            out["stiffness"] = loop.gains.stiffness;
            out["damping"] = loop.gains.damping;
            out["rest_exists"] = p.rest_exists;
            out["abbott_okamura"] = {{"viscous_bound", ao.viscous_bound},
                                     {"coulomb_bound", ao.coulomb_bound},
                                     {"stiffness_bound", ao.stiffness_bound},
                                     {"passive", ao.passive},
                                     {"covered", ao_covered}};
            out["colgate_schenkel_passive"] = cs_covered ? nlohmann::json(cs_passive) : nlohmann::json(nullptr);
            out["limit_cycle_predicted"] = p.predicted;
            out["limit_cycle"] = p.predicted ? cycle_json(p.cycle) : nlohmann::json(nullptr);
            nlohmann::json all = nlohmann::json::array();
            for (const auto& c : p.cycles) all.push_back(cycle_json(c));
            out["cycles"] = std::move(all);
            out["grows_at_large_amplitude"] = p.grows_at_large_amplitude;
            out["velocity_estimator"] = velocity_json(loop.estimator);
            std::cout << out.dump() << '\n';
            return int{kOk};
        }
        std::printf("wall             K %.6g N/m, B %.6g N s/m\n", loop.gains.stiffness, loop.gains.damping);
        std::printf("velocity         %s\n", velocity_text(loop.estimator).c_str());
        std::printf("rest exists      %s (a level n q with |F - K n q - k x| <= f_c)\n", p.rest_exists ? "yes" : "no");
        std::printf("Abbott-Okamura   K <= max(2b/T = %.6g, 2 f_c/q = %.6g) N/m: %s%s\n", ao.viscous_bound,
                    ao.coulomb_bound, ao.passive ? "passive" : "not passive",
                    ao_covered ? "" : " (the condition assumes B = 0 and d = 0)");
        if (cs_covered)
            std::printf("Colgate-Schenkel %s\n", cs_passive ? "passive" : "not passive");
        else if (!backward)
            std::printf("Colgate-Schenkel not reported (a condition on the backward difference)\n");
        else
            std::printf("Colgate-Schenkel %s\n", kPassivityNotCovered);
        if (!p.predicted) {
            std::printf("limit cycle      none predicted (describing function)\n");
        } else {
            std::printf(
                "limit cycle      amplitude %.4g m, frequency %.4g Hz, %s (describing function; "
                "docs/limit-cycles.md for its accuracy)\n",
                p.cycle.amplitude, p.cycle.frequency, p.cycle.stable ? "stable" : "unstable");
            if (p.cycles.size() > 1) std::printf("                 %zu cycles in all\n", p.cycles.size());
        }
        if (p.grows_at_large_amplitude) std::printf("large motions    grow (outside the linear stable region)\n");
        return int{kOk};
    };
}

}  // namespace hapticopt::cli
