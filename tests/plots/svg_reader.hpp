// SPDX-License-Identifier: Apache-2.0
// A minimal reader for the SVG files written by `hapticopt plot` (see src/svg/svg_writer.hpp
// for the conventions it relies on): well-formedness, elements with their attributes and text, panel
// extraction, and the axis scales recovered from the tick marks and their labels. Plain scanning, no
// std::regex (libstdc++'s recurses once per character, which overflows the stack under ASan on the
// long path attributes).
#pragma once

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <map>
#include <optional>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

namespace plots_test {

inline std::string read_text(const std::string& path) {
    std::ifstream in(path, std::ios::binary);
    std::ostringstream s;
    s << in.rdbuf();
    return s.str();
}

/// "&amp;", "&lt;", "&gt;", "&quot;", "&apos;", "&#123;" or "&#x1F;".
inline bool is_entity(const std::string& e) {
    if (e == "&amp;" || e == "&lt;" || e == "&gt;" || e == "&quot;" || e == "&apos;") return true;
    if (e.size() < 4 || e.compare(0, 2, "&#") != 0 || e.back() != ';') return false;
    const bool hex = e[2] == 'x';
    const std::string digits = e.substr(hex ? 3 : 2, e.size() - (hex ? 4 : 3));
    if (digits.empty()) return false;
    for (const char c : digits) {
        if (!(hex ? std::isxdigit(static_cast<unsigned char>(c)) : std::isdigit(static_cast<unsigned char>(c))))
            return false;
    }
    return true;
}

/// The name="value" pairs of a start tag's text (names: letters, digits, '-', '_', ':', '.').
inline std::map<std::string, std::string> attributes_of(const std::string& head) {
    std::map<std::string, std::string> out;
    auto name_char = [](char c) {
        return std::isalnum(static_cast<unsigned char>(c)) || c == '-' || c == '_' || c == ':' || c == '.';
    };
    for (std::size_t eq = head.find("=\""); eq != std::string::npos; eq = head.find("=\"", eq + 1)) {
        std::size_t begin = eq;
        while (begin > 0 && name_char(head[begin - 1])) --begin;
        const std::size_t close = head.find('"', eq + 2);
        if (close == std::string::npos) break;
        if (begin < eq) out[head.substr(begin, eq - begin)] = head.substr(eq + 2, close - eq - 2);
        eq = close;
    }
    return out;
}

/// Empty when the document is well-formed XML as far as tags go (every start tag closed in order,
/// one root, no stray '<' or '&' in text); otherwise a description of the first problem.
inline std::string xml_problem(const std::string& doc) {
    std::vector<std::string> stack;
    int roots = 0;
    std::size_t i = 0;
    while (i < doc.size()) {
        if (doc[i] == '&') {
            const std::size_t semi = doc.find(';', i);
            const std::string entity = semi == std::string::npos ? "" : doc.substr(i, semi - i + 1);
            if (!is_entity(entity)) {
                return "bad entity at " + std::to_string(i);
            }
            i = semi + 1;
            continue;
        }
        if (doc[i] != '<') {
            ++i;
            continue;
        }
        if (doc.compare(i, 5, "<?xml") == 0) {
            i = doc.find("?>", i) + 2;
            continue;
        }
        if (doc.compare(i, 4, "<!--") == 0) {
            i = doc.find("-->", i) + 3;
            continue;
        }
        const std::size_t end = doc.find('>', i);
        if (end == std::string::npos) return "unterminated tag at " + std::to_string(i);
        const std::string tag = doc.substr(i + 1, end - i - 1);
        if (tag.find('<') != std::string::npos) return "'<' inside tag at " + std::to_string(i);
        if (std::count(tag.begin(), tag.end(), '"') % 2 != 0) return "unbalanced quotes at " + std::to_string(i);
        if (tag.empty()) return "empty tag";
        if (tag[0] == '/') {
            const std::string name = tag.substr(1);
            if (stack.empty() || stack.back() != name) return "unexpected </" + name + ">";
            stack.pop_back();
        } else if (tag.back() != '/') {
            const std::string name = tag.substr(0, tag.find_first_of(" \t\n"));
            if (stack.empty()) ++roots;
            stack.push_back(name);
        } else if (stack.empty()) {
            ++roots;
        }
        i = end + 1;
    }
    if (!stack.empty()) return "unclosed <" + stack.back() + ">";
    if (roots != 1) return std::to_string(roots) + " root elements";
    return {};
}

struct Element {
    std::map<std::string, std::string> attributes;
    std::string text;  ///< content up to the next '<' (for <text> elements)
    std::string attr(const std::string& name) const {
        const auto it = attributes.find(name);
        return it == attributes.end() ? std::string{} : it->second;
    }
    bool has_class(const std::string& c) const {
        std::istringstream s(attr("class"));
        std::string word;
        while (s >> word)
            if (word == c) return true;
        return false;
    }
};

/// All <tag ...> elements of `doc` carrying CSS class `css_class` (any class when empty).
inline std::vector<Element> elements(const std::string& doc, const std::string& tag,
                                     const std::string& css_class = {}) {
    std::vector<Element> out;
    const std::string open = "<" + tag + " ";
    for (std::size_t i = doc.find(open); i != std::string::npos; i = doc.find(open, i + 1)) {
        const std::size_t end = doc.find('>', i);
        const std::string head = doc.substr(i, end - i);
        Element e;
        e.attributes = attributes_of(head);
        if (head.back() != '/') e.text = doc.substr(end + 1, doc.find('<', end) - end - 1);
        if (css_class.empty() || e.has_class(css_class)) out.push_back(std::move(e));
    }
    return out;
}

/// The text of panel `name` (<g class="panel" id="panel-NAME"> up to the next panel or the end).
inline std::string panel(const std::string& doc, const std::string& name) {
    const std::size_t start = doc.find("<g class=\"panel\" id=\"panel-" + name + "\">");
    if (start == std::string::npos) return {};
    const std::size_t next = doc.find("<g class=\"panel\"", start + 1);
    return doc.substr(start, next == std::string::npos ? std::string::npos : next - start);
}

/// "x,y x,y ..." -> points.
inline std::vector<std::pair<double, double>> points(const std::string& list) {
    std::vector<std::pair<double, double>> out;
    std::istringstream s(list);
    std::string pair;
    while (s >> pair) {
        const std::size_t comma = pair.find(',');
        out.emplace_back(std::stod(pair.substr(0, comma)), std::stod(pair.substr(comma + 1)));
    }
    return out;
}

/// "translate(x,y)" -> (x, y).
inline std::pair<double, double> translation(const std::string& transform) {
    const std::size_t open = transform.find('('), comma = transform.find(','), close = transform.find(')');
    return {std::stod(transform.substr(open + 1, comma - open - 1)),
            std::stod(transform.substr(comma + 1, close - comma - 1))};
}

/// An axis scale recovered from its ticks: pixel -> value through the first and last tick.
struct AxisScale {
    double p0 = 0, p1 = 1, v0 = 0, v1 = 1;
    std::size_t ticks = 0;
    double value(double pixel) const { return v0 + (pixel - p0) * (v1 - v0) / (p1 - p0); }
    double pixel(double value) const { return p0 + (value - v0) * (p1 - p0) / (v1 - v0); }
};

/// Reads the ticks of axis "x" or "y" of a panel; nullopt unless there are >= 2 ticks with numeric,
/// equally spaced labels at equally spaced pixels (to 0.02 px).
inline std::optional<AxisScale> axis_scale(const std::string& panel_text, const std::string& axis) {
    const auto lines = elements(panel_text, "line", "tick-" + axis);
    const auto labels = elements(panel_text, "text", "tick-label-" + axis);
    if (lines.size() < 2 || lines.size() != labels.size()) return std::nullopt;
    std::vector<double> px, val;
    for (std::size_t i = 0; i < lines.size(); ++i) {
        px.push_back(std::stod(lines[i].attr(axis == "x" ? "x1" : "y1")));
        val.push_back(std::stod(labels[i].text));
        if (std::abs(std::stod(labels[i].attr(axis)) - px.back()) > 1e-9) return std::nullopt;
    }
    AxisScale s{px.front(), px.back(), val.front(), val.back(), px.size()};
    for (std::size_t i = 0; i < px.size(); ++i) {
        if (std::abs(s.pixel(val[i]) - px[i]) > 0.02) return std::nullopt;
    }
    return s;
}

}  // namespace plots_test
