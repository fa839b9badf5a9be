// SPDX-License-Identifier: Apache-2.0
#include "server/object_resolution.hpp"

#include <algorithm>
#include <cmath>
#include <exception>
#include <numbers>
#include <variant>

#include "client/text_limits.hpp"
#include "common/criterion_names.hpp"
#include "tuning/tuning.hpp"

namespace hapticd::server {

namespace {

namespace cl = hapticd::client;
using cl::ErrorCode;

std::string g(double v) { return short_number(v); }

// u u^T scale.
Matrix3 outer(const AxisVector& u, double scale) {
    Matrix3 m{};
    for (std::size_t i = 0; i < 3; ++i) {
        for (std::size_t j = 0; j < 3; ++j) m[i][j] = scale * u[i] * u[j];
    }
    return m;
}

AxisVector to_axis(const cl::Vec3& v) { return AxisVector{v[0], v[1], v[2]}; }

std::optional<Refusal> from_limits(const std::optional<LimitRefusal>& r) {
    if (!r) return std::nullopt;
    return Refusal{r->code, r->message, std::nullopt};
}

}  // namespace

std::vector<SceneTerm> terms_of_config_walls(const std::vector<ConfigWallInfo>& config_walls) {
    std::vector<AxisWall> walls;
    for (const auto& w : config_walls) walls.push_back(AxisWall{w.axis, w.position, w.direction, w.bilateral});
    const std::vector<int> pairs = exclusive_wall_pairs(walls);
    std::vector<SceneTerm> terms;
    for (std::size_t i = 0; i < config_walls.size(); ++i) {
        const auto& w = config_walls[i];
        std::array<double, 3> e{};
        e[w.axis] = 1.0;
        SceneTerm t = plane_term(e, w.K, w.B);
        t.conditional = !w.bilateral;
        t.exclusive_pair = pairs[i];
        t.object_id = static_cast<std::uint32_t>(i + 1);
        terms.push_back(t);
    }
    return terms;
}

void add_config_walls(const std::vector<ConfigWallInfo>& config_walls, Matrix3& K, Matrix3& B) {
    for (const auto& w : config_walls) {
        AxisVector e{};
        e[w.axis] = 1.0;
        add_to(K, outer(e, w.K));
        add_to(B, outer(e, w.B));
    }
}

SceneTerm slot_term(const ServerSlot& slot, SceneTerm::Role role) {
    SceneTerm t;
    t.K = slot.resolved.K_matrix;
    t.B = slot.resolved.B_matrix;
    t.conditional = engages_conditionally(slot.resolved.params);
    t.role = role;
    t.object_id = slot.id;
    t.proxy = slot.resolved.params.kind == ObjectKind::Mesh;
    t.shaded = t.proxy && slot.resolved.params.crease_angle_deg >= 0.0;
    return t;
}

std::size_t objects_held(const SlotTable& slots, std::uint64_t session) {
    std::size_t n = 0;
    for (const auto& slot : slots) n += slot.state == ServerSlot::State::Used && slot.owner == session ? 1U : 0U;
    return n;
}

SlotLookup owned_slot(const SlotTable& slots, std::uint32_t object_id, std::uint64_t session,
                      std::size_t config_walls) {
    int slot = -1;
    for (std::size_t i = 0; i < kSceneObjectCapacity; ++i) {
        if (slots[i].state == ServerSlot::State::Used && slots[i].id == object_id) {
            slot = static_cast<int>(i);
            break;
        }
    }
    if (slot < 0) {
        if (object_id >= 1 && object_id <= config_walls) {
            return {-1, Refusal{ErrorCode::NotOwner,
                                "object " + std::to_string(object_id) + " is a config-file wall, owned by the daemon"}};
        }
        return {-1, Refusal{ErrorCode::UnknownObject,
                            "object_id = " + std::to_string(object_id) + ": no such object in the scene"}};
    }
    const std::uint64_t owner = slots[static_cast<std::size_t>(slot)].owner;
    if (owner != session) {
        return {-1, Refusal{ErrorCode::NotOwner, "object " + std::to_string(object_id) + " belongs to session " +
                                                     std::to_string(owner) + ", not to this one (" +
                                                     std::to_string(session) + ")"}};
    }
    return {slot, std::nullopt};
}

int free_slot(const SlotTable& slots, const std::array<bool, kSceneObjectCapacity>& taken) {
    for (std::size_t i = 0; i < kSceneObjectCapacity; ++i) {
        if (slots[i].state == ServerSlot::State::Free && !taken[i]) return static_cast<int>(i);
    }
    return -1;
}

std::optional<Refusal> ObjectResolver::check_vector(const cl::Vec3& v, const std::string& field, bool unit) const {
    for (std::size_t a = config_.axes; a < 3; ++a) {
        if (v[a] != 0.0) {
            return Refusal{ErrorCode::BadMessage,
                           field + "[" + std::to_string(a) + "] = " + g(v[a]) + " is invalid: the device has " +
                               std::to_string(config_.axes) + " axes; accepted: 0 beyond axis " +
                               std::to_string(config_.axes - 1),
                           std::nullopt};
        }
    }
    if (unit) {
        const double n = std::sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
        if (!(std::fabs(n - 1.0) <= 1e-6)) {
            return Refusal{
                ErrorCode::BadMessage,
                field + ": length " + g(n) + " is invalid; accepted range: a unit vector, | |n| - 1 | <= 1e-6",
                std::nullopt};
        }
    }
    return std::nullopt;
}

WorkspaceBox ObjectResolver::workspace() const {
    WorkspaceBox box;
    box.axes = config_.axes;
    for (std::size_t a = 0; a < 3; ++a) {
        box.min[a] = config_.workspace_min[a];
        box.max[a] = config_.workspace_max[a];
    }
    return box;
}

// The profile's stiffness limit (beyond_device_limits); `what` names the stiffness ("plane: K").
std::optional<Refusal> ObjectResolver::check_stiffness_limit(double K, const std::string& what) const {
    const std::optional<double> limit = checker_.max_stiffness();
    if (!limit || !(K > *limit)) return std::nullopt;
    return Refusal{ErrorCode::BeyondDeviceLimits,
                   what + " = " + g(K) +
                       " N/m exceeds the device's stiffness limit (device profile key "
                       "max_stiffness = " +
                       g(*limit) + " N/m); accepted range: <= " + g(*limit) + " N/m",
                   std::nullopt};
}

std::optional<hapticopt::Criterion> named_criterion(const cl::Gains& gains) {
    if (gains.criterion.empty()) return std::nullopt;
    return hapticopt::parse_criterion(gains.criterion);
}

// Gains of an object acting with gains (K P, B P) and the masses `masses` (GainChecker::masses_of):
// explicit or the cached optimum of the criterion for the lightest of them; then the stiffness limit
// and the exact verdict for every mass.
std::optional<Refusal> ObjectResolver::resolve_gains(const cl::Gains& gains, const std::string& kind,
                                                     const std::vector<double>& masses, double& K, double& B) {
    const double lightest =
        masses.empty() ? checker_.mass().smallest() : *std::min_element(masses.begin(), masses.end());
    if (!gains.criterion.empty()) {
        const std::optional<hapticopt::Criterion> criterion = named_criterion(gains);
        if (!criterion) {
            return Refusal{ErrorCode::UnknownCriterion,
                           kind + ".gains.criterion = " +
                               invalid_criterion_text("\"" + cl::truncate_utf8(gains.criterion, 40) + "\""),
                           std::nullopt};
        }
        const std::string name(hapticopt::to_string(*criterion));
        CriterionGains c;
        try {
            c = checker_.criterion_gains(*criterion, lightest);
        } catch (const std::exception& e) {
            return Refusal{ErrorCode::BadMessage, kind + ".gains.criterion = " + name + ": " + e.what(), std::nullopt};
        }
        K = c.K;
        B = c.B;
        if (auto r = check_stiffness_limit(K, kind + ": the optimal K of criterion " + name)) return r;
    } else {
        K = gains.K.value_or(0.0);
        B = gains.B.value_or(0.0);
        if (auto r = from_limits(check_explicit_gains(K, B, kind))) return r;
        if (auto r = check_stiffness_limit(K, kind + ": K")) return r;
    }
    // The verdict per mass (one Schur-Cohn test each); the largest stable K only for the refusal.
    const PairVerdict v = checker_.check_object(K, B, masses);
    if (!v.stable) {
        const std::string along =
            masses.size() == 1 ? "the mass along the object's direction" : "one of the object's directional masses";
        return Refusal{
            ErrorCode::UnstableGains,
            kind + ": K = " + g(K) + " N/m, B = " + g(B) + " N s/m (alpha = " + g(v.alpha) + ", beta = " + g(v.beta) +
                ") are outside the stability region with " + checker_.plant_text(v) + " of " + checker_.set_text() +
                ", for " + along + ", " + g(v.mass) + " kg (device mass " + checker_.mass().describe() + "), period " +
                g(config_.period) + " s, delay " + g(config_.delay) +
                " s; the largest stable K over the set at B = " + g(B) + " N s/m is " + g(v.largest_stable_K) +
                " N/m (alpha_max = " + g(v.alpha_max) + " at the nominal mass); " +
                (v.damping_stable
                     ? "K = " + g(K) + " N/m is stable with the nominal mass for " + g(v.damping_stable->first) +
                           " < B < " + g(v.damping_stable->second) + " N s/m" +
                           (v.damping_needed ? ", accepted (stable over the set) for " + g(v.damping_needed->first) +
                                                   " < B < " + g(v.damping_needed->second) + " N s/m (damping_needed)"
                                             : " but with no B over the whole set")
                     : "no B makes K = " + g(K) + " N/m stable with " + along),
            v.largest_stable_K, v.damping_needed};
    }
    return std::nullopt;
}

std::optional<Refusal> ObjectResolver::resolve(const cl::ObjectDescription& d, Resolved& out,
                                               const MeshLookup* meshes) {
    out = Resolved{};
    if (const auto* plane = std::get_if<cl::Plane>(&d)) return resolve_plane(*plane, out);
    if (const auto* spring = std::get_if<cl::Spring>(&d)) return resolve_spring(*spring, out);
    if (const auto* m = std::get_if<cl::Mesh>(&d)) return resolve_mesh(*m, out, meshes);
    return resolve_field(std::get<cl::Field>(d), out);
}

// Plane: K n n^T, B n n^T, checked with the mass along n.
std::optional<Refusal> ObjectResolver::resolve_plane(const cl::Plane& plane, Resolved& out) {
    ObjectParams& p = out.params;
    if (auto r = check_vector(plane.normal, "plane.normal", true)) return r;
    if (auto r = from_limits(check_plane_in_workspace(plane.normal, plane.offset, workspace()))) return r;
    p.kind = ObjectKind::Plane;
    p.direction = to_axis(plane.normal);
    p.offset = plane.offset;
    p.bilateral = plane.bilateral;
    if (auto r = resolve_gains(plane.gains, "plane", {checker_.mass_along(p.direction)}, p.K, p.B)) return r;
    out.K_matrix = outer(p.direction, p.K);
    out.B_matrix = outer(p.direction, p.B);
    return std::nullopt;
}

// Spring: K P, B P with P = n n^T (plane constraint), I - d d^T (line) or I (point), on the device's axes;
// checked with the masses of P.
std::optional<Refusal> ObjectResolver::resolve_spring(const cl::Spring& spring, Resolved& out) {
    ObjectParams& p = out.params;
    if (auto r = check_vector(spring.point, "spring.point", false)) return r;
    if (auto r = from_limits(check_in_workspace(spring.point, "spring.point", workspace()))) return r;
    p.kind = ObjectKind::Spring;
    p.constraint = spring.constraint == cl::Constraint::Point  ? SpringConstraint::Point
                   : spring.constraint == cl::Constraint::Line ? SpringConstraint::Line
                                                               : SpringConstraint::Plane;
    if (p.constraint != SpringConstraint::Point) {
        if (auto r = check_vector(spring.direction, "spring.direction", true)) return r;
        p.direction = to_axis(spring.direction);
    }
    p.point = to_axis(spring.point);
    Matrix3 P{};
    if (p.constraint == SpringConstraint::Plane) {
        P = outer(p.direction, 1.0);
    } else {
        for (std::size_t i = 0; i < config_.axes; ++i) P[i][i] = 1.0;  // only the device's axes
        if (p.constraint == SpringConstraint::Line) {
            const Matrix3 dd = outer(p.direction, -1.0);
            add_to(P, dd);
        }
    }
    const std::vector<double> masses = p.constraint == SpringConstraint::Plane
                                           ? std::vector<double>{checker_.mass_along(p.direction)}
                                           : checker_.masses_of(P);
    if (auto r = resolve_gains(spring.gains, "spring", masses, p.K, p.B)) return r;
    for (std::size_t i = 0; i < 3; ++i) {
        for (std::size_t j = 0; j < 3; ++j) {
            out.K_matrix[i][j] = p.K * P[i][j];
            out.B_matrix[i][j] = p.B * P[i][j];
        }
    }
    return std::nullopt;
}

// Field F0 + J (x - x0) - B v: stiffness -sym(J) (negative semi-definite sym(J) required), the largest force
// |F0| + ||J|| radius within max_force, checked with the isotropic damping B on the device's axes.
std::optional<Refusal> ObjectResolver::resolve_field(const cl::Field& field, Resolved& out) {
    ObjectParams& p = out.params;
    if (auto r = check_vector(field.center, "field.center", false)) return r;
    if (auto r = check_vector(field.force, "field.force", false)) return r;
    if (auto r = from_limits(check_in_workspace(field.center, "field.center", workspace()))) return r;
    if (auto r = from_limits(check_field_damping(field.damping))) return r;
    if (!(field.radius > 0.0) || !std::isfinite(field.radius)) {
        return Refusal{ErrorCode::BadMessage,
                       "field.radius = " + g(field.radius) + " is invalid; accepted range: finite, > 0 m",
                       std::nullopt};
    }
    Matrix3 J{};
    for (std::size_t i = 0; i < 3; ++i) {
        for (std::size_t j = 0; j < 3; ++j) {
            J[i][j] = field.jacobian[i][j];
            if ((i >= config_.axes || j >= config_.axes) && J[i][j] != 0.0) {
                return Refusal{ErrorCode::BadMessage,
                               "field.jacobian[" + std::to_string(i) + "][" + std::to_string(j) +
                                   "] is invalid: the device has " + std::to_string(config_.axes) +
                                   " axes; accepted: 0 outside them",
                               std::nullopt};
            }
        }
    }
    const GainChecker::FieldStiffness fs = GainChecker::field_stiffness(J);
    const double scale = 1e-12 * (1.0 + fs.jacobian_norm);
    if (fs.stiffness_min < -scale) {
        return Refusal{ErrorCode::UnstableGains,
                       "field.jacobian: its symmetric part has the eigenvalue " + g(-fs.stiffness_min) +
                           " N/m > 0 (a negative stiffness, unstable); accepted: sym(J) negative semi-definite",
                       std::nullopt};
    }
    const double f0 =
        std::sqrt(field.force[0] * field.force[0] + field.force[1] * field.force[1] + field.force[2] * field.force[2]);
    const double largest = f0 + fs.jacobian_norm * field.radius;
    if (largest > config_.max_force) {
        return Refusal{ErrorCode::BeyondDeviceLimits,
                       "field: the largest force |F0| + ||J|| radius = " + g(largest) +
                           " N exceeds the device's max_force; accepted range: <= " + g(config_.max_force) + " N",
                       std::nullopt};
    }
    if (!(field.damping >= 0.0)) {
        return Refusal{ErrorCode::BadMessage,
                       "field.damping = " + g(field.damping) + " is invalid; accepted range: finite, >= 0 N s/m",
                       std::nullopt};
    }
    if (auto r = check_stiffness_limit(fs.stiffness_max,
                                       "field: the stiffness of its Jacobian (largest eigenvalue of -sym(J))"))
        return r;
    Matrix3 B_field{};
    for (std::size_t i = 0; i < config_.axes; ++i) B_field[i][i] = field.damping;
    std::string why;
    std::optional<double> largest_stable_K;
    if (!checker_.field_is_stable(J, B_field, why, largest_stable_K))
        return Refusal{ErrorCode::UnstableGains, why, largest_stable_K};
    p.kind = ObjectKind::Field;
    p.point = to_axis(field.center);
    p.radius = field.radius;
    p.force = to_axis(field.force);
    p.B = field.damping;
    for (std::size_t i = 0; i < 3; ++i) p.jacobian[i] = AxisVector{J[i][0], J[i][1], J[i][2]};
    out.K_matrix = GainChecker::field_stiffness_matrix(J);
    out.B_matrix = B_field;
    return std::nullopt;
}

std::vector<double> mesh_masses(const std::vector<double>& eigen_masses, double scale_min, double scale_max) {
    if (eigen_masses.empty()) return {};
    const double lo = *std::min_element(eigen_masses.begin(), eigen_masses.end());
    const double hi = *std::max_element(eigen_masses.begin(), eigen_masses.end());
    const double ratio = scale_max / scale_min;
    std::vector<double> out{lo};
    if (!(hi > lo)) return out;
    if (!(ratio > 1.0 + 1e-9)) {  // a point set: no interval to chain; the range sampled at 65 masses
        for (int j = 1; j <= 64; ++j) out.push_back(lo * std::pow(hi / lo, j / 64.0));
        return out;
    }
    for (double m = lo * ratio; m < hi; m *= ratio) out.push_back(m);
    out.push_back(hi);
    return out;
}

std::vector<double> shaded_mesh_masses(const std::vector<double>& eigen_masses, double scale_min, double scale_max,
                                       double crease_angle_deg) {
    if (eigen_masses.empty()) return {};
    std::vector<double> extended = eigen_masses;
    const double c = std::cos(crease_angle_deg * std::numbers::pi / 180.0) * (1.0 - 1e-9);
    extended.push_back(*std::max_element(eigen_masses.begin(), eigen_masses.end()) / c);
    return mesh_masses(extended, scale_min, scale_max);
}

// Mesh: a proxy whose coupling to the handle is K P, B P for the active constraints' projector P (any rank, I
// with friction): certified as a spring of K and a damper of B in every direction with every mass P can give
// (mesh_masses); in the sums a conditional term K I, B I on the device's axes.
std::optional<Refusal> ObjectResolver::resolve_mesh(const cl::Mesh& m, Resolved& out, const MeshLookup* meshes) {
    ObjectParams& p = out.params;
    if (auto r = check_vector(m.position, "mesh.position", false)) return r;
    if (auto r = from_limits(check_in_workspace(m.position, "mesh.position", workspace()))) return r;
    const double qn = std::sqrt(m.orientation[0] * m.orientation[0] + m.orientation[1] * m.orientation[1] +
                                m.orientation[2] * m.orientation[2] + m.orientation[3] * m.orientation[3]);
    if (!(std::fabs(qn - 1.0) <= 1e-6)) {
        return Refusal{
            ErrorCode::BadMessage,
            "mesh.orientation: |q| = " + g(qn) + "; accepted: a unit quaternion [w, x, y, z], ||q|| - 1| <= 1e-6",
            std::nullopt};
    }
    if (!(m.dynamic_friction >= 0.0 && m.dynamic_friction <= m.static_friction && m.static_friction <= 10.0)) {
        return Refusal{ErrorCode::BadMessage,
                       "mesh.friction: static = " + g(m.static_friction) + ", dynamic = " + g(m.dynamic_friction) +
                           "; accepted: 0 <= dynamic <= static <= 10",
                       std::nullopt};
    }
    if (config_.axes != 3) {
        return Refusal{
            ErrorCode::BadMessage,
            "mesh: the device has " + std::to_string(config_.axes) + " axes; accepted: meshes on 3-axis devices",
            std::nullopt};
    }
    if (meshes == nullptr) {
        return Refusal{ErrorCode::UnknownObject, "mesh.mesh = " + std::to_string(m.mesh) + ": no mesh store",
                       std::nullopt};
    }
    if (m.shading_crease_angle_deg) {
        const double crease = *m.shading_crease_angle_deg;
        if (!(crease >= 0.0 && crease <= mesh::kMaxCreaseAngleDeg)) {
            return Refusal{ErrorCode::BadMessage,
                           "mesh.shading.crease_angle_deg = " + g(crease) + "; accepted: 0 .. " +
                               g(mesh::kMaxCreaseAngleDeg) + " (degrees)",
                           std::nullopt};
        }
        if (!checker_.mass().isotropic || !checker_.certified()) {
            return Refusal{ErrorCode::BadMessage,
                           "mesh.shading: accepted on devices with one mass and a free-mass plant (b = k = 0), whose "
                           "shaded wall is the wall with a heavier mass (docs/mesh-rendering.md, \"Force shading\"); "
                           "this profile's plant is " +
                               checker_.set_text(),
                           std::nullopt};
        }
    }
    MeshLookupResult found = (*meshes)(m.mesh);
    if (found.refusal) return found.refusal;
    Matrix3 I{};
    for (std::size_t i = 0; i < config_.axes; ++i) I[i][i] = 1.0;
    const auto [c_min, c_max] = checker_.mass_scales();
    const std::vector<double> masses =
        m.shading_crease_angle_deg
            ? shaded_mesh_masses(checker_.masses_of(I), c_min, c_max, *m.shading_crease_angle_deg)
            : mesh_masses(checker_.masses_of(I), c_min, c_max);
    if (auto r = resolve_gains(m.gains, "mesh", masses, p.K, p.B)) return r;
    if (m.shading_crease_angle_deg && config_.ramp_time > 0.0) {
        // The ramp scenes of the shaded mesh alone, (s^2 K, s B) at the same masses (the summed check takes them
        // at the plant set's masses, without the shading's heavier ones).
        const double step = config_.period / config_.ramp_time;
        for (int j = 1; j * step < 1.0; ++j) {
            const double s = j * step;
            const PairVerdict v = checker_.check_object(s * s * p.K, s * p.B, masses);
            if (!v.stable) {
                return Refusal{ErrorCode::UnstableGains,
                               "mesh.shading.crease_angle_deg = " + g(*m.shading_crease_angle_deg) + ": K = " + g(p.K) +
                                   " N/m, B = " + g(p.B) + " N s/m during the ramp (weight " + g(s) +
                                   ") are outside the stability region with " + checker_.plant_text(v) + " of " +
                                   checker_.set_text() + ", for the shaded mass " + g(v.mass) +
                                   " kg; accepted: a smaller crease angle or other gains",
                               std::nullopt};
            }
        }
    }
    if (m.shading_crease_angle_deg) {
        // The table is the last thing checked (a new angle's is built here, counted against the mesh limits).
        if (!found.shading) {
            return Refusal{ErrorCode::UnknownObject,
                           "mesh.shading: mesh " + std::to_string(m.mesh) + " has no store counting its normals",
                           std::nullopt};
        }
        auto table = found.shading(*m.shading_crease_angle_deg);
        if (auto* r = std::get_if<Refusal>(&table)) return std::move(*r);
        p.shading = std::get<const mesh::ShadingNormals*>(table);
        p.crease_angle_deg = *m.shading_crease_angle_deg;
    }
    p.kind = ObjectKind::Mesh;
    p.point = to_axis(m.position);
    for (std::size_t i = 0; i < 4; ++i) p.orientation[i] = m.orientation[i] / qn;
    p.static_friction = m.static_friction;
    p.dynamic_friction = m.dynamic_friction;
    p.mesh = found.hierarchy.get();
    p.mesh_id = m.mesh;
    out.mesh = std::move(found.hierarchy);
    for (std::size_t i = 0; i < 3; ++i) {
        out.K_matrix[i][i] = p.K * I[i][i];
        out.B_matrix[i][i] = p.B * I[i][i];
    }
    return std::nullopt;
}

}  // namespace hapticd::server
