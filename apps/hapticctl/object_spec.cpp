// SPDX-License-Identifier: Apache-2.0
#include "object_spec.hpp"

#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <map>
#include <optional>
#include <set>
#include <sstream>

namespace hapticctl {

namespace hc = hapticd::client;

namespace {

double parse_number(const std::string& key, const std::string& text) {
    errno = 0;
    char* end = nullptr;
    const double v = std::strtod(text.c_str(), &end);
    if (text.empty() || end != text.c_str() + text.size() || errno == ERANGE || !std::isfinite(v)) {
        throw SpecError("parse_object_spec: " + key + " = '" + text + "' is not a finite number");
    }
    return v;
}

std::vector<double> parse_numbers(const std::string& key, const std::string& text, std::size_t count) {
    std::vector<double> out;
    std::string item;
    std::istringstream in(text);
    while (std::getline(in, item, ',')) out.push_back(parse_number(key, item));
    if (out.size() != count || (!text.empty() && text.back() == ',')) {
        throw SpecError("parse_object_spec: " + key + " = '" + text + "' must be " + std::to_string(count) +
                        " comma-separated numbers");
    }
    return out;
}

hc::Vec3 parse_vec3(const std::string& key, const std::string& text) {
    const auto v = parse_numbers(key, text, 3);
    return {v[0], v[1], v[2]};
}

struct Words {
    std::string kind;
    std::map<std::string, std::string> values;

    bool has(const std::string& key) const { return values.count(key) != 0; }
    const std::string& at(const std::string& key) const {
        const auto it = values.find(key);
        if (it == values.end()) throw SpecError("parse_object_spec: " + kind + ": " + key + "= is required");
        return it->second;
    }
};

Words split_key_values(const std::vector<std::string>& words, const std::set<std::string>& allowed) {
    Words w;
    w.kind = words.front();
    for (std::size_t i = 1; i < words.size(); ++i) {
        const auto eq = words[i].find('=');
        if (eq == std::string::npos || eq == 0) {
            throw SpecError("parse_object_spec: '" + words[i] + "' is not key=value");
        }
        const std::string key = words[i].substr(0, eq);
        if (allowed.count(key) == 0) {
            std::string list;
            for (const auto& a : allowed) list += (list.empty() ? "" : ", ") + a;
            throw SpecError("parse_object_spec: " + w.kind + ": unknown key '" + key + "'; accepted: " + list);
        }
        if (!w.values.emplace(key, words[i].substr(eq + 1)).second) {
            throw SpecError("parse_object_spec: " + w.kind + ": " + key + "= given twice");
        }
    }
    return w;
}

// criterion=C, or K= with optional B= (default 0). `required`: one of them must be given.
std::optional<hc::Gains> parse_gains(const Words& w, bool required) {
    const bool by_criterion = w.has("criterion");
    const bool explicit_gains = w.has("K") || w.has("B");
    if (by_criterion && explicit_gains) {
        throw SpecError("parse_object_spec: " + w.kind + ": give either criterion= or K=/B=, not both");
    }
    if (by_criterion) return hc::Gains::by_criterion(w.at("criterion"));
    if (explicit_gains) {
        if (!w.has("K")) throw SpecError("parse_object_spec: " + w.kind + ": B= needs K= (N/m)");
        const double B = w.has("B") ? parse_number("B", w.at("B")) : 0.0;
        return hc::Gains::explicit_gains(parse_number("K", w.at("K")), B);
    }
    if (required)
        throw SpecError("parse_object_spec: " + w.kind + ": gains are required: K=N/m [B=N s/m] or criterion=CE2");
    return std::nullopt;
}

}  // namespace

std::vector<std::string> split_words(const std::string& line) {
    std::vector<std::string> out;
    std::istringstream in(line);
    std::string w;
    while (in >> w) out.push_back(w);
    return out;
}

hc::ObjectDescription parse_object_spec(const std::vector<std::string>& words) {
    if (words.empty()) {
        throw SpecError("parse_object_spec: an object kind is required: plane, spring, field or mesh");
    }
    const std::string& kind = words.front();
    if (kind == "plane") {
        const Words w = split_key_values(words, {"normal", "offset", "mode", "criterion", "K", "B"});
        hc::Plane p;
        p.normal = parse_vec3("normal", w.at("normal"));
        p.offset = w.has("offset") ? parse_number("offset", w.at("offset")) : 0.0;
        if (w.has("mode")) {
            const std::string& m = w.at("mode");
            if (m != "unilateral" && m != "bilateral") {
                throw SpecError("parse_object_spec: plane: mode = '" + m + "'; accepted: unilateral, bilateral");
            }
            p.bilateral = m == "bilateral";
        }
        p.gains = parse_gains(w, false).value_or(hc::Gains::by_criterion("CE2"));
        return p;
    }
    if (kind == "spring") {
        const Words w = split_key_values(words, {"constraint", "point", "direction", "criterion", "K", "B"});
        hc::Spring s;
        const std::string constraint = w.has("constraint") ? w.at("constraint") : "point";
        if (constraint == "point") {
            s.constraint = hc::Constraint::Point;
            if (w.has("direction"))
                throw SpecError("parse_object_spec: spring: direction= is not used by constraint=point");
        } else if (constraint == "line" || constraint == "plane") {
            s.constraint = constraint == "line" ? hc::Constraint::Line : hc::Constraint::Plane;
            s.direction = parse_vec3("direction", w.at("direction"));
        } else {
            throw SpecError("parse_object_spec: spring: constraint = '" + constraint +
                            "'; accepted: point, line, plane");
        }
        s.point = parse_vec3("point", w.at("point"));
        s.gains = *parse_gains(w, true);
        return s;
    }
    if (kind == "field") {
        const Words w = split_key_values(words, {"center", "radius", "force", "jacobian"});
        hc::Field f;
        f.center = parse_vec3("center", w.at("center"));
        f.radius = parse_number("radius", w.at("radius"));
        if (w.has("force")) f.force = parse_vec3("force", w.at("force"));
        if (w.has("jacobian")) {
            const auto j = parse_numbers("jacobian", w.at("jacobian"), 9);
            for (std::size_t r = 0; r < 3; ++r) f.jacobian[r] = {j[3 * r], j[3 * r + 1], j[3 * r + 2]};
        }
        return f;
    }
    if (kind == "mesh") {
        const Words w = split_key_values(words, {"mesh", "position", "orientation", "criterion", "K", "B",
                                                 "static_friction", "dynamic_friction", "shading"});
        hc::Mesh m;
        const double id = parse_number("mesh", w.at("mesh"));
        if (!(id >= 1 && id <= 4294967295.0) || id != std::floor(id)) {
            throw SpecError("parse_object_spec: mesh: mesh = '" + w.at("mesh") + "'; accepted: an uploaded mesh's id");
        }
        m.mesh = static_cast<std::uint32_t>(id);
        if (w.has("position")) m.position = parse_vec3("position", w.at("position"));
        if (w.has("orientation")) {
            const auto q = parse_numbers("orientation", w.at("orientation"), 4);
            m.orientation = {q[0], q[1], q[2], q[3]};
        }
        m.gains = parse_gains(w, false).value_or(hc::Gains::by_criterion("CE2"));
        if (w.has("static_friction")) m.static_friction = parse_number("static_friction", w.at("static_friction"));
        if (w.has("dynamic_friction")) m.dynamic_friction = parse_number("dynamic_friction", w.at("dynamic_friction"));
        if (w.has("shading")) m.shading_crease_angle_deg = parse_number("shading", w.at("shading"));
        return m;
    }
    throw SpecError("parse_object_spec: object kind '" + kind + "' is unknown; accepted: plane, spring, field, mesh");
}

}  // namespace hapticctl
