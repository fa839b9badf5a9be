// SPDX-License-Identifier: Apache-2.0
// hapticopt plot region: the stability boundaries in the (alpha, beta) plane for the corners of a
// (gamma, delta) box (Fig. 3 of the paper), with each region's tip (alpha_max) marked, and optionally
// the passive set of the Colgate-Schenkel condition with the loop delay (passivity.hpp) for comparison.
// With --velocity other than backward: the main stable region of the estimator's loop per corner
// (estimator_region_boundary, estimator_region.hpp; alpha_max is the main region's tip) and the bounding boxes
// of the stable islands not connected to it, drawn separately (class "island").
#include <algorithm>
#include <chrono>
#include <cmath>
#include <memory>
#include <string>

#include <hapticopt/estimator_region.hpp>
#include <hapticopt/passivity.hpp>
#include <hapticopt/stability_region.hpp>
#include <hapticopt/estimator_types.hpp>

#include "cli_output.hpp"

#include "commands.hpp"
#include "svg/svg_figure.hpp"

namespace hapticopt::cli {

CommandRunner add_plot_region(CLI::App& plot) {
    struct Args {
        FigureOptions fig;
        int points = 400;
        bool passivity = false;
        VelocityOption velocity;
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
    args->velocity.add_to(*sub);
    return [args]() {
        const auto start = std::chrono::steady_clock::now();
        const FigureOptions& o = args->fig;
        const double sx = o.k_scale(), sy = o.b_scale();
        const VelocityEstimator estimator = args->velocity.parse(o.physical() ? o.period : 0.0);
        const bool backward = estimator.kind == VelocityEstimatorKind::backward;
        if (!backward && args->passivity) {
            throw InvalidParameter("hapticopt plot region", "velocity", std::nan(""),
                                   "backward with --passivity (the passive set is the backward difference's)");
        }
        struct Curve {
            NormalizedPlant plant;
            double alpha_max, beta_at_alpha_max;
            svg::Polyline points;
            std::vector<StableIsland> islands;
        };
        std::vector<Curve> curves;
        double x0 = 0, x1 = 0, y0 = 0, y1 = 0;
        for (const NormalizedPlant& p : o.plants()) {
            Curve c{p, 0, 0, {}, {}};
            if (backward) {
                const StabilityRegion region(p);
                c.points = boundary_curve(region, args->points);
                c.alpha_max = region.alpha_max();
                c.beta_at_alpha_max = region.beta_at_alpha_max();
            } else {
                const EstimatorStabilityRegion region(p, estimator);
                c.points = estimator_region_boundary(region, std::min(args->points, 100000));
                c.alpha_max = region.alpha_max();
                c.beta_at_alpha_max = region.beta_at_alpha_max();
                c.islands = region.islands();
            }
            for (const auto& [a, b] : c.points) {
                x0 = std::min(x0, a);
                x1 = std::max(x1, a);
                y0 = std::min(y0, b);
                y1 = std::max(y1, b);
            }
            curves.push_back(std::move(c));
        }
        const std::string velocity = backward ? "" : ", velocity " + velocity_text(estimator);
        svg::Document doc(o.width, o.height, "Stability boundaries, " + o.caption(curves.front().plant) + velocity);
        svg::Axes& ax =
            main_axes(doc, o, {x0 * sx, x1 * 1.05 * sx}, {y0 * sy, y1 * 1.05 * sy}, o.alpha_label(), o.beta_label(),
                      "Stability boundaries (stable inside), " + o.caption(curves.front().plant) + velocity);
        if (args->passivity) {
            NormalizedPlant widest = curves.front().plant;
            for (const auto& c : curves)
                if (c.plant.delta > widest.delta) widest = c.plant;
            const svg::Style style{"#2ca02c", 1, "", "#2ca02c", 0.3};
            if (!passivity_is_covered(widest)) {
                ax.legend_line("passive: not covered (delay not an integer 0..1000)", style);
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
        int index = 0, islands = 0;
        for (const auto& c : curves) {
            svg::Style style{svg::color(index), 1.5, index % 2 ? "6 3" : "", "none", 1};
            const std::string label = o.corner_label(c.plant);
            ax.polyline(scaled(c.points, sx, sy), style, "boundary", label);
            ax.marker(c.alpha_max * sx, c.beta_at_alpha_max * sy, svg::MarkerShape::Circle,
                      svg::Style{svg::color(index), 1.2, "", "none", 1}, "alpha-max", "alpha_max " + label, 4);
            ax.legend_line(label, style);
            for (const StableIsland& i : c.islands) {
                ++islands;
                // Clipped to the main regions' frame (an island elsewhere is listed by `boundary --velocity`).
                const double a0 = std::max(i.alpha_min, x0), a1 = std::min(i.alpha_max, x1 * 1.05);
                const double b0 = std::max(i.beta_min, y0), b1 = std::min(i.beta_max, y1 * 1.05);
                if (!(a0 < a1 && b0 < b1)) continue;
                const svg::Polyline box{{a0, b0}, {a1, b0}, {a1, b1}, {a0, b1}};
                ax.polygon(scaled(box, sx, sy), svg::Style{svg::color(index), 1, "2 2", svg::color(index), 0.15},
                           "island", "stable island " + label);
            }
            ++index;
        }
        if (islands > 0) {
            ax.legend_line(std::to_string(islands) + " stable island(s), not connected (bounding boxes)",
                           svg::Style{"#000000", 1, "2 2", "#000000", 0.15});
        }
        ax.legend_marker("\u03b1_max (tip)", svg::MarkerShape::Circle, svg::Style{"#000000", 1.2, "", "none", 1});
        return save_figure(doc, o, start);
    };
}

}  // namespace hapticopt::cli
