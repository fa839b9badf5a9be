// SPDX-License-Identifier: Apache-2.0
// hapticopt plot collision: step against collision optima. In the (alpha, beta) plane: the
// stability boundary, the optimal curve beta_opt(alpha) of the step criterion C_Ex (optimum.hpp) and of
// the collision criterion C_Ix (impulse_optimum.hpp) for the same x = --index, and both optimal points.
// The paper's conclusion expects the impulse-response optima to "look quite different"; this figure
// shows how. Run time: 2 x --curve-points optimal-curve points (a few ms each) and two global optima.
#include <algorithm>
#include <chrono>
#include <memory>

#include <hapticopt/impulse_optimum.hpp>
#include <hapticopt/optimum.hpp>

#include "commands.hpp"
#include "svg/svg_figure.hpp"

namespace hapticopt::cli {

CommandRunner add_plot_collision(CLI::App& plot) {
    struct Args {
        FigureOptions fig;
        int index = 2;
        int curve_points = 60;
    };
    auto args = std::make_shared<Args>();
    CLI::App* sub = plot.add_subcommand("collision", "step (CEx) against collision (CIx) optimal curves and points");
    args->fig.add_to(*sub);
    sub->add_option("--index", args->index, "x of CEx and CIx: 0, 1 or 2")
        ->capture_default_str()
        ->check(CLI::Range(0, 2));
    add_curve_points_option(*sub, args->curve_points);
    return [args]() {
        const auto start = std::chrono::steady_clock::now();
        const FigureOptions& o = args->fig;
        const double sx = o.k_scale(), sy = o.b_scale();
        const NormalizedPlant plant = o.plant();
        const int k = args->index;
        const Criterion step_criterion = k == 0 ? Criterion::CE0 : k == 1 ? Criterion::CE1 : Criterion::CE2;
        const ImpulseCriterion hit_criterion = k == 0   ? ImpulseCriterion::CI0
                                               : k == 1 ? ImpulseCriterion::CI1
                                                        : ImpulseCriterion::CI2;
        const WallOptimizer step(plant);
        const ImpulseOptimizer hit(plant);
        const StabilityRegion& region = step.region();
        const Optimum step_best = step.optimum(step_criterion);
        const ImpulseOptimum hit_best = hit.optimum(hit_criterion);
        const svg::Polyline boundary = boundary_curve(region);
        double b_lo = HUGE_VAL, b_hi = -HUGE_VAL;
        for (const auto& p : boundary) {
            b_lo = std::min(b_lo, p.second);
            b_hi = std::max(b_hi, p.second);
        }
        svg::Polyline step_curve, hit_curve;
        for (const double a : alpha_samples(region, args->curve_points)) {
            step_curve.emplace_back(a, step.optimal_beta(k, a));
            hit_curve.emplace_back(a, hit.optimal_beta(k, a));
        }
        const std::string ce = std::string(to_string(step_criterion)), ci = std::string(to_string(hit_criterion));
        svg::Document doc(o.width, o.height, ce + " and " + ci + " optima, " + o.caption(plant));
        svg::Axes& ax = main_axes(doc, o, {region.alpha_min() * sx, region.alpha_max() * 1.05 * sx},
                                  {b_lo * sy, b_hi * 1.05 * sy}, o.alpha_label(), o.beta_label(),
                                  "Step (" + ce + ") and collision (" + ci + ") optima, " + o.caption(plant));
        const svg::Style boundary_style{"#000000", 1.5, "", "none", 1};
        const svg::Style step_style{"#1f77b4", 2, "", "none", 1};
        const svg::Style hit_style{"#d62728", 2, "6 3", "none", 1};
        ax.polyline(scaled(boundary, sx, sy), boundary_style, "boundary", "stability boundary");
        ax.polyline(scaled(step_curve, sx, sy), step_style, "step-curve", ce + " optimal curve");
        ax.polyline(scaled(hit_curve, sx, sy), hit_style, "collision-curve", ci + " optimal curve");
        ax.marker(step_best.alpha * sx, step_best.beta * sy, svg::MarkerShape::Plus, step_style, "step-optimum",
                  ce + " optimum", 8);
        ax.marker(hit_best.alpha * sx, hit_best.beta * sy, svg::MarkerShape::Cross, hit_style, "collision-optimum",
                  ci + " optimum", 8);
        ax.legend_line("stability boundary", boundary_style);
        ax.legend_line(ce + " optimal curve (force step)", step_style);
        ax.legend_line(ci + " optimal curve (collision at v0)", hit_style);
        ax.legend_marker(ce + " optimum " + short_number(*step_best.cost), svg::MarkerShape::Plus, step_style);
        ax.legend_marker(
            ci + " optimum " + short_number(hit_best.cost) + (hit_best.on_region_edge ? " (region edge)" : ""),
            svg::MarkerShape::Cross, hit_style);
        return save_figure(doc, o, start);
    };
}

}  // namespace hapticopt::cli
