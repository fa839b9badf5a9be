// SPDX-License-Identifier: Apache-2.0
// A small SVG writer for the `hapticopt plot` figures: linear scales with "nice" ticks, axes with
// tick labels and axis labels, polylines, filled polygons, markers and a legend.
//
// Output conventions (the tests in tests/plots parse them):
//  - every coordinate is written with two decimals (rounding error <= 0.005 px per coordinate);
//  - a panel is <g class="panel" id="panel-NAME">; inside it x ticks are <line class="tick-x" x1=..>
//    with a <text class="tick-label-x" x=..>LABEL</text> (y likewise, class "tick-y"/"tick-label-y",
//    position in y1/y); labels are the exact decimal values of the tick positions;
//  - a data series is <polyline class="series CLASS" data-label="LABEL" points="x,y x,y ..."/>;
//  - a marker is <g class="marker CLASS" data-label="LABEL" transform="translate(x,y)">..</g>, its
//    centre at the translation.
#pragma once

#include <memory>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace hapticopt::cli::svg {

/// Escapes &, <, >, " and ' for text content and attribute values.
std::string escape(std::string_view text);

/// A coordinate with two decimals ("-0.00" is written "0.00").
std::string coord(double value);

/// Ticks of a "nice" step (1, 2, 2.5 or 5 times a power of ten) covering [lo, hi] with about
/// `count` intervals.
struct Ticks {
    double step = 1;
    std::vector<double> values;       ///< tick positions inside [lo, hi] (multiples of step)
    std::vector<std::string> labels;  ///< the same values as exact decimals with the step's digits
};
Ticks nice_ticks(double lo, double hi, int count = 6);

/// [lo, hi] widened to the nearest multiples of the nice step (padding a degenerate interval).
std::pair<double, double> nice_domain(double lo, double hi, int count = 6);

/// Affine map of a data interval [d0, d1] to a pixel interval [r0, r1] (r1 < r0 for y axes).
struct LinearScale {
    double d0 = 0, d1 = 1, r0 = 0, r1 = 1;
    double operator()(double value) const { return r0 + (value - d0) * (r1 - r0) / (d1 - d0); }
    double invert(double pixel) const { return d0 + (pixel - r0) * (d1 - d0) / (r1 - r0); }
};

struct Style {
    std::string stroke = "#000000";
    double width = 1.5;
    std::string dash;  ///< stroke-dasharray, empty for a solid line
    std::string fill = "none";
    double opacity = 1.0;  ///< fill opacity
};

enum class MarkerShape { Plus, Cross, Circle, Square, Diamond };

class Document;

/// One plot panel: a frame at (left, top, width, height) in the document with ticked, labelled axes.
class Axes {
  public:
    void polyline(const std::vector<std::pair<double, double>>& points, const Style& style, std::string_view css_class,
                  std::string_view label = {});
    /// A closed, filled polygon (drawn under the series; e.g. a region).
    void polygon(const std::vector<std::pair<double, double>>& points, const Style& style, std::string_view css_class,
                 std::string_view label = {});
    void marker(double x, double y, MarkerShape shape, const Style& style, std::string_view css_class,
                std::string_view label = {}, double size = 6);
    /// A text at data coordinates, offset by (dx, dy) pixels.
    void text(double x, double y, std::string_view content, double dx = 6, double dy = -6);
    /// Adds an entry to the legend (line sample, or a marker when `shape` is given).
    void legend_line(std::string_view label, const Style& style);
    void legend_marker(std::string_view label, MarkerShape shape, const Style& style);
    /// Where the legend box goes: "top-right", "top-left", "bottom-right", "bottom-left".
    void set_legend_position(std::string position) { legend_position_ = std::move(position); }

    const LinearScale& x() const { return x_; }
    const LinearScale& y() const { return y_; }

  private:
    friend class Document;
    struct LegendEntry {
        std::string label;
        Style style;
        bool is_marker = false;
        MarkerShape shape = MarkerShape::Plus;
    };
    std::string name_, title_, x_label_, y_label_, legend_position_ = "top-right";
    double left_ = 0, top_ = 0, width_ = 0, height_ = 0;
    LinearScale x_, y_;
    Ticks x_ticks_, y_ticks_;
    std::string under_, body_;  // filled regions, then series and markers
    std::vector<LegendEntry> legend_;
    std::string render(int index) const;
};

/// An SVG document of fixed pixel size holding one or more panels.
class Document {
  public:
    Document(double width, double height, std::string title);
    /// Adds a panel; x/y domains are widened to nice ticks. The reference stays valid until save().
    Axes& add_axes(std::string name, double left, double top, double width, double height,
                   std::pair<double, double> x_domain, std::pair<double, double> y_domain, std::string x_label,
                   std::string y_label, std::string title = {});
    /// The whole document as text.
    std::string str() const;
    /// Writes the document; throws std::runtime_error when the file cannot be written.
    void save(const std::string& path) const;

  private:
    double width_, height_;
    std::string title_;
    std::vector<std::unique_ptr<Axes>> axes_;
};

/// The i-th colour of a qualitative palette (cycles).
std::string color(int index);

/// Marker path (centred on 0,0) for a shape of half-size `size`.
std::string marker_path(MarkerShape shape, double size);

}  // namespace hapticopt::cli::svg
