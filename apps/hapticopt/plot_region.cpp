// SPDX-License-Identifier: Apache-2.0
// hapticopt plot region: the stability boundaries in the (alpha, beta) plane for the corners of a
// (gamma, delta) box (Fig. 3 of the paper), with each region's tip (alpha_max) marked, and optionally
// the passive set of the Colgate-Schenkel condition with the loop delay (passivity.hpp) for comparison.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <memory>
#include <string>

#include <hapticopt/passivity.hpp>
#include <hapticopt/stability_region.hpp>

#include "commands.hpp"
#include "svg/svg_figure.hpp"

namespace hapticopt::cli {

CommandRunner add_plot_region(CLI::App& plot) {
    struct Args {
        FigureOptions fig;
        int points = 400;
        bool passivity = false;
    };
    auto args = std::make_shared<Args>();
    CLI::App* sub =
        plot.add_subcommand("region", "stability boundaries for the corners of the gamma/delta box (Fig. 3)");
    args->fig.add_to(*sub, /*corner_lists=*/true);
    sub->add_option("--points", args->points, "samples of each boundary's complex-root branch (>= 8)")
        ->capture_default_str()
        ->check(CLI::Range(8, 1000000));
    sub->add_flag("--passivity", args->passivity,
                  "also draw the passive set delta > max_theta R(theta) (Colgate & Schenkel 1997 with the delay "
                  "z^-d; integer delays) of the largest delta");
    return [args]() {
        const auto start = std::chrono::steady_clock::now();
        const FigureOptions& o = args->fig;
        const double sx = o.k_scale(), sy = o.b_scale();
        struct Curve {
            NormalizedPlant plant;
            StabilityRegion region;
            svg::Polyline points;
        };
        std::vector<Curve> curves;
        double x0 = 0, x1 = 0, y0 = 0, y1 = 0;
        for (const NormalizedPlant& p : o.plants()) {
            StabilityRegion region(p);
            svg::Polyline pts = boundary_curve(region, args->points);
            for (const auto& [a, b] : pts) {
                x0 = std::min(x0, a);
                x1 = std::max(x1, a);
                y0 = std::min(y0, b);
                y1 = std::max(y1, b);
            }
            curves.push_back({p, std::move(region), std::move(pts)});
        }
        svg::Document doc(o.width, o.height, "Stability boundaries, " + o.caption(curves.front().plant));
        svg::Axes& ax =
            main_axes(doc, o, {x0 * sx, x1 * 1.05 * sx}, {y0 * sy, y1 * 1.05 * sy}, o.alpha_label(), o.beta_label(),
                      "Stability boundaries (stable inside), " + o.caption(curves.front().plant));
        if (args->passivity) {
            NormalizedPlant widest = curves.front().plant;
            for (const auto& c : curves)
                if (c.plant.delta > widest.delta) widest = c.plant;
            const svg::Style style{"#2ca02c", 1, "", "#2ca02c", 0.3};
            if (!passivity_is_covered(widest)) {
                ax.legend_line("passive: not covered (fractional delay)", style);
            } else if (widest.delta > 0) {
                svg::Polyline set;
                for (const PassivePoint& p : passive_polygon(widest, 64)) set.emplace_back(p.alpha, p.beta);
                ax.polygon(scaled(set, sx, sy), style, "passivity",
                           "passive: \u03b4 > max R(\u03b8), d = " +
                               std::to_string(static_cast<int>(std::lround(widest.delay))));
                ax.legend_line("passive (" + o.corner_label(widest) + ")", style);
            } else {
                ax.legend_line("passive: none (\u03b4 = 0)", style);
            }
        }
        int index = 0;
        for (const auto& c : curves) {
            svg::Style style{svg::color(index), 1.5, index % 2 ? "6 3" : "", "none", 1};
            const std::string label = o.corner_label(c.plant);
            ax.polyline(scaled(c.points, sx, sy), style, "boundary", label);
            ax.marker(c.region.alpha_max() * sx, c.region.beta_at_alpha_max() * sy, svg::MarkerShape::Circle,
                      svg::Style{svg::color(index), 1.2, "", "none", 1}, "alpha-max", "alpha_max " + label, 4);
            ax.legend_line(label, style);
            ++index;
        }
        ax.legend_marker("\u03b1_max (tip)", svg::MarkerShape::Circle, svg::Style{"#000000", 1.2, "", "none", 1});
        return save_figure(doc, o, start);
    };
}

}  // namespace hapticopt::cli
