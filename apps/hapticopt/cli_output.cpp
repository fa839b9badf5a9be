// SPDX-License-Identifier: Apache-2.0
#include "cli_output.hpp"

#include <cmath>

namespace hapticopt::cli {

nlohmann::json number_or_null(double value) {
  return std::isfinite(value) ? nlohmann::json(value) : nlohmann::json(nullptr);
}

void PlantOptions::add_to(CLI::App& app) {
  app.add_option("--gamma", gamma, "normalised physical stiffness k T^2/m (>= 0)")->capture_default_str();
  app.add_option("--delta", delta, "normalised physical damping b T/m (>= 0)")->capture_default_str();
  app.add_option("--delay", delay, "delay d = t_d/T in periods (>= 0, may be fractional)")->capture_default_str();
}

}  // namespace hapticopt::cli
