#include "scene/scene_objects.hpp"

#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

namespace hapticd {

namespace {

double dot(const AxisVector& a, const AxisVector& b) noexcept { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }

}  // namespace

SceneObjects::SceneObjects(const SceneObjectsConfig& config, CommitRing& ring) : config_(config), ring_(ring) {
    if (!(config_.period > 0.0) || !std::isfinite(config_.period)) {
        throw std::invalid_argument("SceneObjects: period = " + std::to_string(config_.period) + " is invalid; accepted range: finite, > 0");
    }
    if (!(config_.ramp_time >= 0.0) || !std::isfinite(config_.ramp_time)) {
        throw std::invalid_argument("SceneObjects: ramp_time = " + std::to_string(config_.ramp_time) +
                                    " is invalid; accepted range: finite, >= 0 s");
    }
    if (!(config_.max_force > 0.0) || !(config_.max_force_rate > 0.0)) {
        throw std::invalid_argument("SceneObjects: max_force and max_force_rate must be > 0");
    }
    inverse_period_ = 1.0 / config_.period;
    ramp_step_ = config_.ramp_time > 0.0 ? config_.period / config_.ramp_time : 1.0;
    if (ramp_step_ > 1.0) ramp_step_ = 1.0;
}

namespace {

// A Move keeps everything but where the object is (plane offset, spring point, field centre and F0); its
// surface moves by at most the returned distance. Anything else changed is not a move.
bool is_move_of(const ObjectParams& before, const ObjectParams& after, double& surface_shift) noexcept {
    if (before.id != after.id || before.kind != after.kind || before.bilateral != after.bilateral ||
        before.constraint != after.constraint || before.direction != after.direction || before.radius != after.radius ||
        before.jacobian != after.jacobian || before.K != after.K || before.B != after.B) {
        return false;
    }
    switch (after.kind) {
        case ObjectKind::Plane: surface_shift = std::fabs(after.offset - before.offset); break;
        case ObjectKind::Spring: surface_shift = 0.0; break;  // no switching surface
        case ObjectKind::Field: {
            double d2 = 0.0;
            for (std::size_t a = 0; a < 3; ++a) d2 += (after.point[a] - before.point[a]) * (after.point[a] - before.point[a]);
            surface_shift = std::sqrt(d2);
            break;
        }
    }
    return std::isfinite(surface_shift);
}

}  // namespace

void SceneObjects::apply_commits() noexcept {
    for (std::size_t n = 0; n < config_.commits_per_tick; ++n) {
        if (!ring_.try_pop(incoming_)) return;
        bool only_moves = true;
        for (std::uint32_t i = 0; i < incoming_.count && i < kSceneObjectCapacity; ++i) {
            const SlotUpdate& u = incoming_.updates[i];
            if (u.slot >= kSceneObjectCapacity) continue;  // the server never sends one; ignore rather than crash
            Slot& slot = slots_[u.slot];
            switch (u.action) {
                case SlotUpdate::Action::Set:
                    only_moves = false;
                    if (slot.current.active) {
                        slot.fading = slot.current;  // cross-fade from wherever the old one is
                        slot.fading.active = ramp_step_ < 1.0;  // no ramp: replaced at once
                    }
                    slot.current.active = true;
                    slot.current.ramp = ramp_step_ >= 1.0 ? 1.0 : 0.0;
                    slot.current.params = u.params;
                    break;
                case SlotUpdate::Action::Move:
                    if (slot.current.active) {
                        double shift = 0.0;
                        if (is_move_of(slot.current.params, u.params, shift)) {
                            moved_mask_ |= std::uint64_t{1} << u.slot;
                            moved_shift_ += shift;
                        } else {
                            only_moves = false;
                        }
                        slot.current.params = u.params;  // same gains, new place: no ramp
                    }
                    break;
                case SlotUpdate::Action::Remove:
                    only_moves = false;
                    if (slot.current.active) {
                        slot.fading = slot.current;
                        slot.fading.active = ramp_step_ < 1.0;  // no ramp: removed at once
                        slot.current.active = false;
                    }
                    break;
            }
        }
        if (!only_moves) {
            scene_changed_ = true;
            ++slot_table_version_;
            count_occupied();
        }
        ++stats_.commits_applied;
        stats_.last_commit_seq = incoming_.seq;
    }
}

// After moves only: the moved objects' constant terms c_i are recomputed and c re-summed in slot order
// from the stored c_i (the same sum a classification would form), their copies in the near lists are
// updated, and the safe radius shrinks by the distance their surfaces moved (each object's distance to the
// handle changes by at most that). K and B are unchanged. Cost: ~3 flops per object for the re-sum.
void SceneObjects::apply_moves() noexcept {
    for (std::uint64_t m = moved_mask_; m != 0; m &= m - 1) {
        const auto s = static_cast<std::size_t>(__builtin_ctzll(m));
        const Entry& e = slots_[s].current;
        EntryPlace& place = place_[2 * s];
        switch (place.list) {
            case EntryPlace::Linear: entry_c_[2 * s] = linear_constant(e.params, e.ramp); break;
            case EntryPlace::NearPlane: near_planes_.offset[place.index] = e.params.offset; break;
            case EntryPlace::NearFlag:
                near_flags_.offset[place.index] = e.params.offset;
                entry_c_[2 * s] = linear_constant(e.params, e.ramp);
                break;
            case EntryPlace::NearField: break;  // evaluated from its params, which the move has updated
            case EntryPlace::None: break;       // out of reach: its distance is covered by the radius below
        }
    }
    AxisVector c{};
    for (std::size_t i = 0; i < 2 * kSceneObjectCapacity; ++i) {
        if (!entry_in_sum_[i]) continue;
        for (std::size_t a = 0; a < 3; ++a) c[a] += entry_c_[i][a];
    }
    linear_.c = c;
    safe_radius_ -= moved_shift_;
    moved_mask_ = 0;
    moved_shift_ = 0.0;
}

void SceneObjects::count_occupied() noexcept {
    std::uint32_t n = 0;
    for (std::size_t s = 0; s < kSceneObjectCapacity; ++s) n += slot_object_id(s) != 0 ? 1U : 0U;
    occupied_ = n;
}

namespace {

constexpr double kEps = std::numeric_limits<double>::epsilon();

double norm1(const AxisVector& a) noexcept { return std::fabs(a[0]) + std::fabs(a[1]) + std::fabs(a[2]); }

}  // namespace

// One linear object's term w (c_i - K_i x - B_i v) of the affine law:
//   plane (bilateral), spring to a plane:  K_i = k u u^T,       B_i = b u u^T,       c_i = k u (u.point)
//   spring to a line (direction u):        K_i = k (I - u u^T), B_i = b (I - u u^T), c_i = k (point - u (u.point))
//   spring to a point:                     K_i = k I,           B_i = b I,           c_i = k point
//   field, handle inside:                  K_i = -J,            B_i = b I,           c_i = F0 - J x0
// (a plane's u.point is its offset). With the ramp factor r the stiffness terms are weighted r^2, the
// damping and a field's constant force r (ramp_weights): add_linear adds r^2 K_i and r B_i;
// linear_constant gives r^2 k (..) or r F0 - r^2 J x0.
void SceneObjects::add_linear(const ObjectParams& p, double r) noexcept {
    const double w = r * r;  // the stiffness weight
    const double wk = w * p.K, wb = r * p.B;
    const AxisVector& u = p.direction;
    AffineLaw& l = linear_;
    l.any = true;
    if (p.kind == ObjectKind::Field) {
        for (std::size_t r = 0; r < 3; ++r) {
            for (std::size_t c = 0; c < 3; ++c) l.K[r][c] -= w * p.jacobian[r][c];
            l.B[r][r] += wb;
        }
        return;
    }
    if (p.kind == ObjectKind::Spring && p.constraint == SpringConstraint::Point) {
        for (std::size_t r = 0; r < 3; ++r) {
            l.K[r][r] += wk;
            l.B[r][r] += wb;
        }
        return;
    }
    if (p.kind == ObjectKind::Spring && p.constraint == SpringConstraint::Line) {  // I - u u^T
        for (std::size_t r = 0; r < 3; ++r) {
            for (std::size_t c = 0; c < 3; ++c) {
                const double P = (r == c ? 1.0 : 0.0) - u[r] * u[c];
                l.K[r][c] += wk * P;
                l.B[r][c] += wb * P;
            }
        }
        return;
    }
    for (std::size_t r = 0; r < 3; ++r) {  // u u^T
        const double kr = wk * u[r], br = wb * u[r];
        for (std::size_t c = 0; c < 3; ++c) {
            l.K[r][c] += kr * u[c];
            l.B[r][c] += br * u[c];
        }
    }
}

AxisVector SceneObjects::linear_constant(const ObjectParams& p, double ramp) noexcept {
    AxisVector c{};
    const double w = ramp * ramp;  // the stiffness weight
    const double wk = w * p.K;
    const AxisVector& u = p.direction;
    if (p.kind == ObjectKind::Field) {
        for (std::size_t r = 0; r < 3; ++r) c[r] = ramp * p.force[r] - w * dot(p.jacobian[r], p.point);
    } else if (p.kind == ObjectKind::Spring && p.constraint == SpringConstraint::Point) {
        for (std::size_t r = 0; r < 3; ++r) c[r] = wk * p.point[r];
    } else {
        const double up = p.kind == ObjectKind::Plane ? p.offset : dot(u, p.point);
        const bool line = p.kind == ObjectKind::Spring && p.constraint == SpringConstraint::Line;
        for (std::size_t r = 0; r < 3; ++r) c[r] = line ? wk * (p.point[r] - u[r] * up) : wk * u[r] * up;
    }
    return c;
}

namespace {

// A plane's geometry and slot appended to a near list (NearPlanes or NearFlags); count grows by one.
template <class List>
void append_plane(List& n, const ObjectParams& p, std::size_t slot) noexcept {
    n.nx[n.count] = p.direction[0];
    n.ny[n.count] = p.direction[1];
    n.nz[n.count] = p.direction[2];
    n.offset[n.count] = p.offset;
    n.slot[n.count++] = static_cast<std::uint8_t>(slot);
}

}  // namespace

void SceneObjects::classify(const AxisVector& x) noexcept {
    ++classifications_;
    linear_ = AffineLaw{};
    near_planes_.count = 0;
    near_flags_.count = 0;
    near_fields_.count = 0;
    static_mask_ = 0;
    ramping_ = 0;
    moved_mask_ = 0;
    moved_shift_ = 0.0;
    place_.fill(EntryPlace{});
    entry_in_sum_.fill(false);
    double rho = std::numeric_limits<double>::infinity();
    const double x1 = norm1(x);
    double scale = x1;
    for (std::size_t s = 0; s < kSceneObjectCapacity; ++s) {
        const Slot& slot = slots_[s];
        const std::uint64_t bit = std::uint64_t{1} << s;
        for (std::size_t which = 0; which < 2; ++which) {
            const Entry* e = which == 0 ? &slot.current : &slot.fading;
            if (!e->active) continue;
            if (which == 1 || e->ramp < 1.0) ++ramping_;
            const ObjectParams& p = e->params;
            const double w = e->ramp;
            const std::size_t k = 2 * s + which;
            auto sum_linear = [&] {
                add_linear(p, w);
                entry_c_[k] = linear_constant(p, w);
                entry_in_sum_[k] = true;
                place_[k] = EntryPlace{EntryPlace::Linear, 0};
            };
            switch (p.kind) {
                case ObjectKind::Plane: {
                    const double d = p.offset - dot(p.direction, x);
                    const double ad = std::fabs(d);
                    const double sc = std::fabs(p.offset) + x1;
                    scale = sc > scale ? sc : scale;
                    if (p.bilateral) {
                        sum_linear();
                        if (ad >= kNearDistance) {
                            if (d > 0.0) static_mask_ |= bit;
                            rho = ad < rho ? ad : rho;
                        } else {
                            place_[k] = EntryPlace{EntryPlace::NearFlag, static_cast<std::uint8_t>(near_flags_.count)};
                            append_plane(near_flags_, p, s);
                        }
                    } else if (d <= -kNearDistance) {
                        rho = ad < rho ? ad : rho;  // out of contact and far from it: no force, no flag
                    } else {
                        NearPlanes& n = near_planes_;
                        place_[k] = EntryPlace{EntryPlace::NearPlane, static_cast<std::uint8_t>(n.count)};
                        n.K[n.count] = w * w * p.K;  // the ramp's weights: r^2 for the stiffness, r for the damping
                        n.B[n.count] = w * p.B;
                        append_plane(n, p, s);
                    }
                    break;
                }
                case ObjectKind::Spring:
                    sum_linear();
                    static_mask_ |= bit;
                    break;
                case ObjectKind::Field: {
                    AxisVector r{};
                    for (std::size_t a = 0; a < 3; ++a) r[a] = x[a] - p.point[a];
                    const double e_dist = std::sqrt(dot(r, r)) - p.radius;
                    const double ae = std::fabs(e_dist);
                    const double sc = norm1(p.point) + p.radius + x1;
                    scale = sc > scale ? sc : scale;
                    if (e_dist <= -kNearDistance) {
                        sum_linear();
                        static_mask_ |= bit;
                        rho = ae < rho ? ae : rho;
                    } else if (e_dist >= kNearDistance) {
                        rho = ae < rho ? ae : rho;
                    } else {
                        NearFields& n = near_fields_;
                        place_[k] = EntryPlace{EntryPlace::NearField, static_cast<std::uint8_t>(n.count)};
                        n.params[n.count] = &p;
                        n.w[n.count] = w;
                        n.slot[n.count++] = static_cast<std::uint8_t>(s);
                    }
                    break;
                }
            }
        }
    }
    AxisVector c{};
    for (std::size_t i = 0; i < 2 * kSceneObjectCapacity; ++i) {
        if (!entry_in_sum_[i]) continue;
        for (std::size_t a = 0; a < 3; ++a) c[a] += entry_c_[i][a];
    }
    linear_.c = c;
    // The distances above carry a rounding error below ~3 eps (scale + ||x - x_ref||_1); 16 eps (scale +
    // 2 rho) bounds it with room for the norm of the displacement.
    reference_ = x;
    safe_radius_ = std::isfinite(rho) ? rho - 16.0 * kEps * (scale + 2.0 * rho) : rho;
    scene_changed_ = false;
}

void SceneObjects::step_ramps() noexcept {
    for (std::size_t s = 0; s < kSceneObjectCapacity; ++s) {
        Slot& slot = slots_[s];
        if (slot.current.active && slot.current.ramp < 1.0) {
            slot.current.ramp = slot.current.ramp + ramp_step_ >= 1.0 ? 1.0 : slot.current.ramp + ramp_step_;
        }
        if (slot.fading.active) {
            slot.fading.ramp -= ramp_step_;
            if (slot.fading.ramp <= 0.0) {
                slot.fading.active = false;
                slot.fading.ramp = 0.0;
            }
        }
    }
    scene_changed_ = true;
    ++slot_table_version_;
    count_occupied();
}

bool SceneObjects::add_forces(const AxisVector& position, AxisVector& force) noexcept {
    // Everything is accumulated in locals and written to `force` once (through the reference every += would
    // be a load and a store: the compiler cannot assume `force` does not alias the members).
    const double x0 = config_.axes > 0 ? position[0] : 0.0;
    const double x1 = config_.axes > 1 ? position[1] : 0.0;
    const double x2 = config_.axes > 2 ? position[2] : 0.0;
    const AxisVector x{x0, x1, x2};
    double v0 = 0.0, v1 = 0.0, v2 = 0.0;
    if (primed_) {
        v0 = (x0 - previous_position_[0]) * inverse_period_;
        v1 = (x1 - previous_position_[1]) * inverse_period_;
        v2 = (x2 - previous_position_[2]) * inverse_period_;
    }
    primed_ = true;
    velocity_ = {v0, v1, v2};
    previous_position_ = x;

    const double d0 = x0 - reference_[0], d1 = x1 - reference_[1], d2 = x2 - reference_[2];
    const double moved2 = d0 * d0 + d1 * d1 + d2 * d2;
    if (moved_mask_ != 0 && !scene_changed_) apply_moves();
    // !(a < b) also re-classifies on a NaN (whose forces then fail the finite check below).
    if (scene_changed_ || !(moved2 < safe_radius_ * safe_radius_) || !(safe_radius_ > 0.0)) classify(x);

    double f0 = force[0], f1 = force[1], f2 = force[2];
    if (linear_.any) {
        const AffineLaw& l = linear_;
        f0 += l.c[0] - (l.K[0][0] * x0 + l.K[0][1] * x1 + l.K[0][2] * x2) - (l.B[0][0] * v0 + l.B[0][1] * v1 + l.B[0][2] * v2);
        f1 += l.c[1] - (l.K[1][0] * x0 + l.K[1][1] * x1 + l.K[1][2] * x2) - (l.B[1][0] * v0 + l.B[1][1] * v1 + l.B[1][2] * v2);
        f2 += l.c[2] - (l.K[2][0] * x0 + l.K[2][1] * x1 + l.K[2][2] * x2) - (l.B[2][0] * v0 + l.B[2][1] * v1 + l.B[2][2] * v2);
    }
    std::uint64_t mask = static_mask_;
    {
        const NearPlanes& n = near_planes_;
        for (std::size_t i = 0; i < n.count; ++i) {
            const double pen = n.offset[i] - (n.nx[i] * x0 + n.ny[i] * x1 + n.nz[i] * x2);
            const double vn = n.nx[i] * v0 + n.ny[i] * v1 + n.nz[i] * v2;
            const double fn = n.K[i] * pen - n.B[i] * vn;
            const bool contact = pen > 0.0;
            const double s = contact && fn > 0.0 ? fn : 0.0;  // unilateral: never pulls
            f0 += s * n.nx[i];
            f1 += s * n.ny[i];
            f2 += s * n.nz[i];
            mask |= static_cast<std::uint64_t>(contact) << n.slot[i];
        }
    }
    {
        const NearFlags& n = near_flags_;
        for (std::size_t i = 0; i < n.count; ++i) {
            const bool contact = n.offset[i] - (n.nx[i] * x0 + n.ny[i] * x1 + n.nz[i] * x2) > 0.0;
            mask |= static_cast<std::uint64_t>(contact) << n.slot[i];
        }
    }
    {
        const NearFields& n = near_fields_;
        for (std::size_t i = 0; i < n.count; ++i) {
            // f = r F0 + r^2 J (x - x0) - r B v inside the radius (the field's law with the ramp's weights)
            const ObjectParams& p = *n.params[i];
            const double r = n.w[i], rr = r * r;
            const AxisVector d{x0 - p.point[0], x1 - p.point[1], x2 - p.point[2]};
            const bool contact = dot(d, d) <= p.radius * p.radius;
            if (contact) {
                f0 += r * p.force[0] + rr * dot(p.jacobian[0], d) - r * p.B * v0;
                f1 += r * p.force[1] + rr * dot(p.jacobian[1], d) - r * p.B * v1;
                f2 += r * p.force[2] + rr * dot(p.jacobian[2], d) - r * p.B * v2;
            }
            mask |= static_cast<std::uint64_t>(contact) << n.slot[i];
        }
    }
    contact_mask_ = mask;
    if (ramping_ > 0) step_ramps();

    if (config_.axes < 2) f1 = 0.0;
    if (config_.axes < 3) f2 = 0.0;
    if (!std::isfinite(f0) || !std::isfinite(f1) || !std::isfinite(f2)) {
        force = AxisVector{};
        previous_total_ = AxisVector{};
        return false;
    }
    // Saturation per axis, then the rate limit on the change (scalars: no store-and-reload of an array).
    const double m = config_.max_force;
    const bool saturated = f0 > m || f0 < -m || f1 > m || f1 < -m || f2 > m || f2 < -m;
    f0 = f0 > m ? m : f0 < -m ? -m : f0;
    f1 = f1 > m ? m : f1 < -m ? -m : f1;
    f2 = f2 > m ? m : f2 < -m ? -m : f2;
    stats_.saturated_ticks += saturated ? 1U : 0U;
    const double p0 = previous_total_[0], p1 = previous_total_[1], p2 = previous_total_[2];
    const double c0 = std::fabs(f0 - p0), c1 = std::fabs(f1 - p1), c2 = std::fabs(f2 - p2);
    const double c01 = c0 > c1 ? c0 : c1;
    const double largest = c01 > c2 ? c01 : c2;
    const double max_step = config_.max_force_rate * config_.period;
    if (largest > max_step) {
        const double scale = max_step / largest;
        f0 = p0 + scale * (f0 - p0);
        f1 = p1 + scale * (f1 - p1);
        f2 = p2 + scale * (f2 - p2);
        ++stats_.rate_limited_ticks;
    }
    previous_total_ = {f0, f1, f2};
    force = {f0, f1, f2};
    return true;
}

std::uint32_t SceneObjects::slot_object_id(std::size_t slot) const noexcept {
    const Slot& s = slots_[slot];
    if (s.current.active) return s.current.params.id;
    if (s.fading.active) return s.fading.params.id;
    return 0;
}

double SceneObjects::slot_ramp(std::size_t slot) const noexcept {
    const Slot& s = slots_[slot];
    if (s.current.active) return s.current.ramp;
    if (s.fading.active) return s.fading.ramp;
    return 0.0;
}

}  // namespace hapticd
