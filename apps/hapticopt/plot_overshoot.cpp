// SPDX-License-Identifier: Apache-2.0
// hapticopt plot overshoot: the region without overshoot (C_OV <= tolerance) inside the stable region,
// the optimal curves of C_E0, C_E1, C_E2 over it and their C_Ex+OV points (Fig. 6 of the paper), and
// the OV point (largest alpha without overshoot).
//
// The no-overshoot region at each of --alphas stiffnesses between alpha_min and the OV point: the
// first and last of --betas grid betas of the stable interval without overshoot, each widened by
// bisection (to 1e-9 in beta) against its outer neighbour; where no grid beta qualifies (near the
// tip), the beta of least overshoot (optimal_beta of C_OV) is tried instead. This assumes the no-overshoot betas form
// one interval at each alpha (true on every plant tried; a gap narrower than the beta grid would be
// missed). The scan starts one step above alpha_min (the region's left end is not drawn).
// Run time: about alphas x (betas + 60) overshoot evaluations.
#include <algorithm>
#include <array>
#include <chrono>
#include <memory>

#include <hapticopt/optimum.hpp>

#include "commands.hpp"
#include "svg/svg_figure.hpp"

namespace hapticopt::cli {

CommandRunner add_plot_overshoot(CLI::App& plot) {
    struct Args {
        FigureOptions fig;
        double tolerance = 1e-12;
        int alphas = 80, betas = 48, curve_points = 60;
    };
    auto args = std::make_shared<Args>();
    CLI::App* sub =
        plot.add_subcommand("overshoot", "no-overshoot region, CE0..2 optimal curves, CEx+OV points (Fig. 6)");
    args->fig.add_to(*sub);
    sub->add_option("--overshoot-tol", args->tolerance, "relative overshoot counted as none, (0, 1]")
        ->capture_default_str()
        ->check(CLI::Range(1e-300, 1.0));
    sub->add_option("--alphas", args->alphas, "stiffnesses sampled across the no-overshoot region")
        ->capture_default_str()
        ->check(CLI::Range(4, 100000));
    sub->add_option("--betas", args->betas, "grid betas per stiffness")
        ->capture_default_str()
        ->check(CLI::Range(4, 100000));
    add_curve_points_option(*sub, args->curve_points);
    return [args]() {
        const auto start = std::chrono::steady_clock::now();
        const FigureOptions& o = args->fig;
        const double sx = o.k_scale(), sy = o.b_scale();
        const NormalizedPlant plant = o.plant();
        OptimumOptions options;
        options.overshoot_tolerance = args->tolerance;
        const WallOptimizer optimizer(plant, options);
        const StabilityRegion& region = optimizer.region();
        const Optimum ov_point = optimizer.optimum(Criterion::Overshoot);
        // Slowly decaying points (a real pole near 1, e.g. at tiny alpha) can need millions of periods for
        // the proven stop; a point not proven within 2e5 periods counts as "not without overshoot".
        OvershootOptions ovo;
        ovo.tolerance = args->tolerance;
        ovo.max_periods = 200000;
        auto ok = [&](double a, double b) { return overshoot(optimizer.sampled_plant(), a, b, ovo).within_tolerance; };

        svg::Polyline lower, upper;
        const double a0 = region.alpha_min(), a1 = ov_point.alpha;
        for (int i = 0; i < args->alphas; ++i) {
            const double a = a0 + (a1 - a0) * (i + 1.0 - 1e-6) / args->alphas;  // from (a1 - a0)/alphas to a1
            const auto [lo, hi] = region.beta_range(a);
            const int n = args->betas;
            auto beta_at = [&](int j) { return lo + (hi - lo) * (j + 0.5) / n; };
            int first = -1, last = -1;
            for (int j = 0; j < n; ++j) {
                if (ok(a, beta_at(j))) {
                    if (first < 0) first = j;
                    last = j;
                }
            }
            auto edge = [&](double inside, double outside) {
                for (int it = 0; it < 80 && std::abs(outside - inside) > 1e-9; ++it) {
                    const double mid = (inside + outside) / 2;
                    (ok(a, mid) ? inside : outside) = mid;
                }
                return inside;
            };
            if (first < 0) {
                // Near the tip the interval is narrower than the grid: try the beta of least overshoot.
                const double b = optimizer.optimal_beta(3, a);
                if (!ok(a, b)) continue;
                lower.emplace_back(a, edge(b, lo));
                upper.emplace_back(a, edge(b, hi));
                continue;
            }
            lower.emplace_back(a, edge(beta_at(first), first > 0 ? beta_at(first - 1) : lo));
            upper.emplace_back(a, edge(beta_at(last), last < n - 1 ? beta_at(last + 1) : hi));
        }
        svg::Polyline no_overshoot = lower;
        no_overshoot.emplace_back(ov_point.alpha, ov_point.beta);
        no_overshoot.insert(no_overshoot.end(), upper.rbegin(), upper.rend());

        const svg::Polyline boundary = boundary_curve(region);
        double b_lo = HUGE_VAL, b_hi = -HUGE_VAL;
        for (const auto& p : boundary) {
            b_lo = std::min(b_lo, p.second);
            b_hi = std::max(b_hi, p.second);
        }
        svg::Document doc(o.width, o.height, "Optimal curves and the no-overshoot region, " + o.caption(plant));
        svg::Axes& ax =
            main_axes(doc, o, {a0 * sx, region.alpha_max() * 1.05 * sx}, {b_lo * sy, b_hi * 1.05 * sy}, o.alpha_label(),
                      o.beta_label(), "Optimal curves over the no-overshoot region, " + o.caption(plant));
        const svg::Style region_style{"#2ca02c", 1.2, "", "#2ca02c", 0.25};
        ax.polygon(scaled(no_overshoot, sx, sy), region_style, "no-overshoot",
                   "C_OV <= " + short_number(args->tolerance));
        ax.legend_line("no overshoot (C_OV \u2264 " + short_number(args->tolerance) + ")", region_style);
        const svg::Style boundary_style{"#000000", 1.5, "", "none", 1};
        ax.polyline(scaled(boundary, sx, sy), boundary_style, "boundary", "stability boundary");
        ax.legend_line("stability boundary", boundary_style);
        const std::array<Criterion, 3> with_ov{Criterion::CE0_OV, Criterion::CE1_OV, Criterion::CE2_OV};
        for (int k = 0; k < 3; ++k) {
            const std::string name = "CE" + std::to_string(k);
            const svg::Style style{svg::color(k), 1.8, "", "none", 1};
            svg::Polyline curve;
            for (const double a : alpha_samples(region, args->curve_points))
                curve.emplace_back(a, optimizer.optimal_beta(k, a));
            ax.polyline(scaled(curve, sx, sy), style, "optimal-curve", name);
            const Optimum p = optimizer.optimum(with_ov[static_cast<std::size_t>(k)]);
            ax.marker(p.alpha * sx, p.beta * sy, svg::MarkerShape::Plus, svg::Style{svg::color(k), 2.2, "", "none", 1},
                      "ce-ov", name + "+OV", 7);
            ax.legend_line(name + " optimal curve", style);
            ax.legend_marker(name + "+OV: " + (o.physical() ? "K " : "\u03b1 ") + short_number(p.alpha * sx) +
                                 (o.physical() ? ", B " : ", \u03b2 ") + short_number(p.beta * sy),
                             svg::MarkerShape::Plus, svg::Style{svg::color(k), 2.2, "", "none", 1});
        }
        ax.marker(ov_point.alpha * sx, ov_point.beta * sy, svg::MarkerShape::Diamond,
                  svg::Style{"#000000", 1.5, "", "none", 1}, "ov-point", "OV", 5);
        ax.legend_marker("OV point (largest \u03b1 without overshoot)", svg::MarkerShape::Diamond,
                         svg::Style{"#000000", 1.5, "", "none", 1});
        return save_figure(doc, o, start);
    };
}

}  // namespace hapticopt::cli
