// SPDX-License-Identifier: Apache-2.0
// hapticopt plot costs: contour lines of an energy criterion C_E0..2 over the stable region, its
// optimal curve beta_opt(alpha) and its optimal point (Fig. 4 of the paper), and below, the cost along
// the optimal curve.
//
// Contours: marching squares (svg_contour.hpp) on log2 C over a `--grid` x `--grid` grid of the
// region's bounding box, the exact cost (energy_costs.hpp) at every grid point, +inf outside the
// stable region (no contour there). Levels C_min 2^(k/2), k = 1..--levels: as in the paper, every
// second line is a doubling of the cost. Run time: grid^2 cost evaluations (200 x 200: about 0.5 s at
// d = 1) plus --curve-points optimal-curve points (a few ms each).
#include <algorithm>
#include <chrono>
#include <cmath>
#include <memory>

#include <hapticopt/criterion.hpp>
#include <hapticopt/optimum.hpp>

#include "commands.hpp"
#include "criterion_option.hpp"
#include "svg/svg_figure.hpp"

namespace hapticopt::cli {

CommandRunner add_plot_costs(CLI::App& plot) {
    struct Args {
        FigureOptions fig;
        Criterion criterion = Criterion::CE2;
        int grid = 200, levels = 12, curve_points = 60;
    };
    auto args = std::make_shared<Args>();
    CLI::App* sub =
        plot.add_subcommand("costs", "cost contours, optimal curve and optimal point of CE0/CE1/CE2 (Fig. 4)");
    args->fig.add_to(*sub, false, 800);
    add_criterion_option(*sub, "--criterion,-c", args->criterion, kEnergyCriteria, "CE0, CE1 or CE2");
    sub->add_option("--grid", args->grid, "grid points per axis of the contour grid")
        ->capture_default_str()
        ->check(CLI::Range(8, 2000));
    sub->add_option("--levels", args->levels, "contour levels C_min 2^(k/2), k = 1..levels")
        ->capture_default_str()
        ->check(CLI::Range(1, 60));
    add_curve_points_option(*sub, args->curve_points);
    return [args]() {
        const auto start = std::chrono::steady_clock::now();
        const FigureOptions& o = args->fig;
        const double sx = o.k_scale(), sy = o.b_scale();
        const NormalizedPlant plant = o.plant();
        const Criterion criterion = args->criterion;
        const int k = *energy_index(criterion);
        const WallOptimizer optimizer(plant);
        const StabilityRegion& region = optimizer.region();
        const Optimum best = optimizer.optimum(criterion);
        const svg::Polyline boundary = boundary_curve(region);
        double b_lo = HUGE_VAL, b_hi = -HUGE_VAL;
        for (const auto& p : boundary) {
            b_lo = std::min(b_lo, p.second);
            b_hi = std::max(b_hi, p.second);
        }

        svg::SampledGrid grid;
        const auto n = static_cast<std::size_t>(args->grid);
        for (std::size_t i = 0; i < n; ++i) {
            const double s = static_cast<double>(i) / static_cast<double>(n - 1);
            grid.xs.push_back(region.alpha_min() + s * (region.alpha_max() - region.alpha_min()));
            grid.ys.push_back(b_lo + s * (b_hi - b_lo));
        }
        grid.values.resize(n * n);
        for (std::size_t j = 0; j < n; ++j) {
            for (std::size_t i = 0; i < n; ++i)
                grid.values[j * n + i] = std::log2(optimizer.energy_cost(k, grid.xs[i], grid.ys[j]));
        }

        svg::Polyline curve, along;
        for (const double a : alpha_samples(region, args->curve_points)) {
            const double b = optimizer.optimal_beta(k, a);
            curve.emplace_back(a, b);
            along.emplace_back(a * sx, optimizer.energy_cost(k, a, b));
        }

        const std::string name(to_string(criterion));
        svg::Document doc(o.width, o.height, name + " contours and optimum, " + o.caption(plant));
        svg::Axes& ax =
            main_axes(doc, o, {region.alpha_min() * sx, region.alpha_max() * 1.05 * sx}, {b_lo * sy, b_hi * 1.05 * sy},
                      o.alpha_label(), o.beta_label(),
                      name + ": contours C_min\u00b72^(k/2), optimal curve and optimum, " + o.caption(plant), 0.68);
        const svg::Style contour_style{"#7f7f7f", 0.8, "", "none", 1};
        const double cmin = *best.cost;
        for (int level = 1; level <= args->levels; ++level) {
            const double value = cmin * std::pow(2.0, level / 2.0);
            const std::string label = "C = " + short_number(value);
            svg::Style s = contour_style;
            if (level % 2 == 0) s.width = 1.2;
            for (const auto& line : svg::contour_lines(grid, std::log2(value))) {
                ax.polyline(scaled(line, sx, sy), s, "contour", label);
            }
        }
        const svg::Style boundary_style{"#000000", 1.5, "", "none", 1};
        const svg::Style curve_style{"#1f77b4", 2, "", "none", 1};
        const svg::Style best_style{"#2ca02c", 2.5, "", "none", 1};
        ax.polyline(scaled(boundary, sx, sy), boundary_style, "boundary", "stability boundary");
        ax.polyline(scaled(curve, sx, sy), curve_style, "optimal-curve", name + " optimal curve");
        ax.marker(best.alpha * sx, best.beta * sy, svg::MarkerShape::Plus, best_style, "optimum", name + " optimum", 8);
        ax.legend_line("stability boundary", boundary_style);
        ax.legend_line("contours (2 lines = cost x2)", contour_style);
        ax.legend_line(name + " optimal curve", curve_style);
        ax.legend_marker(name + " optimum " + short_number(cmin), svg::MarkerShape::Plus, best_style);

        // Lower panel: the cost along the optimal curve (clipped at 16 C_min).
        const double top = 60 + (o.height - 96) * 0.68;  // below the upper panel and its labels
        svg::Axes& lower = doc.add_axes("along-curve", 80, top, o.width - 104, o.height - 56 - top,
                                        {region.alpha_min() * sx, region.alpha_max() * 1.05 * sx}, {0.0, 16 * cmin},
                                        o.alpha_label(), name + " on the curve");
        lower.polyline(along, curve_style, "cost-along-curve", name + " along the optimal curve");
        lower.marker(best.alpha * sx, cmin, svg::MarkerShape::Plus, best_style, "optimum-cost", name + " optimum", 8);
        return save_figure(doc, o, start);
    };
}

}  // namespace hapticopt::cli
