// SPDX-License-Identifier: Apache-2.0
// hapticopt plot step: continuous-time step responses x(t)/x_inf at the optima of chosen criteria
// (Fig. 5 of the paper), each maximum overshoot marked where it falls inside the time span.
//
// The response is evaluated exactly (step_response.hpp) at --samples points per period; the marker
// is at the exact continuous-time maximum (overshoot.hpp: time and C_OV), not at a sample.
#include <algorithm>
#include <chrono>
#include <memory>

#include <hapticopt/criterion.hpp>
#include <hapticopt/optimum.hpp>
#include <hapticopt/step_response.hpp>

#include "commands.hpp"
#include "criterion_option.hpp"
#include "svg/svg_figure.hpp"

namespace hapticopt::cli {

CommandRunner add_plot_step(CLI::App& plot) {
    struct Args {
        FigureOptions fig;
        std::vector<Criterion> criteria{Criterion::CE0, Criterion::CE1, Criterion::CE2};
        double duration = 30, tolerance = 1e-12;
        int samples = 20;
    };
    auto args = std::make_shared<Args>();
    CLI::App* sub = plot.add_subcommand("step", "step responses at the optima of criteria, overshoot marked (Fig. 5)");
    args->fig.add_to(*sub);
    add_criteria_option(*sub, "--criteria,-c", args->criteria, kAllCriteria,
                        "criteria whose optima are shown (amax OV CE0 CE1 CE2 CEx+OV)");
    sub->add_option("--duration", args->duration, "time span in periods T")
        ->capture_default_str()
        ->check(CLI::Range(1.0, 1e5));
    sub->add_option("--samples", args->samples, "samples per period")
        ->capture_default_str()
        ->check(CLI::Range(1, 1000));
    sub->add_option("--overshoot-tol", args->tolerance, "relative overshoot counted as none, (0, 1]")
        ->capture_default_str()
        ->check(CLI::Range(1e-300, 1.0));
    return [args]() {
        const auto start = std::chrono::steady_clock::now();
        const FigureOptions& o = args->fig;
        const double st = o.t_scale();
        const NormalizedPlant plant = o.plant();
        OptimumOptions options;
        options.overshoot_tolerance = args->tolerance;
        const WallOptimizer optimizer(plant, options);
        std::vector<double> times;
        const auto count = static_cast<long long>(args->duration * args->samples);
        for (long long i = 0; i <= count; ++i)
            times.push_back(args->duration * static_cast<double>(i) / static_cast<double>(count));

        struct Curve {
            std::string name;
            Optimum opt;
            svg::Polyline points;
            OvershootResult ov;
        };
        std::vector<Curve> curves;
        double y_max = 1.0;
        for (const Criterion criterion : args->criteria) {
            Curve c{std::string(to_string(criterion)), optimizer.optimum(criterion), {}, {}};
            const double x_inf = 1.0 / (c.opt.alpha + plant.gamma);  // F = 1 in normalised units
            for (const auto& p : step_response(optimizer.sampled_plant(), c.opt.alpha, c.opt.beta, times)) {
                c.points.emplace_back(p.time * st, p.position / x_inf);
                y_max = std::max(y_max, p.position / x_inf);
            }
            OvershootOptions ovo;
            ovo.tolerance = args->tolerance;
            c.ov = overshoot(optimizer.sampled_plant(), c.opt.alpha, c.opt.beta, ovo);
            curves.push_back(std::move(c));
        }
        svg::Document doc(o.width, o.height, "Step responses at the optima, " + o.caption(plant));
        svg::Axes& ax = main_axes(doc, o, {0.0, args->duration * st}, {0.0, y_max * 1.05}, o.time_label(),
                                  "position x / x\u221e", "Step responses at the optima, " + o.caption(plant));
        ax.set_legend_position("bottom-right");
        ax.polyline({{0.0, 1.0}, {args->duration * st, 1.0}}, svg::Style{"#7f7f7f", 1, "4 3", "none", 1}, "final-value",
                    "x = x\u221e");
        int index = 0;
        for (const Curve& c : curves) {
            const svg::Style style{svg::color(index), 1.8, "", "none", 1};
            const std::string label = c.name + ": " + (o.physical() ? "K " : "\u03b1 ") +
                                      short_number(c.opt.alpha * o.k_scale()) + (o.physical() ? ", B " : ", \u03b2 ") +
                                      short_number(c.opt.beta * o.b_scale()) + ", OV " + short_number(c.ov.value);
            ax.polyline(c.points, style, "step-response", c.name);
            if (c.ov.value > args->tolerance && c.ov.time <= args->duration) {
                ax.marker(c.ov.time * st, 1 + c.ov.value, svg::MarkerShape::Circle,
                          svg::Style{svg::color(index), 1.5, "", "none", 1}, "overshoot", c.name, 5);
            }
            ax.legend_line(label, style);
            ++index;
        }
        ax.legend_marker("maximum overshoot", svg::MarkerShape::Circle, svg::Style{"#000000", 1.5, "", "none", 1});
        return save_figure(doc, o, start);
    };
}

}  // namespace hapticopt::cli
