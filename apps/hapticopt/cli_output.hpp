// SPDX-License-Identifier: Apache-2.0
// Shared pieces of the hapticopt subcommands: exit codes, number formatting, plant options.
#pragma once

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>

#include <hapticopt/estimator_region.hpp>
#include <hapticopt/parameters.hpp>
#include <hapticopt/estimator_types.hpp>

namespace hapticopt::cli {

/// Exit codes of `hapticopt` (also printed by --help).
enum ExitCode : int {
    kOk = 0,
    kUsage = 2,              ///< unknown option, missing value, malformed number (CLI11)
    kInvalidParameter = 3,   ///< a value outside its accepted range (message names it)
    kComputationFailed = 4,  ///< an unexpected failure inside a computation (a bug: please report)
};

/// A finite double as JSON, or null (NaN, +-inf: e.g. the costs of an unstable loop).
nlohmann::json number_or_null(double value);

/// The stable islands of an estimator's region (beyond its main region) as a JSON array of
/// {alpha_min, alpha_max, beta_min, beta_max}.
nlohmann::json islands_json(const EstimatorStabilityRegion& region);

/// Normalised-plant options shared by the subcommands (--gamma, --delta, --delay).
struct PlantOptions {
    double gamma = 0.0;
    double delta = 0.0;
    double delay = 0.0;
    void add_to(CLI::App& app);
    NormalizedPlant normalized() const { return NormalizedPlant{gamma, delta, delay}; }
};

/// The velocity estimator option (--velocity backward|lowpass:NU|lowpass:FHz|window:N) of the subcommands
/// that take gains or a plant (velocity_estimator.hpp).
struct VelocityOption {
    std::string text = "backward";
    void add_to(CLI::App& app);
    /// The estimator; `period` [s] converts a cutoff in Hz (nu = f_c T), 0 when no period is known.
    /// Throws InvalidParameter for a malformed text, a cutoff in Hz without a period, and the library's ranges.
    VelocityEstimator parse(double period) const;
};

/// {"kind": "backward"} / {"kind": "lowpass", "cutoff": nu} / {"kind": "window", "window": N}.
nlohmann::json velocity_json(const VelocityEstimator& estimator);

/// A one-line description: "backward", "lowpass nu = 0.02", "window N = 15".
std::string velocity_text(const VelocityEstimator& estimator);

}  // namespace hapticopt::cli
