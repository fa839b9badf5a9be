// SPDX-License-Identifier: Apache-2.0
#include "svg/svg_figure.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <iostream>

#include <hapticopt/stability_region.hpp>

namespace hapticopt::cli {

void add_curve_points_option(CLI::App& app, int& points) {
    app.add_option("--curve-points", points, "points sampled on each optimal curve")
        ->capture_default_str()
        ->check(CLI::Range(4, 10000));
}

void FigureOptions::add_to(CLI::App& app, bool corner_lists, double default_height) {
    height = default_height;
    app.add_option("--out,-o", out, "SVG file to write")->required();
    app.add_option("--width", width, "image width [px]")->capture_default_str()->check(CLI::Range(200.0, 10000.0));
    app.add_option("--height", height, "image height [px]")->capture_default_str()->check(CLI::Range(200.0, 10000.0));
    CLI::Option* g = app.add_option("--gamma", gamma,
                                    corner_lists ? "normalised k T^2/m, one or more values (>= 0)"
                                                 : "normalised physical stiffness k T^2/m (>= 0)");
    CLI::Option* d = app.add_option(
        "--delta", delta,
        corner_lists ? "normalised b T/m, one or more values (>= 0)" : "normalised physical damping b T/m (>= 0)");
    CLI::Option* delay_opt = app.add_option("--delay", delay, "delay d = t_d/T in periods (>= 0, may be fractional)");
    mass_option = app.add_option("--mass", mass, "moving mass m [kg]: physical axes (K, B, t in ms); needs --period");
    CLI::Option* p = app.add_option("--period", period, "sampling period T [s]");
    CLI::Option* td = app.add_option("--time-delay", time_delay, "loop delay t_d [s]");
    CLI::Option* k =
        app.add_option("--stiffness", stiffness,
                       corner_lists ? "physical stiffness k [N/m], one or more" : "physical stiffness k [N/m]");
    CLI::Option* b = app.add_option(
        "--damping", damping, corner_lists ? "physical damping b [N s/m], one or more" : "physical damping b [N s/m]");
    for (CLI::Option* o : {g, d, k, b}) {
        o->capture_default_str();
        if (corner_lists)
            o->delimiter(',');
        else
            o->expected(1);
    }
    if (corner_lists) {
        gamma = {0.0, 0.001};
        delta = {0.0, 0.02};
        g->default_str("0,0.001");
        d->default_str("0,0.02");
    }
    mass_option->needs(p);
    p->needs(mass_option);
    for (CLI::Option* o : {td, k, b}) o->needs(mass_option);
    for (CLI::Option* o : {g, d, delay_opt}) mass_option->excludes(o);
}

std::vector<NormalizedPlant> FigureOptions::plants() const {
    std::vector<NormalizedPlant> out;
    if (physical()) {
        for (const double kk : stiffness) {
            for (const double bb : damping) out.push_back(normalize(PhysicalPlant{mass, bb, kk, period, time_delay}));
        }
    } else {
        for (const double gg : gamma) {
            for (const double dd : delta) {
                const NormalizedPlant p{gg, dd, delay};
                validate(p, "hapticopt plot");
                out.push_back(p);
            }
        }
    }
    return out;
}

std::string short_number(double value) {
    char buf[64];
    std::snprintf(buf, sizeof buf, "%.4g", value);
    return buf;
}

std::string FigureOptions::caption(const NormalizedPlant& p) const {
    if (physical()) {
        return "m = " + short_number(mass) + " kg, T = " + short_number(period * 1e3) +
               " ms, t_d = " + short_number(time_delay * 1e3) + " ms";
    }
    return "d = " + short_number(p.delay);
}

std::string FigureOptions::corner_label(const NormalizedPlant& p) const {
    if (physical()) {
        return "k = " + short_number(p.gamma * mass / (period * period)) +
               " N/m, b = " + short_number(p.delta * mass / period) + " N s/m";
    }
    return "\u03b3 = " + short_number(p.gamma) + ", \u03b4 = " + short_number(p.delta);
}

svg::Polyline boundary_curve(const StabilityRegion& region, int points) {
    const auto polygon = region.polygon(points);
    svg::Polyline out;
    out.reserve(polygon.size() + 2);
    bool tip_done = false;
    for (std::size_t i = 0; i + 1 < polygon.size(); ++i) {
        if (!tip_done && polygon[i].theta > region.tip_frequency()) {
            out.emplace_back(region.alpha_max(), region.beta_at_alpha_max());
            tip_done = true;
        }
        out.emplace_back(polygon[i].alpha, polygon[i].beta);
    }
    out.emplace_back(polygon.back().alpha, polygon.back().beta);
    out.push_back(out.front());
    return out;
}

std::vector<double> alpha_samples(const StabilityRegion& region, int count) {
    const double a0 = region.alpha_min(), a1 = region.alpha_max(), margin = 1e-6 * (a1 - a0);
    std::vector<double> out;
    for (int i = 0; i < count; ++i) {
        out.push_back(a0 + margin + (a1 - a0 - 2 * margin) * i / std::max(count - 1, 1));
    }
    return out;
}

svg::Polyline scaled(const svg::Polyline& points, double sx, double sy) {
    svg::Polyline out;
    out.reserve(points.size());
    for (const auto& [x, y] : points) out.emplace_back(x * sx, y * sy);
    return out;
}

svg::Axes& main_axes(svg::Document& doc, const FigureOptions& o, std::pair<double, double> x_domain,
                     std::pair<double, double> y_domain, std::string x_label, std::string y_label, std::string title,
                     double top_fraction) {
    constexpr double kLeft = 80, kRight = 24, kTop = 40, kBottom = 56;
    const double h = (o.height - kTop - kBottom) * top_fraction - (top_fraction < 1 ? kBottom : 0);
    return doc.add_axes("main", kLeft, kTop, o.width - kLeft - kRight, h, x_domain, y_domain, std::move(x_label),
                        std::move(y_label), std::move(title));
}

int save_figure(const svg::Document& doc, const FigureOptions& o, std::chrono::steady_clock::time_point start) {
    doc.save(o.out);
    const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    std::printf("wrote %s (%.2f s)\n", o.out.c_str(), seconds);
    return 0;
}

}  // namespace hapticopt::cli
