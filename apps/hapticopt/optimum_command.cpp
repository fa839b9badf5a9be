// hapticopt optimum: the optimal point of one criterion, normalised or physical.
#include <cstdio>
#include <iostream>
#include <memory>

#include <hapticopt/optimal_wall.hpp>

#include "cli_output.hpp"
#include "commands.hpp"

namespace hapticopt::cli {

CommandRunner add_optimum_command(CLI::App& app) {
  struct Args {
    std::string criterion;
    PlantOptions plant;
    double mass = 0, period = 0, time_delay = 0, damping = 0, stiffness = 0;
    double tolerance = 1e-12;
    bool json = false;
  };
  auto args = std::make_shared<Args>();
  CLI::App* sub = app.add_subcommand("optimum", "optimal (alpha, beta) of a criterion, and (K, B) with --mass");
  sub->add_option("--criterion", args->criterion, "amax, OV, CE0, CE1, CE2, CE0+OV, CE1+OV, CE2+OV")
      ->required()
      ->check(CLI::IsMember({"amax", "OV", "CE0", "CE1", "CE2", "CE0+OV", "CE1+OV", "CE2+OV"}));
  args->plant.add_to(*sub);
  CLI::Option* mass = sub->add_option("--mass", args->mass, "moving mass m [kg] (device + arm); physical mode");
  CLI::Option* period = sub->add_option("--period", args->period, "sampling period T [s]");
  CLI::Option* time_delay = sub->add_option("--time-delay", args->time_delay, "loop delay t_d [s]");
  CLI::Option* damping = sub->add_option("--damping", args->damping, "physical damping b [N s/m]");
  CLI::Option* stiffness = sub->add_option("--stiffness", args->stiffness, "physical stiffness k [N/m]");
  mass->needs(period);
  period->needs(mass);
  for (CLI::Option* o : {time_delay, damping, stiffness}) o->needs(mass);
  for (const char* name : {"--gamma", "--delta", "--delay"}) mass->excludes(sub->get_option(name));
  sub->add_option("--overshoot-tol", args->tolerance, "relative overshoot counted as none, (0, 1]")
      ->capture_default_str();
  sub->add_flag("--json", args->json, "print one JSON object");
  return [args, mass]() {
    const Criterion criterion = *parse_criterion(args->criterion);
    OptimumOptions options;
    options.overshoot_tolerance = args->tolerance;
    const bool physical = mass->count() > 0;
    nlohmann::json out;
    double alpha = 0, beta = 0, K = 0, B = 0, alpha_max = 0;
    std::optional<double> cost;
    if (physical) {
      const WallTuning t = optimal_wall(
          criterion, PhysicalPlant{args->mass, args->damping, args->stiffness, args->period, args->time_delay},
          options);
      alpha = t.alpha; beta = t.beta; cost = t.cost; K = t.K; B = t.B; alpha_max = t.alpha_max;
    } else {
      const Optimum o = optimal_point(criterion, args->plant.normalized(), options);
      alpha = o.alpha; beta = o.beta; cost = o.cost; alpha_max = o.alpha_max;
    }
    if (args->json) {
      out["criterion"] = args->criterion;
      out["alpha"] = alpha;
      out["beta"] = beta;
      out["cost"] = cost ? nlohmann::json(*cost) : nlohmann::json(nullptr);
      out["alpha_max"] = alpha_max;
      if (physical) {
        out["K"] = K;
        out["B"] = B;
      }
      std::cout << out.dump() << '\n';
      return int{kOk};
    }
    std::printf("criterion  %s\nalpha      %.10f\nbeta       %.10f\n", args->criterion.c_str(), alpha, beta);
    if (cost) std::printf("cost       %.10g\n", *cost);
    std::printf("alpha/alpha_max  %.4f\n", alpha / alpha_max);
    if (physical) std::printf("K          %.6g N/m\nB          %.6g N s/m\n", K, B);
    return int{kOk};
  };
}

}  // namespace hapticopt::cli
