// hapticopt boundary: the exact stability boundary in the (alpha, beta) plane.
#include <cstdio>
#include <iostream>
#include <memory>

#include <hapticopt/stability_region.hpp>

#include "cli_output.hpp"
#include "commands.hpp"

namespace hapticopt::cli {

CommandRunner add_boundary_command(CLI::App& app) {
  struct Args {
    PlantOptions plant;
    int points = 256;
    bool json = false, csv = false;
  };
  auto args = std::make_shared<Args>();
  CLI::App* sub = app.add_subcommand("boundary", "stability boundary points (closed polygon) and alpha_max");
  args->plant.add_to(*sub);
  sub->add_option("--points", args->points, "points on the complex-root branch (>= 8)")->capture_default_str();
  CLI::Option* json = sub->add_flag("--json", args->json, "print one JSON object");
  CLI::Option* csv = sub->add_flag("--csv", args->csv, "print CSV: theta,alpha,beta");
  json->excludes(csv);
  return [args]() {
    const StabilityRegion region(args->plant.normalized());
    const auto polygon = region.polygon(args->points);
    if (args->json) {
      nlohmann::json out;
      out["alpha_max"] = region.alpha_max();
      out["beta_at_alpha_max"] = region.beta_at_alpha_max();
      out["alpha_min"] = region.alpha_min();
      nlohmann::json pts = nlohmann::json::array();
      for (const auto& p : polygon) pts.push_back({{"theta", p.theta}, {"alpha", p.alpha}, {"beta", p.beta}});
      out["points"] = std::move(pts);
      std::cout << out.dump() << '\n';
      return int{kOk};
    }
    if (args->csv) {
      std::printf("theta,alpha,beta\n");
      for (const auto& p : polygon) std::printf("%.17g,%.17g,%.17g\n", p.theta, p.alpha, p.beta);
      return int{kOk};
    }
    std::printf("stiffness range  [%.10f, %.10f]\nalpha_max        %.12f at beta %.12f\n", region.alpha_min(),
                region.alpha_max(), region.alpha_max(), region.beta_at_alpha_max());
    std::printf("%10s %14s %14s\n", "theta", "alpha", "beta");
    for (const auto& p : polygon) std::printf("%10.6f %14.10f %14.10f\n", p.theta, p.alpha, p.beta);
    return int{kOk};
  };
}

}  // namespace hapticopt::cli
