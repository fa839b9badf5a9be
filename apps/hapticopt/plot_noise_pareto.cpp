// SPDX-License-Identifier: Apache-2.0
// hapticopt plot noise-pareto: the trade-off between an energy criterion and the quantisation force noise
// (beyond the paper): for each velocity estimator, the criterion's optimum under a force-noise budget
// g_F <= g_max (noise_budget.hpp, noise_pareto_front) against the g_F it reaches, both on log10 axes, with
// the estimator's unconstrained optimum marked.
//
// Budgets: --points values log-spaced from the estimator's unconstrained g_F (its first point is the
// unconstrained optimum) down to 1e-2 of it. With --mass, --period and --position-resolution q the x-axis
// label also gives the physical force noise, sigma_F = (m q / T^2) g_F [N]. Run time: one constrained
// optimum per point (each one also computes the unconstrained optimum): about 5 s for the default three
// estimators and 12 points at d = 1 (docs/velocity-estimation.md).
#include <chrono>
#include <cmath>
#include <memory>
#include <string>
#include <vector>

#include <hapticopt/criterion.hpp>
#include <hapticopt/noise_budget.hpp>

#include "cli_output.hpp"
#include "commands.hpp"
#include "criterion_option.hpp"
#include "svg/svg_figure.hpp"

namespace hapticopt::cli {

CommandRunner add_plot_noise_pareto(CLI::App& plot) {
    struct Args {
        FigureOptions fig;
        Criterion criterion = Criterion::CE2;
        std::vector<std::string> velocity{"backward", "lowpass:0.02", "window:5"};
        int points = 12;
        double resolution = 0;
        CLI::Option* resolution_option = nullptr;
    };
    auto args = std::make_shared<Args>();
    CLI::App* sub = plot.add_subcommand(
        "noise-pareto", "optimum cost against force-noise gain g_F under a noise budget, one curve per estimator");
    args->fig.add_to(*sub);
    add_criterion_option(*sub, "--criterion,-c", args->criterion, kEnergyCriteria, "CE0, CE1 or CE2");
    sub->add_option("--velocity", args->velocity,
                    "velocity estimators, one curve each (repeat the option): backward, lowpass:NU (lowpass:FHz with "
                    "--period), window:N")
        ->capture_default_str();
    sub->add_option("--points", args->points,
                    "budgets per curve, log-spaced from the unconstrained optimum's g_F down to 1e-2 of it")
        ->capture_default_str()
        ->check(CLI::Range(2, 200));
    args->resolution_option =
        sub->add_option("--position-resolution", args->resolution,
                        "encoder step q [m] (with --mass and --period): label sigma_F = (m q / T^2) g_F [N]");
    args->resolution_option->needs(args->fig.mass_option);
    return [args]() {
        const auto start = std::chrono::steady_clock::now();
        const FigureOptions& o = args->fig;
        const NormalizedPlant plant = o.plant();
        const Criterion criterion = args->criterion;
        const bool sigma = args->resolution_option->count() > 0;
        if (sigma) detail::require_positive("hapticopt plot noise-pareto", "position_resolution", args->resolution);
        std::vector<VelocityEstimator> estimators;
        for (const std::string& text : args->velocity) {
            VelocityOption v;
            v.text = text;
            estimators.push_back(v.parse(o.physical() ? o.period : 0.0));
        }

        struct Curve {
            VelocityEstimator estimator;
            std::vector<NoiseBudgetOptimum> front;
        };
        std::vector<Curve> curves;
        double x0 = HUGE_VAL, x1 = -HUGE_VAL, y0 = HUGE_VAL, y1 = -HUGE_VAL;
        for (const VelocityEstimator& e : estimators) {
            const EstimatorOptimum free = optimal_point(criterion, plant, e);
            const double g0 = force_noise_gain(plant, NormalizedGains{free.alpha, free.beta}, e);
            std::vector<double> budgets;
            for (int i = 0; i < args->points; ++i) budgets.push_back(g0 * std::pow(1e-2, i / (args->points - 1.0)));
            Curve c{e, noise_pareto_front(criterion, plant, e, budgets)};
            if (c.front.empty()) {  // the first budget is the unconstrained optimum's own g_F
                throw InvalidParameter("hapticopt plot noise-pareto", "velocity", std::nan(""),
                                       "an estimator whose unconstrained optimum exists (" + velocity_text(e) + ")");
            }
            for (const NoiseBudgetOptimum& p : c.front) {
                x0 = std::min(x0, std::log10(p.force_noise_gain));
                x1 = std::max(x1, std::log10(p.force_noise_gain));
                y0 = std::min(y0, std::log10(p.cost));
                y1 = std::max(y1, std::log10(p.cost));
            }
            curves.push_back(std::move(c));
        }
        const double pad_x = 0.05 * (x1 - x0), pad_y = 0.05 * (y1 - y0);
        const std::string name(to_string(criterion));
        std::string x_label = "log\u2081\u2080 g_F (force noise per encoder step, normalised)";
        if (sigma) {
            const double scale = o.mass * args->resolution / (o.period * o.period);
            x_label = "log\u2081\u2080 g_F; \u03c3_F = " + short_number(scale) +
                      " g_F [N] (q = " + short_number(args->resolution) + " m)";
        }
        svg::Document doc(o.width, o.height, name + " optimum under a force-noise budget, " + o.caption(plant));
        svg::Axes& ax = main_axes(doc, o, {x0 - pad_x, x1 + pad_x}, {y0 - pad_y, y1 + pad_y}, x_label,
                                  "log\u2081\u2080 " + name + " (constrained optimum)",
                                  name + " against force noise g_F, " + o.caption(plant));
        ax.set_legend_position("top-right");
        int index = 0;
        for (const Curve& c : curves) {
            const std::string label = velocity_text(c.estimator);
            const svg::Style style{svg::color(index), 1.8, index % 2 ? "6 3" : "", "none", 1};
            svg::Polyline line;
            for (const NoiseBudgetOptimum& p : c.front)
                line.emplace_back(std::log10(p.force_noise_gain), std::log10(p.cost));
            ax.polyline(line, style, "pareto", label);
            for (const auto& [x, y] : line)
                ax.marker(x, y, svg::MarkerShape::Circle, svg::Style{svg::color(index), 1, "", "none", 1},
                          "pareto-point", label, 2.5);
            const NoiseBudgetOptimum& free = c.front.front();
            ax.marker(std::log10(free.unconstrained_force_noise_gain), std::log10(free.unconstrained_cost),
                      svg::MarkerShape::Plus, svg::Style{svg::color(index), 2.5, "", "none", 1}, "unconstrained", label,
                      8);
            ax.legend_line(label, style);
            ++index;
        }
        ax.legend_marker("unconstrained optimum", svg::MarkerShape::Plus, svg::Style{"#000000", 2.5, "", "none", 1});
        return save_figure(doc, o, start);
    };
}

}  // namespace hapticopt::cli
