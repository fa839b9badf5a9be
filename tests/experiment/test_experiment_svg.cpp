// SPDX-License-Identifier: Apache-2.0
// The experiment figures' content: the measured markers sit at the CSV values and the theory path lies on
// the library's stability boundary. Plain string scanning (no std::regex).
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "experiment/experiment_output.hpp"
#include "experiment_fixture.hpp"

namespace hapticd::experiment::test {
namespace {

std::string slurp(const std::filesystem::path& p) {
    std::ifstream in(p);
    std::stringstream s;
    s << in.rdbuf();
    return s.str();
}

// The value of attribute `name` of the element starting at `pos`.
std::string attribute(const std::string& svg, std::size_t pos, const std::string& name) {
    const std::size_t end = svg.find('>', pos);
    const std::size_t at = svg.find(" " + name + "=\"", pos);
    if (at == std::string::npos || at > end) return {};
    const std::size_t begin = at + name.size() + 3;
    return svg.substr(begin, svg.find('"', begin) - begin);
}

// Pixel -> data map of one axis from its tick labels (<text class="tick-label-x" x="..">VALUE</text>).
struct AxisMap {
    double p0 = 0, v0 = 0, p1 = 1, v1 = 1;
    [[nodiscard]] double data(double pixel) const { return v0 + (pixel - p0) * (v1 - v0) / (p1 - p0); }
    [[nodiscard]] double per_pixel() const { return std::abs((v1 - v0) / (p1 - p0)); }
};

AxisMap axis_map(const std::string& svg, char axis) {
    const std::string tag = std::string("<text class=\"tick-label-") + axis + "\"";
    std::vector<std::pair<double, double>> ticks;
    for (std::size_t pos = svg.find(tag); pos != std::string::npos; pos = svg.find(tag, pos + 1)) {
        const double pixel = std::stod(attribute(svg, pos, axis == 'x' ? "x" : "y"));
        const std::size_t text = svg.find('>', pos) + 1;
        ticks.emplace_back(pixel, std::stod(svg.substr(text, svg.find('<', text) - text)));
    }
    EXPECT_GE(ticks.size(), 2U);
    return {ticks.front().first, ticks.front().second, ticks.back().first, ticks.back().second};
}

std::vector<std::pair<double, double>> markers(const std::string& svg, const std::string& css) {
    std::vector<std::pair<double, double>> out;
    const std::string tag = "<g class=\"marker " + css + "\"";
    for (std::size_t pos = svg.find(tag); pos != std::string::npos; pos = svg.find(tag, pos + 1)) {
        const std::string t = attribute(svg, pos, "transform");  // translate(x,y)
        const std::size_t comma = t.find(',');
        out.emplace_back(std::stod(t.substr(10, comma - 10)), std::stod(t.substr(comma + 1)));
    }
    return out;
}

std::vector<std::pair<double, double>> polyline(const std::string& svg, const std::string& css) {
    std::vector<std::pair<double, double>> out;
    const std::size_t pos = svg.find("<polyline class=\"series " + css + "\"");
    if (pos == std::string::npos) return out;
    std::istringstream points(attribute(svg, pos, "points"));
    std::string pair;
    while (points >> pair) {
        const std::size_t comma = pair.find(',');
        out.emplace_back(std::stod(pair.substr(0, comma)), std::stod(pair.substr(comma + 1)));
    }
    return out;
}

TEST(ExperimentSvg, MarkersAtTheCsvValuesAndTheTheoryPathOnTheLibraryBoundary) {
    const Plant plant{0.3, 3.0, 200.0, 1.0, 1, 1e-3};
    const Theory theory(plant.theory());
    auto sim = make_sim(plant);
    TrialRunner runner(*sim, 1'000'000, true);
    ExperimentSetup setup = make_setup(plant, theory, 2000);
    setup.settle.home = runner.read_position(0);
    const double b_tip = theory.damping_at_max_stiffness();
    const BoundarySettings s = k_sweep(theory, {0.3 * b_tip, b_tip, 1.4 * b_tip}, 10.0, 16.0);
    const BoundaryResult r = run_boundary_quietly(runner, setup, s, theory);
    ASSERT_EQ(r.abort.outcome, TrialOutcome::Stable);
    const auto dir = std::filesystem::temp_directory_path() / ("hapticd_experiment_svg_" + std::to_string(::getpid()));
    write_boundary_outputs(dir.string(), r, theory, FigureCaption{"test"});

    // The CSV's boundary points (B, K_boundary) read back.
    std::ifstream csv(dir / "boundary.csv");
    std::string line;
    std::getline(csv, line);
    ASSERT_EQ(line.rfind("B_Ns_per_m,", 0), 0U);
    std::vector<std::pair<double, double>> rows;
    while (std::getline(csv, line)) {
        std::vector<double> v;
        std::stringstream ls(line);
        std::string field;
        while (std::getline(ls, field, ',')) v.push_back(std::stod(field));
        rows.emplace_back(v[3], v[0]);  // (K_boundary, B)
    }
    ASSERT_EQ(rows.size(), 3U);

    const std::string svg = slurp(dir / "boundary.svg");
    const AxisMap x = axis_map(svg, 'x'), y = axis_map(svg, 'y');
    const auto measured = markers(svg, "measured-boundary");
    ASSERT_EQ(measured.size(), rows.size());
    for (std::size_t i = 0; i < rows.size(); ++i) {  // coordinates are written with 2 decimals: +-0.005 px
        EXPECT_NEAR(x.data(measured[i].first), rows[i].first, 0.01 * x.per_pixel());
        EXPECT_NEAR(y.data(measured[i].second), rows[i].second, 0.01 * y.per_pixel());
    }
    // Every point of the theory path, away from the K = 0 segment, has stable and unstable gains within
    // 2 px of it: it is on the library's stability boundary to the drawing's resolution.
    const auto path = polyline(svg, "boundary");
    ASSERT_GT(path.size(), 100U);
    int checked = 0;
    for (const auto& [px, py] : path) {
        const double K = x.data(px), B = y.data(py);
        if (K < 0.02 * theory.max_stiffness()) continue;
        const double dk = 2 * x.per_pixel(), db = 2 * y.per_pixel();
        int stable = 0;
        for (const auto& [sk, sb] : {std::pair{-dk, 0.0}, {dk, 0.0}, {0.0, -db}, {0.0, db}})
            stable += theory.is_stable(K + sk, B + sb);
        EXPECT_TRUE(stable > 0 && stable < 4) << "K = " << K << ", B = " << B;
        ++checked;
    }
    EXPECT_GT(checked, 100);
    std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace hapticd::experiment::test
