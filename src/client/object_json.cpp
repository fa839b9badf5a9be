// SPDX-License-Identifier: Apache-2.0
#include "client/object_json.hpp"

#include <cmath>

#include <hapticopt/criterion.hpp>

#include "client/text_limits.hpp"

namespace hapticd::client {

namespace {

using nlohmann::json;

json vec(const Vec3& v) { return json::array({v[0], v[1], v[2]}); }

json gains_json(const Gains& g) {
    if (!g.criterion.empty()) return json{{"criterion", g.criterion}};
    return json{{"K", g.K.value_or(0.0)}, {"B", g.B.value_or(0.0)}};
}

bool read_number(const json& j, const char* key, const std::string& where, double& out, std::string& error,
                 bool required = true) {
    const auto it = j.find(key);
    if (it == j.end()) {
        if (!required) return true;
        error = where + "." + key + ": missing; expected a finite number";
        return false;
    }
    if (!it->is_number() || !std::isfinite(it->get<double>())) {
        error = where + "." + key + ": expected a finite number, got " + truncate_utf8(it->dump(), 40);
        return false;
    }
    out = it->get<double>();
    return true;
}

bool read_vec(const json& j, const char* key, const std::string& where, Vec3& out, std::string& error,
              bool required = true) {
    const auto it = j.find(key);
    if (it == j.end()) {
        if (!required) return true;
        error = where + "." + key + ": missing; expected an array of 3 finite numbers";
        return false;
    }
    if (!it->is_array() || it->size() != 3) {
        error = where + "." + key + ": expected an array of 3 finite numbers, got " + truncate_utf8(it->dump(), 80);
        return false;
    }
    for (std::size_t i = 0; i < 3; ++i) {
        const json& e = (*it)[i];
        if (!e.is_number() || !std::isfinite(e.get<double>())) {
            error = where + "." + key + "[" + std::to_string(i) + "]: expected a finite number, got " +
                    truncate_utf8(e.dump(), 40);
            return false;
        }
        out[i] = e.get<double>();
    }
    return true;
}

bool read_gains(const json& j, const std::string& where, Gains& out, std::string& error) {
    const auto it = j.find("gains");
    if (it == j.end()) {
        error = where + ".gains: missing; expected {\"K\": N/m, \"B\": N s/m} or {\"criterion\": \"CE2\"}";
        return false;
    }
    if (!it->is_object()) {
        error = where + ".gains: expected an object {\"K\", \"B\"} or {\"criterion\"}, got " +
                truncate_utf8(it->dump(), 80);
        return false;
    }
    const auto c = it->find("criterion");
    if (c != it->end()) {
        if (!c->is_string() || it->contains("K") || it->contains("B")) {
            error = where + ".gains: expected either {\"criterion\": name} or {\"K\", \"B\"}, not both";
            return false;
        }
        if (c->get_ref<const std::string&>().empty()) {
            error = where + ".gains.criterion: \"\" is invalid; accepted:";
            for (const hapticopt::Criterion name : hapticopt::kAllCriteria) {
                error += name == hapticopt::kAllCriteria.front() ? " " : ", ";
                error += hapticopt::to_string(name);
            }
            return false;
        }
        out = Gains::by_criterion(c->get<std::string>());
        return true;
    }
    double K = 0.0, B = 0.0;
    if (!read_number(*it, "K", where + ".gains", K, error) || !read_number(*it, "B", where + ".gains", B, error)) {
        return false;
    }
    out = Gains::explicit_gains(K, B);
    return true;
}

}  // namespace

const char* kind_name(const ObjectDescription& object) noexcept {
    switch (object.index()) {
        case 0:
            return "plane";
        case 1:
            return "spring";
        case 2:
            return "field";
        default:
            return "mesh";
    }
}

json object_to_json(const ObjectDescription& object) {
    if (const auto* p = std::get_if<Plane>(&object)) {
        return json{{"kind", "plane"},
                    {"normal", vec(p->normal)},
                    {"offset", p->offset},
                    {"mode", p->bilateral ? "bilateral" : "unilateral"},
                    {"gains", gains_json(p->gains)}};
    }
    if (const auto* s = std::get_if<Spring>(&object)) {
        const char* c = s->constraint == Constraint::Point  ? "point"
                        : s->constraint == Constraint::Line ? "line"
                                                            : "plane";
        json j{{"kind", "spring"}, {"constraint", c}, {"point", vec(s->point)}, {"gains", gains_json(s->gains)}};
        if (s->constraint != Constraint::Point) j["direction"] = vec(s->direction);
        return j;
    }
    if (const auto* m = std::get_if<Mesh>(&object)) {
        json j{
            {"kind", "mesh"},
            {"mesh", m->mesh},
            {"position", vec(m->position)},
            {"orientation", json::array({m->orientation[0], m->orientation[1], m->orientation[2], m->orientation[3]})},
            {"gains", gains_json(m->gains)},
            {"friction", json{{"static", m->static_friction}, {"dynamic", m->dynamic_friction}}}};
        if (m->shading_crease_angle_deg) j["shading"] = json{{"crease_angle_deg", *m->shading_crease_angle_deg}};
        return j;
    }
    const auto& f = std::get<Field>(object);
    return json{{"kind", "field"},
                {"center", vec(f.center)},
                {"radius", f.radius},
                {"force", vec(f.force)},
                {"jacobian", json::array({vec(f.jacobian[0]), vec(f.jacobian[1]), vec(f.jacobian[2])})},
                {"damping", f.damping}};
}

std::optional<ObjectDescription> object_from_json(const json& j, std::string& error) {
    const std::string where = "object";
    if (!j.is_object()) {
        error = "object: expected a JSON object with \"kind\" plane|spring|field|mesh";
        return std::nullopt;
    }
    const auto kind = j.find("kind");
    if (kind == j.end() || !kind->is_string()) {
        error = "object.kind: missing or not a string; accepted: plane, spring, field, mesh";
        return std::nullopt;
    }
    const std::string k = kind->get<std::string>();
    if (k == "plane") {
        Plane p;
        if (!read_vec(j, "normal", where, p.normal, error) || !read_number(j, "offset", where, p.offset, error) ||
            !read_gains(j, where, p.gains, error)) {
            return std::nullopt;
        }
        if (const auto m = j.find("mode"); m != j.end()) {
            if (*m == "unilateral") {
                p.bilateral = false;
            } else if (*m == "bilateral") {
                p.bilateral = true;
            } else {
                error = "object.mode: " + truncate_utf8(m->dump(), 40) + " is invalid; accepted: unilateral, bilateral";
                return std::nullopt;
            }
        }
        return ObjectDescription{p};
    }
    if (k == "spring") {
        Spring s;
        const auto c = j.find("constraint");
        if (c == j.end() || !c->is_string()) {
            error = "object.constraint: missing or not a string; accepted: point, line, plane";
            return std::nullopt;
        }
        if (*c == "point") {
            s.constraint = Constraint::Point;
        } else if (*c == "line") {
            s.constraint = Constraint::Line;
        } else if (*c == "plane") {
            s.constraint = Constraint::Plane;
        } else {
            error = "object.constraint: " + truncate_utf8(c->dump(), 40) + " is invalid; accepted: point, line, plane";
            return std::nullopt;
        }
        if (!read_vec(j, "point", where, s.point, error) ||
            !read_vec(j, "direction", where, s.direction, error, s.constraint != Constraint::Point) ||
            !read_gains(j, where, s.gains, error)) {
            return std::nullopt;
        }
        return ObjectDescription{s};
    }
    if (k == "field") {
        Field f;
        if (!read_vec(j, "center", where, f.center, error) || !read_number(j, "radius", where, f.radius, error) ||
            !read_vec(j, "force", where, f.force, error) ||
            !read_number(j, "damping", where, f.damping, error, false)) {
            return std::nullopt;
        }
        const auto jac = j.find("jacobian");
        if (jac == j.end() || !jac->is_array() || jac->size() != 3) {
            error = "object.jacobian: expected 3 rows of 3 finite numbers (N/m)";
            return std::nullopt;
        }
        for (std::size_t r = 0; r < 3; ++r) {
            json row_holder{{"row", (*jac)[r]}};
            if (!read_vec(row_holder, "row", "object.jacobian[" + std::to_string(r) + "]", f.jacobian[r], error)) {
                return std::nullopt;
            }
        }
        return ObjectDescription{f};
    }
    if (k == "mesh") {
        Mesh m;
        const auto id = j.find("mesh");
        if (id == j.end() || !id->is_number_unsigned() || id->get<std::uint64_t>() == 0 ||
            id->get<std::uint64_t>() > 0xffffffffULL) {
            error = "object.mesh: missing or invalid; accepted: the id of a mesh this session uploaded, 1 .. 2^32-1";
            return std::nullopt;
        }
        m.mesh = static_cast<std::uint32_t>(id->get<std::uint64_t>());
        if (!read_vec(j, "position", where, m.position, error) || !read_gains(j, where, m.gains, error)) {
            return std::nullopt;
        }
        if (const auto q = j.find("orientation"); q != j.end()) {
            if (!q->is_array() || q->size() != 4) {
                error = "object.orientation: expected a unit quaternion [w, x, y, z] of 4 finite numbers";
                return std::nullopt;
            }
            for (std::size_t i = 0; i < 4; ++i) {
                if (!(*q)[i].is_number() || !std::isfinite((*q)[i].get<double>())) {
                    error = "object.orientation[" + std::to_string(i) + "]: expected a finite number";
                    return std::nullopt;
                }
                m.orientation[i] = (*q)[i].get<double>();
            }
        }
        if (const auto fr = j.find("friction"); fr != j.end()) {
            if (!fr->is_object()) {
                error = "object.friction: expected {\"static\": number, \"dynamic\": number}";
                return std::nullopt;
            }
            if (!read_number(*fr, "static", where + ".friction", m.static_friction, error, false) ||
                !read_number(*fr, "dynamic", where + ".friction", m.dynamic_friction, error, false)) {
                return std::nullopt;
            }
        }
        if (const auto sh = j.find("shading"); sh != j.end()) {
            double crease = 0.0;
            if (!sh->is_object()) {
                error = "object.shading: expected {\"crease_angle_deg\": number}";
                return std::nullopt;
            }
            if (!read_number(*sh, "crease_angle_deg", where + ".shading", crease, error)) return std::nullopt;
            m.shading_crease_angle_deg = crease;
        }
        return ObjectDescription{m};
    }
    error = "object.kind: \"" + truncate_utf8(k, 40) + "\" is invalid; accepted: plane, spring, field, mesh";
    return std::nullopt;
}

}  // namespace hapticd::client
