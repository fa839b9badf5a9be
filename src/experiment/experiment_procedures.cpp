// SPDX-License-Identifier: Apache-2.0
#include "experiment/experiment_procedures.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <limits>

namespace hapticd::experiment {

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// One trial and the return phase after it; fills the row; returns false when the experiment must stop.
class TrialSequence {
  public:
    TrialSequence(TrialRunner& runner, const ExperimentSetup& setup) : runner_(runner), setup_(setup) {}

    bool run(double K, double B, const char* phase, TrialRow& row, Abort& abort, TrialRecord& record) {
        TrialSettings t = setup_.trial;
        t.K = K;
        t.B = B;
        t.step_force = (count_ % 2 == 0 ? 1.0 : -1.0) * std::abs(setup_.trial.step_force);
        runner_.run(t, record);
        row.index = count_++;
        row.phase = phase;
        row.K = K;
        row.B = B;
        row.step_force = t.step_force;
        row.outcome = record.outcome;
        row.ticks = record.samples;
        row.max_growth = record.max_growth;
        row.max_abs_force = record.max_abs_force;
        row.max_abs_position = record.max_abs_position;
        last_trial_ = t;
        if (ends_experiment(record.outcome)) {
            abort.outcome = record.outcome;
            abort.detail = describe(record.outcome, K, B, record.end_tick, record.device_error);
            return false;
        }
        const SettleResult s = runner_.settle(setup_.settle);
        if (s.outcome != TrialOutcome::Stable) {
            abort.outcome = s.outcome;
            abort.detail = s.outcome == TrialOutcome::PositionLimit
                               ? "return phase after the trial at K = " + number(K) + " N/m, B = " + number(B) +
                                     " N s/m: the device is " + number(s.final_offset) +
                                     " m from home, beyond the return limit; zero force, experiment stopped"
                               : describe(s.outcome, K, B, 0, s.device_error) + " (return phase)";
            return false;
        }
        return true;
    }
    [[nodiscard]] const TrialSettings& last_trial() const { return last_trial_; }

    static std::string number(double v) {
        char b[48];
        std::snprintf(b, sizeof b, "%.6g", v);
        return b;
    }

  private:
    static std::string describe(TrialOutcome o, double K, double B, std::size_t tick, const std::string& device_error) {
        const std::string where =
            "trial at K = " + number(K) + " N/m, B = " + number(B) + " N s/m, tick " + std::to_string(tick);
        switch (o) {
            case TrialOutcome::DeviceFault:
                return where + ": device error: " + device_error + "; zero force, experiment stopped";
            case TrialOutcome::NonFinite:
                return where + ": non-finite position; zero force, experiment stopped";
            case TrialOutcome::Stopped:
                return where + ": stopped by signal; zero force";
            default:
                return where + ": " + to_string(o);
        }
    }

    TrialRunner& runner_;
    const ExperimentSetup& setup_;
    std::size_t count_ = 0;
    TrialSettings last_trial_;
};

}  // namespace

BoundaryResult run_boundary(TrialRunner& runner, const ExperimentSetup& setup, const BoundarySettings& s,
                            const Theory& theory, Progress& progress) {
    BoundaryResult result;
    TrialSequence sequence(runner, setup);
    TrialRecord record;
    const auto steps = static_cast<std::size_t>(std::floor((s.k_max - s.k_min) / s.k_step + 1e-9)) + 1;
    const auto bisections = static_cast<std::size_t>(std::ceil(std::log2(std::max(2.0, s.k_step / s.k_resolution))));
    // Planned: about half the steps (the boundary is mid-range) plus the bisection per B; corrected as it runs.
    std::size_t planned = s.b_values.size() * (steps / 2 + bisections);
    progress.start("boundary", planned);
    for (std::size_t bi = 0; bi < s.b_values.size(); ++bi) {
        const double B = s.b_values[bi];
        BoundaryPointRow point;
        point.B = B;
        point.K_theory = theory.boundary_stiffness(B);
        double stable = kNaN, unstable = kNaN;
        auto trial = [&](double K, const char* phase) {
            TrialRow row;
            const bool go_on = sequence.run(K, B, phase, row, result.abort, record);
            result.trials.push_back(row);
            ++point.trials;
            planned = std::max(planned, result.trials.size() + 1);
            progress.set_total(planned);
            progress.update(result.trials.size(), "B = " + TrialSequence::number(B) + " N s/m, K = " +
                                                      TrialSequence::number(K) + " N/m: " + to_string(row.outcome));
            if (go_on) (counts_as_unstable(row.outcome) ? unstable : stable) = K;
            return go_on;
        };
        bool go_on = true;
        for (std::size_t i = 0; i < steps && go_on; ++i) {
            const double K = s.k_min + static_cast<double>(i) * s.k_step;
            go_on = trial(K, "step");
            if (go_on && !std::isnan(unstable)) break;
        }
        // Bisection between the last stable and the first unstable K.
        while (go_on && !std::isnan(stable) && !std::isnan(unstable) && unstable - stable > s.k_resolution) {
            go_on = trial((stable + unstable) / 2.0, "bisect");
        }
        point.K_last_stable = stable;
        point.K_first_unstable = unstable;
        point.K_boundary = !std::isnan(stable) && !std::isnan(unstable) ? (stable + unstable) / 2.0 : kNaN;
        result.points.push_back(point);
        if (!go_on) break;
    }
    progress.finish(result.abort.outcome == TrialOutcome::Stable ? "done" : to_string(result.abort.outcome));
    return result;
}

OptimalResult run_optimal(TrialRunner& runner, const ExperimentSetup& setup, const OptimalSettings& s,
                          const Theory& theory, Progress& progress) {
    OptimalResult result;
    TrialSequence sequence(runner, setup);
    TrialRecord record;
    progress.start("optimal", s.k_values.size() * static_cast<std::size_t>(s.b_points));
    for (const double K : s.k_values) {
        const auto [lo, hi] = theory.stable_damping(K);
        const double width = hi - lo, first = lo + s.b_margin * width;
        const double step = width * (1.0 - 2.0 * s.b_margin) / (s.b_points - 1);
        std::vector<double> bs;
        std::vector<std::array<double, 3>> costs;
        bool go_on = true;
        for (int i = 0; i < s.b_points && go_on; ++i) {
            const double B = first + i * step;
            TrialRow row;
            go_on = sequence.run(K, B, "grid", row, result.abort, record);
            if (go_on && row.outcome == TrialOutcome::Stable) {
                row.costs = measure_costs(record, sequence.last_trial(), setup.model);
                row.has_costs = true;
            }
            const double inf = std::numeric_limits<double>::infinity();
            bs.push_back(B);
            costs.push_back(row.has_costs ? std::array<double, 3>{row.costs.ce0, row.costs.ce1, row.costs.ce2}
                                          : std::array<double, 3>{inf, inf, inf});
            result.trials.push_back(row);
            progress.update(result.trials.size(), "K = " + TrialSequence::number(K) + " N/m, B = " +
                                                      TrialSequence::number(B) + " N s/m: " + to_string(row.outcome));
        }
        if (!go_on) break;
        for (int c = 0; c < 3; ++c) {
            std::size_t best = 0;
            for (std::size_t i = 1; i < bs.size(); ++i) {
                if (costs[i][c] < costs[best][c]) best = i;
            }
            if (!std::isfinite(costs[best][c])) continue;  // no stable trial at this K
            OptimalPointRow p;
            p.K = K;
            p.criterion = c;
            p.B_grid = bs[best];
            p.cost_grid = costs[best][c];
            p.b_step = step;
            p.B_theory = theory.optimal_damping(c, K);
            p.on_edge = best == 0 || best + 1 == bs.size() || !std::isfinite(costs[best - 1][c]) ||
                        !std::isfinite(costs[best + 1][c]);
            p.B_refined = p.on_edge ? p.B_grid
                                    : parabola_vertex(bs[best - 1], costs[best - 1][c], bs[best], costs[best][c],
                                                      bs[best + 1], costs[best + 1][c]);
            result.points.push_back(p);
        }
    }
    progress.finish(result.abort.outcome == TrialOutcome::Stable ? "done" : to_string(result.abort.outcome));
    return result;
}

}  // namespace hapticd::experiment
