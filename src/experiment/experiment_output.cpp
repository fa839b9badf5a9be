// SPDX-License-Identifier: Apache-2.0
#include "experiment/experiment_output.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <stdexcept>

#include "svg/svg_figure.hpp"

namespace hapticd::experiment {

namespace svg = hapticopt::cli::svg;

namespace {

std::string num(double v) {
    if (std::isnan(v)) return "nan";
    char b[40];
    std::snprintf(b, sizeof b, "%.17g", v);
    return b;
}

std::string short_num(double v) { return hapticopt::cli::short_number(v); }

class CsvFile {
  public:
    CsvFile(const std::string& path, const std::string& header) : path_(path), out_(path) {
        if (!out_) throw std::runtime_error("cannot open '" + path + "' for writing");
        out_ << header << "\n";
    }
    std::ofstream& out() { return out_; }
    void close() {
        out_.close();
        if (!out_) throw std::runtime_error("writing '" + path_ + "' failed");
    }

  private:
    std::string path_;
    std::ofstream out_;
};

const char* kTrialHeader =
    "index,phase,K_N_per_m,B_Ns_per_m,step_force_N,outcome,unstable,ticks,max_growth,max_abs_force_N,max_abs_position_"
    "m";

void trial_columns(std::ofstream& o, const TrialRow& r) {
    o << r.index << "," << r.phase << "," << num(r.K) << "," << num(r.B) << "," << num(r.step_force) << ","
      << to_string(r.outcome) << "," << (counts_as_unstable(r.outcome) ? 1 : 0) << "," << r.ticks << ","
      << num(r.max_growth) << "," << num(r.max_abs_force) << "," << num(r.max_abs_position);
}

const svg::Style kBoundaryStyle{"#000000", 1.5, "", "none", 1};

// The panel: K across, B up, domain covering the analysed boundary and every measured point; the analysed
// boundary drawn with its legend entry.
svg::Axes& figure_axes(svg::Document& doc, const Theory& theory, const std::vector<std::pair<double, double>>& measured,
                       const std::string& title) {
    const svg::Polyline boundary = theory.boundary_polyline();
    double x1 = 0, y1 = 0;
    for (const auto& [k, b] : boundary) {
        x1 = std::max(x1, k);
        y1 = std::max(y1, b);
    }
    for (const auto& [k, b] : measured) {
        if (std::isfinite(k)) x1 = std::max(x1, k);
        if (std::isfinite(b)) y1 = std::max(y1, b);
    }
    hapticopt::cli::FigureOptions o;
    o.width = 800;
    o.height = 600;
    svg::Axes& ax = hapticopt::cli::main_axes(doc, o, {0.0, x1 * 1.05}, {0.0, y1 * 1.05}, "stiffness K [N/m]",
                                              "damping B [N s/m]", title);
    ax.polyline(boundary, kBoundaryStyle, "boundary", "analysis");
    ax.legend_line("stability boundary (analysis)", kBoundaryStyle);
    return ax;
}

// The output directory (created) and the files written into it, in order.
class OutputFiles {
  public:
    explicit OutputFiles(const std::string& dir) : base_(dir) {
        std::error_code ec;
        std::filesystem::create_directories(dir, ec);
        if (ec) throw std::runtime_error("cannot create the output directory '" + dir + "': " + ec.message());
    }
    // <dir>/<name>: `header`, then the rows `write_rows(std::ofstream&)` prints.
    template <class WriteRows>
    void csv(const char* name, const std::string& header, WriteRows&& write_rows) {
        const std::string path = (base_ / name).string();
        CsvFile f(path, header);
        write_rows(f.out());
        f.close();
        written_.push_back(path);
    }
    void figure(const char* name, const svg::Document& doc) {
        const std::string path = (base_ / name).string();
        doc.save(path);
        written_.push_back(path);
    }
    [[nodiscard]] std::vector<std::string> written() const { return written_; }

  private:
    std::filesystem::path base_;
    std::vector<std::string> written_;
};

}  // namespace

std::vector<std::string> write_boundary_outputs(const std::string& dir, const BoundaryResult& result,
                                                const Theory& theory, const FigureCaption& caption) {
    OutputFiles files(dir);
    files.csv("boundary_trials.csv", kTrialHeader, [&](std::ofstream& out) {
        for (const auto& r : result.trials) {
            trial_columns(out, r);
            out << "\n";
        }
    });
    files.csv("boundary.csv",
              "B_Ns_per_m,K_last_stable_N_per_m,K_first_unstable_N_per_m,K_boundary_N_per_m,K_theory_N_per_m,trials",
              [&](std::ofstream& out) {
                  for (const auto& p : result.points) {
                      out << num(p.B) << "," << num(p.K_last_stable) << "," << num(p.K_first_unstable) << ","
                          << num(p.K_boundary) << "," << num(p.K_theory) << "," << p.trials << "\n";
                  }
              });
    std::vector<std::pair<double, double>> measured;
    for (const auto& p : result.points) measured.emplace_back(p.K_boundary, p.B);
    svg::Document doc(800, 600, "Measured stability boundary, " + caption.text);
    svg::Axes& ax = figure_axes(doc, theory, measured, "Stability boundary: measured vs analysis, " + caption.text);
    const svg::Style marker{"#d62728", 1.5, "", "none", 1};
    for (const auto& p : result.points) {
        if (std::isnan(p.K_boundary)) continue;
        ax.marker(p.K_boundary, p.B, svg::MarkerShape::Circle, marker, "measured-boundary",
                  "B = " + short_num(p.B) + " N s/m", 4);
    }
    ax.legend_marker("measured boundary", svg::MarkerShape::Circle, marker);
    files.figure("boundary.svg", doc);
    return files.written();
}

std::vector<std::string> write_optimal_outputs(const std::string& dir, const OptimalResult& result,
                                               const OptimalSettings& settings, const Theory& theory,
                                               const FigureCaption& caption) {
    OutputFiles files(dir);
    files.csv("optimal_trials.csv", std::string(kTrialHeader) + ",CE0,CE1,CE2,COV,tail_estimate",
              [&](std::ofstream& out) {
                  for (const auto& r : result.trials) {
                      trial_columns(out, r);
                      const double nan = std::nan("");
                      const MeasuredCosts& c = r.costs;
                      out << "," << num(r.has_costs ? c.ce0 : nan) << "," << num(r.has_costs ? c.ce1 : nan) << ","
                          << num(r.has_costs ? c.ce2 : nan) << "," << num(r.has_costs ? c.overshoot : nan) << ","
                          << num(r.has_costs ? c.tail_estimate : nan) << "\n";
                  }
              });
    files.csv(
        "optimal.csv",
        "K_N_per_m,criterion,B_grid_Ns_per_m,cost_grid,B_refined_Ns_per_m,B_theory_Ns_per_m,B_step_Ns_per_m,on_edge",
        [&](std::ofstream& out) {
            for (const auto& p : result.points) {
                out << num(p.K) << "," << p.criterion_name() << "," << num(p.B_grid) << "," << num(p.cost_grid) << ","
                    << num(p.B_refined) << "," << num(p.B_theory) << "," << num(p.b_step) << "," << (p.on_edge ? 1 : 0)
                    << "\n";
            }
        });
    std::vector<std::pair<double, double>> measured;
    for (const auto& p : result.points) measured.emplace_back(p.K, p.B_refined);
    svg::Document doc(800, 600, "Measured optimal curves, " + caption.text);
    svg::Axes& ax = figure_axes(doc, theory, measured, "Optimal B per K: measured vs analysis, " + caption.text);
    // Theory curves over the K range of the grid (the optimal curve is defined inside the region).
    double k_lo = HUGE_VAL, k_hi = 0;
    for (const double K : settings.k_values) {
        k_lo = std::min(k_lo, K);
        k_hi = std::max(k_hi, K);
    }
    const svg::MarkerShape shapes[3] = {svg::MarkerShape::Square, svg::MarkerShape::Diamond, svg::MarkerShape::Circle};
    for (int c = 0; c < 3 && k_hi > 0; ++c) {
        const svg::Style style{svg::color(c + 1), 1.5, "6 3", "none", 1};
        svg::Polyline curve;
        constexpr int kSamples = 60;
        for (int i = 0; i <= kSamples; ++i) {
            const double K = k_lo + (k_hi - k_lo) * i / kSamples;
            curve.emplace_back(K, theory.optimal_damping(c, K));
        }
        const std::string name = "CE" + std::to_string(c);
        ax.polyline(curve, style, "optimal-" + name, name + " optimal curve (analysis)");
        ax.legend_line("C_E" + std::to_string(c) + " optimal curve (analysis)", style);
        const svg::Style marker{svg::color(c + 1), 1.5, "", "none", 1};
        for (const auto& p : result.points) {
            if (p.criterion != c) continue;
            ax.marker(p.K, p.B_refined, shapes[c], marker, "measured-" + name, name + " K = " + short_num(p.K), 4);
        }
        ax.legend_marker("C_E" + std::to_string(c) + " measured optimum", shapes[c], marker);
    }
    const svg::Style plus{"#7f7f7f", 1.2, "", "none", 1};
    bool any_plus = false;
    for (const auto& r : result.trials) {
        if (r.has_costs && r.costs.overshoot <= settings.overshoot_tolerance) {
            ax.marker(r.K, r.B, svg::MarkerShape::Plus, plus, "no-overshoot", "", 3);
            any_plus = true;
        }
    }
    if (any_plus)
        ax.legend_marker("no overshoot (C_OV <= " + short_num(settings.overshoot_tolerance) + ")",
                         svg::MarkerShape::Plus, plus);
    files.figure("optimal.svg", doc);
    return files.written();
}

}  // namespace hapticd::experiment
