// SPDX-License-Identifier: Apache-2.0
#include "svg/svg_writer.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <stdexcept>
#include <tuple>

namespace hapticopt::cli::svg {

std::string escape(std::string_view text) {
    std::string out;
    out.reserve(text.size());
    for (const char c : text) {
        switch (c) {
            case '&':
                out += "&amp;";
                break;
            case '<':
                out += "&lt;";
                break;
            case '>':
                out += "&gt;";
                break;
            case '"':
                out += "&quot;";
                break;
            case '\'':
                out += "&apos;";
                break;
            default:
                out += c;
        }
    }
    return out;
}

std::string coord(double value) {
    char buf[64];
    std::snprintf(buf, sizeof buf, "%.2f", value);
    std::string s = buf;
    if (s == "-0.00") s = "0.00";
    return s;
}

std::string color(int index) {
    static const std::array<const char*, 8> kPalette = {"#1f77b4", "#d62728", "#2ca02c", "#ff7f0e",
                                                        "#9467bd", "#8c564b", "#e377c2", "#17becf"};
    return kPalette[static_cast<std::size_t>(index) % kPalette.size()];
}

namespace {

struct Step {
    double step;
    int decimals;
};

Step nice_step(double lo, double hi, int count) {
    const double raw = (hi - lo) / std::max(count, 1);
    const int exponent = static_cast<int>(std::floor(std::log10(raw)));
    const double magnitude = std::pow(10.0, exponent);
    const double r = raw / magnitude;
    double mult = 10;
    for (const double m : {1.0, 2.0, 2.5, 5.0}) {
        if (r <= m * (1 + 1e-9)) {
            mult = m;
            break;
        }
    }
    int decimals = std::max(0, -exponent - (mult == 10 ? 1 : 0));
    if (mult == 2.5 && exponent <= 0) ++decimals;
    return {mult * magnitude, decimals};
}

std::pair<double, double> padded(double lo, double hi) {
    if (hi > lo) return {lo, hi};
    const double pad = std::max(1e-12, std::abs(lo) * 0.1 + (lo == 0 ? 1 : 0));
    return {lo - pad, hi + pad};
}

}  // namespace

Ticks nice_ticks(double lo, double hi, int count) {
    std::tie(lo, hi) = padded(lo, hi);
    const Step s = nice_step(lo, hi, count);
    Ticks t;
    t.step = s.step;
    const auto first = static_cast<long long>(std::ceil(lo / s.step - 1e-9));
    const auto last = static_cast<long long>(std::floor(hi / s.step + 1e-9));
    for (long long k = first; k <= last; ++k) {
        const double v = static_cast<double>(k) * s.step;
        char buf[64];
        std::snprintf(buf, sizeof buf, "%.*f", s.decimals, v);
        std::string label = buf;
        if (label.find_first_not_of("-0.") == std::string::npos && label[0] == '-') label.erase(0, 1);
        t.values.push_back(v);
        t.labels.push_back(label);
    }
    return t;
}

std::pair<double, double> nice_domain(double lo, double hi, int count) {
    std::tie(lo, hi) = padded(lo, hi);
    const double step = nice_step(lo, hi, count).step;
    return {std::floor(lo / step + 1e-9) * step, std::ceil(hi / step - 1e-9) * step};
}

std::string marker_path(MarkerShape shape, double size) {
    const std::string s = coord(size), d = coord(2 * size);
    switch (shape) {
        case MarkerShape::Plus:
            return "M-" + s + " 0H" + s + "M0 -" + s + "V" + s;
        case MarkerShape::Cross:
            return "M-" + s + " -" + s + "L" + s + " " + s + "M-" + s + " " + s + "L" + s + " -" + s;
        case MarkerShape::Square:
            return "M-" + s + " -" + s + "h" + d + "v" + d + "h-" + d + "Z";
        case MarkerShape::Diamond:
            return "M0 -" + s + "L" + s + " 0L0 " + s + "L-" + s + " 0Z";
        case MarkerShape::Circle:
            return "M-" + s + " 0A" + s + " " + s + " 0 1 0 " + s + " 0A" + s + " " + s + " 0 1 0 -" + s + " 0Z";
    }
    return {};
}

namespace {

std::string style_attributes(const Style& style) {
    std::string out = " fill=\"" + escape(style.fill) + "\"";
    if (style.fill != "none" && style.opacity < 1) out += " fill-opacity=\"" + coord(style.opacity) + "\"";
    out += " stroke=\"" + escape(style.stroke) + "\" stroke-width=\"" + coord(style.width) + "\"";
    if (!style.dash.empty()) out += " stroke-dasharray=\"" + escape(style.dash) + "\"";
    return out;
}

std::string label_attribute(std::string_view label) {
    return label.empty() ? std::string{} : " data-label=\"" + escape(label) + "\"";
}

}  // namespace

void Axes::polyline(const std::vector<std::pair<double, double>>& points, const Style& style,
                    std::string_view css_class, std::string_view label) {
    std::string run;
    auto flush = [&] {
        if (!run.empty()) {
            body_ += "<polyline class=\"series " + escape(css_class) + "\"" + label_attribute(label) + " points=\"" +
                     run + "\"" + style_attributes(style) + " stroke-linejoin=\"round\"/>\n";
        }
        run.clear();
    };
    for (const auto& [px, py] : points) {
        if (!std::isfinite(px) || !std::isfinite(py)) {
            flush();
            continue;
        }
        if (!run.empty()) run += ' ';
        run += coord(x_(px)) + "," + coord(y_(py));
    }
    flush();
}

void Axes::polygon(const std::vector<std::pair<double, double>>& points, const Style& style, std::string_view css_class,
                   std::string_view label) {
    std::string run;
    for (const auto& [px, py] : points) {
        if (!std::isfinite(px) || !std::isfinite(py)) continue;
        if (!run.empty()) run += ' ';
        run += coord(x_(px)) + "," + coord(y_(py));
    }
    under_ += "<polygon class=\"region " + escape(css_class) + "\"" + label_attribute(label) + " points=\"" + run +
              "\"" + style_attributes(style) + "/>\n";
}

void Axes::marker(double x, double y, MarkerShape shape, const Style& style, std::string_view css_class,
                  std::string_view label, double size) {
    if (!std::isfinite(x) || !std::isfinite(y)) return;
    body_ += "<g class=\"marker " + escape(css_class) + "\"" + label_attribute(label) + " transform=\"translate(" +
             coord(x_(x)) + "," + coord(y_(y)) + ")\"><path d=\"" + marker_path(shape, size) + "\"" +
             style_attributes(style) + "/></g>\n";
}

void Axes::text(double x, double y, std::string_view content, double dx, double dy) {
    body_ += "<text class=\"annotation\" x=\"" + coord(x_(x) + dx) + "\" y=\"" + coord(y_(y) + dy) + "\">" +
             escape(content) + "</text>\n";
}

void Axes::legend_line(std::string_view label, const Style& style) {
    legend_.push_back({std::string(label), style, false, MarkerShape::Plus});
}

void Axes::legend_marker(std::string_view label, MarkerShape shape, const Style& style) {
    legend_.push_back({std::string(label), style, true, shape});
}

std::string Axes::render(int index) const {
    const std::string clip = "clip-" + std::to_string(index);
    const double right = left_ + width_, bottom = top_ + height_;
    std::string out = "<g class=\"panel\" id=\"panel-" + escape(name_) + "\">\n";
    out += "<defs><clipPath id=\"" + clip + "\"><rect x=\"" + coord(left_) + "\" y=\"" + coord(top_) + "\" width=\"" +
           coord(width_) + "\" height=\"" + coord(height_) + "\"/></clipPath></defs>\n";
    if (!title_.empty()) {
        out += "<text class=\"title\" x=\"" + coord(left_ + width_ / 2) + "\" y=\"" + coord(top_ - 10) +
               "\" text-anchor=\"middle\" font-size=\"14\">" + escape(title_) + "</text>\n";
    }
    out += "<g class=\"grid\" stroke=\"#e0e0e0\" stroke-width=\"1\">\n";
    for (const double v : x_ticks_.values) {
        out += "<line x1=\"" + coord(x_(v)) + "\" y1=\"" + coord(top_) + "\" x2=\"" + coord(x_(v)) + "\" y2=\"" +
               coord(bottom) + "\"/>\n";
    }
    for (const double v : y_ticks_.values) {
        out += "<line x1=\"" + coord(left_) + "\" y1=\"" + coord(y_(v)) + "\" x2=\"" + coord(right) + "\" y2=\"" +
               coord(y_(v)) + "\"/>\n";
    }
    out += "</g>\n<g clip-path=\"url(#" + clip + ")\">\n" + under_ + body_ + "</g>\n";
    out += "<rect class=\"frame\" x=\"" + coord(left_) + "\" y=\"" + coord(top_) + "\" width=\"" + coord(width_) +
           "\" height=\"" + coord(height_) + "\" fill=\"none\" stroke=\"#000000\" stroke-width=\"1\"/>\n";
    out += "<g class=\"axis axis-x\">\n";
    for (std::size_t i = 0; i < x_ticks_.values.size(); ++i) {
        const std::string px = coord(x_(x_ticks_.values[i]));
        out += "<line class=\"tick-x\" x1=\"" + px + "\" y1=\"" + coord(bottom) + "\" x2=\"" + px + "\" y2=\"" +
               coord(bottom + 5) + "\" stroke=\"#000000\"/>\n";
        out += "<text class=\"tick-label-x\" x=\"" + px + "\" y=\"" + coord(bottom + 18) +
               "\" text-anchor=\"middle\">" + escape(x_ticks_.labels[i]) + "</text>\n";
    }
    out += "<text class=\"axis-label axis-label-x\" x=\"" + coord(left_ + width_ / 2) + "\" y=\"" + coord(bottom + 38) +
           "\" text-anchor=\"middle\" font-size=\"14\">" + escape(x_label_) + "</text>\n</g>\n";
    out += "<g class=\"axis axis-y\">\n";
    for (std::size_t i = 0; i < y_ticks_.values.size(); ++i) {
        const std::string py = coord(y_(y_ticks_.values[i]));
        out += "<line class=\"tick-y\" x1=\"" + coord(left_ - 5) + "\" y1=\"" + py + "\" x2=\"" + coord(left_) +
               "\" y2=\"" + py + "\" stroke=\"#000000\"/>\n";
        out += "<text class=\"tick-label-y\" x=\"" + coord(left_ - 8) + "\" y=\"" + py +
               "\" text-anchor=\"end\" dominant-baseline=\"middle\">" + escape(y_ticks_.labels[i]) + "</text>\n";
    }
    const std::string ly = coord(top_ + height_ / 2), lx = coord(left_ - 52);
    out += "<text class=\"axis-label axis-label-y\" x=\"" + lx + "\" y=\"" + ly + "\" transform=\"rotate(-90 " + lx +
           " " + ly + ")\" text-anchor=\"middle\" font-size=\"14\">" + escape(y_label_) + "</text>\n</g>\n";
    if (!legend_.empty()) {
        std::size_t longest = 0;
        for (const auto& e : legend_) longest = std::max(longest, e.label.size());
        const double w = 44 + 7.0 * static_cast<double>(longest), h = 8 + 18.0 * static_cast<double>(legend_.size());
        const bool at_right = legend_position_.find("right") != std::string::npos;
        const bool at_top = legend_position_.find("top") != std::string::npos;
        const double lx0 = at_right ? right - w - 8 : left_ + 8, ly0 = at_top ? top_ + 8 : bottom - h - 8;
        out += "<g class=\"legend\">\n<rect x=\"" + coord(lx0) + "\" y=\"" + coord(ly0) + "\" width=\"" + coord(w) +
               "\" height=\"" + coord(h) + "\" fill=\"#ffffff\" fill-opacity=\"0.85\" stroke=\"#808080\"/>\n";
        for (std::size_t i = 0; i < legend_.size(); ++i) {
            const auto& e = legend_[i];
            const double cy = ly0 + 13 + 18.0 * static_cast<double>(i);
            if (e.is_marker) {
                out += "<path transform=\"translate(" + coord(lx0 + 18) + "," + coord(cy) + ")\" d=\"" +
                       marker_path(e.shape, 5) + "\"" + style_attributes(e.style) + "/>\n";
            } else {
                Style s = e.style;
                if (s.fill != "none") {
                    out += "<rect x=\"" + coord(lx0 + 6) + "\" y=\"" + coord(cy - 6) + "\" width=\"24\" height=\"12\"" +
                           style_attributes(s) + "/>\n";
                } else {
                    out += "<line x1=\"" + coord(lx0 + 6) + "\" y1=\"" + coord(cy) + "\" x2=\"" + coord(lx0 + 30) +
                           "\" y2=\"" + coord(cy) + "\"" + style_attributes(s) + "/>\n";
                }
            }
            out += "<text class=\"legend-label\" x=\"" + coord(lx0 + 36) + "\" y=\"" + coord(cy) +
                   "\" dominant-baseline=\"middle\">" + escape(e.label) + "</text>\n";
        }
        out += "</g>\n";
    }
    out += "</g>\n";
    return out;
}

Document::Document(double width, double height, std::string title)
    : width_(width), height_(height), title_(std::move(title)) {}

Axes& Document::add_axes(std::string name, double left, double top, double width, double height,
                         std::pair<double, double> x_domain, std::pair<double, double> y_domain, std::string x_label,
                         std::string y_label, std::string title) {
    auto a = std::make_unique<Axes>();
    a->name_ = std::move(name);
    a->title_ = std::move(title);
    a->x_label_ = std::move(x_label);
    a->y_label_ = std::move(y_label);
    a->left_ = left;
    a->top_ = top;
    a->width_ = width;
    a->height_ = height;
    const auto [x0, x1] = nice_domain(x_domain.first, x_domain.second);
    const auto [y0, y1] = nice_domain(y_domain.first, y_domain.second);
    a->x_ = LinearScale{x0, x1, left, left + width};
    a->y_ = LinearScale{y0, y1, top + height, top};
    a->x_ticks_ = nice_ticks(x0, x1);
    a->y_ticks_ = nice_ticks(y0, y1);
    axes_.push_back(std::move(a));
    return *axes_.back();
}

std::string Document::str() const {
    std::string out = "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n";
    out += "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"" + coord(width_) + "\" height=\"" + coord(height_) +
           "\" viewBox=\"0 0 " + coord(width_) + " " + coord(height_) +
           "\" font-family=\"DejaVu Sans, Arial, sans-serif\" font-size=\"12\">\n";
    out += "<title>" + escape(title_) + "</title>\n";
    out += "<rect class=\"background\" width=\"100%\" height=\"100%\" fill=\"#ffffff\"/>\n";
    for (std::size_t i = 0; i < axes_.size(); ++i) out += axes_[i]->render(static_cast<int>(i));
    out += "</svg>\n";
    return out;
}

void Document::save(const std::string& path) const {
    std::ofstream file(path, std::ios::binary);
    if (!file) throw std::runtime_error("cannot open '" + path + "' for writing");
    file << str();
    file.close();
    if (!file) throw std::runtime_error("cannot write '" + path + "'");
}

}  // namespace hapticopt::cli::svg
