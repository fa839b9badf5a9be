// SPDX-License-Identifier: Apache-2.0
// Shared pieces of the figures of `hapticopt plot` and `hapticd experiment`: the plant and output options,
// normalised or physical axes, the standard panel layout and the exact stability boundary as a closed curve.
#pragma once

#include <CLI/CLI.hpp>
#include <chrono>
#include <string>
#include <vector>

#include <hapticopt/parameters.hpp>

#include "svg/svg_contour.hpp"
#include "svg/svg_writer.hpp"

namespace hapticopt {
class StabilityRegion;  // stability_region.hpp (kept out of this header: it is Eigen-heavy)
}  // namespace hapticopt

namespace hapticopt::cli {

/// Options common to every figure. Normalised by default (--gamma --delta --delay); physical when
/// --mass and --period are given (--time-delay, --stiffness k, --damping b), which also switches the
/// gain axes to K [N/m] and B [N s/m] (K = alpha m / T^2, B = beta m / T) and time to milliseconds.
struct FigureOptions {
    std::string out;
    double width = 800, height = 600;
    std::vector<double> gamma{0.0}, delta{0.0}, stiffness{0.0}, damping{0.0};
    double delay = 0, mass = 0, period = 0, time_delay = 0;
    CLI::Option* mass_option = nullptr;

    /// Registers the options; with `corner_lists` --gamma/--delta (--stiffness/--damping) take several
    /// values and every combination is one plant (the corners of a parameter box).
    void add_to(CLI::App& app, bool corner_lists = false, double default_height = 600);
    bool physical() const { return mass_option != nullptr && mass_option->count() > 0; }
    /// Every (gamma, delta) corner, normalised; the first one is the plant of single-plant figures.
    std::vector<NormalizedPlant> plants() const;
    NormalizedPlant plant() const { return plants().front(); }
    double k_scale() const { return physical() ? mass / (period * period) : 1.0; }  ///< alpha -> axis
    double b_scale() const { return physical() ? mass / period : 1.0; }             ///< beta -> axis
    double t_scale() const { return physical() ? period * 1e3 : 1.0; }              ///< t/T -> axis
    std::string alpha_label() const { return physical() ? "stiffness K [N/m]" : "\u03b1 = K T\u00b2/m"; }
    std::string beta_label() const { return physical() ? "damping B [N s/m]" : "\u03b2 = B T/m"; }
    std::string time_label() const { return physical() ? "time t [ms]" : "time t/T"; }
    /// "d = 1, γ = 0, δ = 0" or "m = 0.3 kg, T = 1 ms, t_d = 1 ms, k = 0 N/m, b = 0 N s/m".
    std::string caption(const NormalizedPlant& p) const;
    /// The plant's corner label for legends: "γ = 0, δ = 0.02" or "k = 0 N/m, b = 6 N s/m".
    std::string corner_label(const NormalizedPlant& p) const;
};

/// --curve-points (4..10000, default shown): points sampled on each optimal curve of a figure.
void add_curve_points_option(CLI::App& app, int& points);

/// Number formatting for labels: %.4g.
std::string short_number(double value);

/// The exact boundary of the stable region as a closed curve in normalised units: `points` samples
/// of the complex-root branch (StabilityRegion::polygon), the tip (alpha_max) inserted in frequency
/// order, the segment on alpha = -gamma, and the first point repeated.
svg::Polyline boundary_curve(const StabilityRegion& region, int points = 400);

/// `count` alphas spread over (alpha_min, alpha_max), both ends excluded by a 1e-6 relative margin.
std::vector<double> alpha_samples(const StabilityRegion& region, int count);

/// Scales (alpha, beta) points to the axes' units.
svg::Polyline scaled(const svg::Polyline& points, double sx, double sy);

/// The standard single-panel layout (margins for ticks and labels).
svg::Axes& main_axes(svg::Document& doc, const FigureOptions& o, std::pair<double, double> x_domain,
                     std::pair<double, double> y_domain, std::string x_label, std::string y_label, std::string title,
                     double top_fraction = 1.0);

/// Writes the document and reports the file and the elapsed time on stdout; returns 0 (success).
int save_figure(const svg::Document& doc, const FigureOptions& o, std::chrono::steady_clock::time_point start);

}  // namespace hapticopt::cli
