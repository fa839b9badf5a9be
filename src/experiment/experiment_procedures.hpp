// SPDX-License-Identifier: Apache-2.0
// The two experiments of Sect. V (Hulin et al., IROS 2011) on the current device.
//
// Boundary: for each B of the set, K is raised from k_min in steps of k_step until a trial counts as
// unstable (experiment_trial.hpp: energy growth, energy cap, force cap or position limit), then the
// interval between the last stable and the first unstable K is bisected down to k_resolution; the
// boundary is its midpoint (so it is within k_resolution / 2 of the detected transition).
// Optimal: for each K of the grid, b_points values of B spread over the analysed stable B interval at K
// (hapticopt StabilityRegion::beta_range) less a margin on each side; each trial records the step
// response, C_E0..2 and C_OV are measured (experiment_measure.hpp), and for each criterion the grid minimum
// is refined by the vertex of the parabola through it and its two neighbours (a minimum on the grid's
// edge is reported as such, unrefined).
// Between trials: zero force at the trial's last tick, the return phase (SettleSettings), and the step's
// sign alternates from trial to trial so that the equilibria F / K do not walk the device away.
#pragma once

#include <cstddef>
#include <string>
#include <string_view>
#include <vector>

#include <hapticopt/criterion.hpp>

#include "experiment/experiment_measure.hpp"
#include "experiment/experiment_progress.hpp"
#include "experiment/experiment_theory.hpp"
#include "experiment/experiment_trial.hpp"

namespace hapticd::experiment {

struct ExperimentSetup {
    TrialSettings trial;    // axis, direction, period, buffer, mass, k, |step force|, limits, detection
    SettleSettings settle;  // return phase (gains, home, caps)
    CostModel model;        // the plant used to reconstruct between samples
};

struct TrialRow {
    std::size_t index = 0;
    std::string phase;  // "step", "bisect" (boundary) or "grid" (optimal)
    double K = 0.0, B = 0.0, step_force = 0.0;
    TrialOutcome outcome = TrialOutcome::Stable;
    std::size_t ticks = 0;
    double max_growth = 0.0, max_abs_force = 0.0, max_abs_position = 0.0;
    MeasuredCosts costs;  // optimal experiment, stable trials only (NaN otherwise)
    bool has_costs = false;
};

struct Abort {
    TrialOutcome outcome = TrialOutcome::Stable;  // Stable: no abort
    std::string detail;
};

struct BoundarySettings {
    std::vector<double> b_values;
    double k_min = 0.0, k_max = 0.0, k_step = 0.0, k_resolution = 0.0;
};

struct BoundaryPointRow {
    double B = 0.0;
    double K_last_stable = 0.0, K_first_unstable = 0.0, K_boundary = 0.0;  // NaN when not found
    double K_theory = 0.0;
    std::size_t trials = 0;
};

struct BoundaryResult {
    std::vector<TrialRow> trials;
    std::vector<BoundaryPointRow> points;
    Abort abort;
};

struct OptimalSettings {
    std::vector<double> k_values;
    int b_points = 11;
    double b_margin = 0.1;              // fraction of the stable B interval left out at each end
    double overshoot_tolerance = 1e-6;  // relative: C_OV <= this counts as no overshoot (markers)
};

struct OptimalPointRow {
    double K = 0.0;
    int criterion = 0;  // 0, 1, 2: C_E0, C_E1, C_E2 (hapticopt::kEnergyCriteria's index)
    double B_grid = 0.0, cost_grid = 0.0, B_refined = 0.0, B_theory = 0.0, b_step = 0.0;
    bool on_edge = false;  // the grid minimum is at the grid's end: not refined
    // "CE0", "CE1", "CE2": the criterion's name (hapticopt::to_string).
    [[nodiscard]] std::string_view criterion_name() const {
        return hapticopt::to_string(hapticopt::kEnergyCriteria.at(static_cast<std::size_t>(criterion)));
    }
};

struct OptimalResult {
    std::vector<TrialRow> trials;
    std::vector<OptimalPointRow> points;
    Abort abort;
};

BoundaryResult run_boundary(TrialRunner& runner, const ExperimentSetup& setup, const BoundarySettings& settings,
                            const Theory& theory, Progress& progress);
OptimalResult run_optimal(TrialRunner& runner, const ExperimentSetup& setup, const OptimalSettings& settings,
                          const Theory& theory, Progress& progress);

}  // namespace hapticd::experiment
