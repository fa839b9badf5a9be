// SPDX-License-Identifier: Apache-2.0
// Outputs of the experiments: CSV files (values with 17 significant digits, units in the header, "nan"
// where a value does not exist) and an SVG figure like the paper's Fig. 8 (measured points beside the
// theoretical stability boundary and optimal curves, K [N/m] across, B [N s/m] up).
//
// boundary:  boundary_trials.csv  index,phase,K_N_per_m,B_Ns_per_m,step_force_N,outcome,unstable,ticks,
//                                 max_growth,max_abs_force_N,max_abs_position_m
//            boundary.csv         B_Ns_per_m,K_last_stable_N_per_m,K_first_unstable_N_per_m,K_boundary_N_per_m,
//                                 K_theory_N_per_m,trials
//            boundary.svg         class "boundary" (theory polyline), markers class "measured-boundary"
// optimal:   optimal_trials.csv   the trial columns + CE0,CE1,CE2,COV,tail_estimate (dimensionless)
//            optimal.csv          K_N_per_m,criterion,B_grid_Ns_per_m,cost_grid,B_refined_Ns_per_m,
//                                 B_theory_Ns_per_m,B_step_Ns_per_m,on_edge
//            optimal.svg          "boundary", "optimal-CE0..2" (theory polylines), markers "measured-CE0..2"
//                                 at (K, B_refined) and "no-overshoot" (pluses) at trials with C_OV <= tol
#pragma once

#include <string>

#include "experiment/experiment_procedures.hpp"

namespace hapticd::experiment {

struct FigureCaption {
    std::string text;  // "m = 0.3 kg, T = 1 ms, t_d = 0 ms, k = 0 N/m, b = 0 N s/m"
};

// Each writes its files into dir (created when missing); throws std::runtime_error naming a file that
// cannot be written. Returns the paths written.
std::vector<std::string> write_boundary_outputs(const std::string& dir, const BoundaryResult& result,
                                                const Theory& theory, const FigureCaption& caption);
std::vector<std::string> write_optimal_outputs(const std::string& dir, const OptimalResult& result,
                                               const OptimalSettings& settings, const Theory& theory,
                                               const FigureCaption& caption);

}  // namespace hapticd::experiment
