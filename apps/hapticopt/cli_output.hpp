// SPDX-License-Identifier: Apache-2.0
// Shared pieces of the hapticopt subcommands: exit codes, number formatting, plant options.
#pragma once

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>

#include <hapticopt/parameters.hpp>

namespace hapticopt::cli {

/// Exit codes of `hapticopt` (also printed by --help).
enum ExitCode : int {
  kOk = 0,
  kUsage = 2,             ///< unknown option, missing value, malformed number (CLI11)
  kInvalidParameter = 3,  ///< a value outside its accepted range (message names it)
  kComputationFailed = 4, ///< an unexpected failure inside a computation (a bug: please report)
};

/// A finite double as JSON, or null (NaN, +-inf: e.g. the costs of an unstable loop).
nlohmann::json number_or_null(double value);

/// Normalised-plant options shared by the subcommands (--gamma, --delta, --delay).
struct PlantOptions {
  double gamma = 0.0;
  double delta = 0.0;
  double delay = 0.0;
  void add_to(CLI::App& app);
  NormalizedPlant normalized() const { return NormalizedPlant{gamma, delta, delay}; }
};

}  // namespace hapticopt::cli
