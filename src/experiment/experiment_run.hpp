// SPDX-License-Identifier: Apache-2.0
// The experiment command after parsing: validation of every parameter (exit 4 naming it and its accepted
// range), the device, the analysis, the run, the files and the summary.
#pragma once

#include "common/startup_error.hpp"

#include <string>
#include <vector>

#include "experiment/experiment_procedures.hpp"

namespace hapticd::experiment {

struct ExperimentOptions {
    std::string device = "sim", out_dir = ".", b_range, k_range;
    bool simulate = false, quiet = false;
    double rate = 1000.0, step_force = 0.0, force_cap = 0.0, position_limit = 0.01, settle = 0.5;
    double trial_time = 0.0, growth = 1.05, energy_cap = 100.0;
    long long delay_buffer = 0, axis = 0, window = 100, consecutive = 3;
    std::vector<double> b_values, k_values;
    double k_min = 0.0, k_max = 0.0, k_step = 0.0, k_resolution = 0.0;
    long long b_points = 11;
    double b_margin = 0.1, overshoot_tol = 1e-6;
};

// Throws StartupError for a bad parameter, device, or output file. Returns how the run ended: Ok (finished, or
// stopped by SIGINT/SIGTERM), Device (a device error during a trial) or RunFault (any other abort).
ErrorKind run_experiment(const ExperimentOptions& options, bool boundary, BoundarySettings boundary_settings,
                         OptimalSettings optimal_settings);

// Throws StartupError(ErrorKind::InvalidParameter) "NAME = VALUE is invalid; accepted range: RANGE" unless ok
// (NaN always fails).
void require(bool ok, const std::string& name, double value, const std::string& range);

}  // namespace hapticd::experiment
