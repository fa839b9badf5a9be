// SPDX-License-Identifier: Apache-2.0
// SceneObjects (scene_objects.hpp): construction, the tick's force (add_forces: the objects' laws summed onto the
// config walls' sum, checked finite) and what the tests observe (rendered_gains, the slots). The other concerns
// are in files of their own: scene_objects_batches.cpp (batches, departures, ramps), scene_objects_affine.cpp (the
// affine laws and their compensated sums), scene_objects_classify.cpp (classification, the safe radius, moves),
// scene_objects_unilateral.cpp (the vectorised unilateral planes), scene_objects_glides.cpp (move holds, activation),
// scene_objects_law_change.cpp (what the scene changed in the law, for the force limiter).
#include "scene/scene_objects.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

#include "scene/scene_objects_detail.hpp"

namespace hapticd {

using scene_objects_detail::dot;
using scene_objects_detail::norm1;

SceneObjects::SceneObjects(const SceneObjectsConfig& config, CommitRing& ring, CommitRing* departures)
    : config_(config), ring_(ring), departures_(departures) {
    if (!(config_.period > 0.0) || !std::isfinite(config_.period)) {
        throw std::invalid_argument("SceneObjects: period = " + std::to_string(config_.period) +
                                    " is invalid; accepted range: finite, > 0");
    }
    velocity_filter_.emplace(config_.velocity, config_.period);
    if (!(config_.ramp_time >= 0.0) || !std::isfinite(config_.ramp_time)) {
        throw std::invalid_argument("SceneObjects: ramp_time = " + std::to_string(config_.ramp_time) +
                                    " is invalid; accepted range: finite, >= 0 s");
    }
    inverse_period_ = 1.0 / config_.period;
    for (std::size_t k = 0; k < proxy_of_.size(); ++k) proxy_of_[k] = static_cast<std::uint8_t>(k);
    held_.resize(kHeldCommitCapacity);  // preallocated here, never in the loop
    ramp_step_ = config_.ramp_time > 0.0 ? config_.period / config_.ramp_time : 1.0;
    if (ramp_step_ > 1.0) ramp_step_ = 1.0;
    if (!(config_.move_interval_max >= 0.0) || !(config_.move_interval_max <= 10.0)) {
        throw std::invalid_argument("SceneObjects: move_interval_max = " + std::to_string(config_.move_interval_max) +
                                    " is invalid; accepted range: 0 .. 10 s");
    }
    if (!(config_.activation_speed >= 0.0) || !std::isfinite(config_.activation_speed)) {
        throw std::invalid_argument("SceneObjects: activation_speed = " + std::to_string(config_.activation_speed) +
                                    " is invalid; accepted range: finite, >= 0 m/s");
    }
    move_hold_max_ = static_cast<std::uint32_t>(std::floor(config_.move_interval_max / config_.period + 0.5));
    activation_step_ = config_.activation_speed * config_.period;
    activation_tail_fraction_ = std::min(1.0, config_.period / kActivationTailTime);
}

bool is_move(const ObjectParams& before, const ObjectParams& after) noexcept {
    if (before.id != after.id || before.kind != after.kind || before.K != after.K || before.B != after.B) return false;
    switch (after.kind) {
        case ObjectKind::Plane:
            return before.bilateral == after.bilateral && before.direction == after.direction;
        case ObjectKind::Spring:
            return before.constraint == after.constraint && before.direction == after.direction;
        case ObjectKind::Field:
            return before.radius == after.radius && before.jacobian == after.jacobian;
        case ObjectKind::Mesh:
            return before.mesh == after.mesh && before.static_friction == after.static_friction &&
                   before.dynamic_friction == after.dynamic_friction && before.shading == after.shading &&
                   before.crease_angle_deg == after.crease_angle_deg;
    }
    return false;
}

bool SceneObjects::add_forces(const AxisVector& position, AxisVector& force) noexcept {
    // Everything is accumulated in locals and written to `force` once (through the reference every += would
    // be a load and a store: the compiler cannot assume `force` does not alias the members).
    const double x0 = config_.axes > 0 ? position[0] : 0.0;
    const double x1 = config_.axes > 1 ? position[1] : 0.0;
    const double x2 = config_.axes > 2 ? position[2] : 0.0;
    const AxisVector x{x0, x1, x2};
    velocity_ = velocity_filter_->update(x);
    const double v0 = velocity_[0], v1 = velocity_[1], v2 = velocity_[2];

    if ((activation_mask_ | gliding_mask_) != 0) [[unlikely]]
        glide_tick(x);
    law_change_.whole = whole_change_pending_;
    whole_change_pending_ = false;
    ++ticks_;
    const double d0 = x0 - reference_[0], d1 = x1 - reference_[1], d2 = x2 - reference_[2];
    const double moved2 = d0 * d0 + d1 * d1 + d2 * d2;
    if (moved_mask_ != 0 && !scene_changed_) apply_moves();
    // !(a < b) also re-classifies on a NaN (whose forces then fail the finite check below).
    if (scene_changed_ || !(moved2 < safe_radius_ * safe_radius_) || !(safe_radius_ > 0.0)) classify(x);

    const double xs[3] = {x0, x1, x2}, vs[3] = {v0, v1, v2};
    double fs[3] = {force[0], force[1], force[2]};
    if (linear_.any) add_law(linear_, xs, vs, fs);
    std::uint64_t mask = static_mask_;
    if (pressed_.any) {
        // The clamp of every deeply pressed plane is idle if ||d||_1 + tau ||v||_1 <= P (header comment).
        const double reach = std::fabs(d0) + std::fabs(d1) + std::fabs(d2) +
                             pressed_tau_ * (std::fabs(v0) + std::fabs(v1) + std::fabs(v2) + pressed_rate_);
        if (reach <= pressed_depth_) {  // which also proves p > 0: all of them in contact
            add_law(pressed_, xs, vs, fs);
            mask |= pressed_mask_;
            ++pressed_summed_;
        } else {
            add_unilateral(pressed_planes_, xs, vs, fs, mask);
            ++pressed_fallbacks_;
        }
    }
    if (near_planes_.count > 0) add_unilateral(near_planes_, xs, vs, fs, mask);
    double f0 = fs[0], f1 = fs[1], f2 = fs[2];
    {
        const NearFlags& n = near_flags_;
        for (std::size_t i = 0; i < n.count; ++i) {
            const bool contact = n.offset[i] - (n.nx[i] * x0 + n.ny[i] * x1 + n.nz[i] * x2) > 0.0;
            mask |= (std::uint64_t{0} - static_cast<std::uint64_t>(contact)) & n.slot_bit[i];
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
                f0 += r * p.force[0] + rr * dot(p.jacobian[0], d) - r * p.B * (v0 - p.point_rate[0]);
                f1 += r * p.force[1] + rr * dot(p.jacobian[1], d) - r * p.B * (v1 - p.point_rate[1]);
                f2 += r * p.force[2] + rr * dot(p.jacobian[2], d) - r * p.B * (v2 - p.point_rate[2]);
            }
            mask |= static_cast<std::uint64_t>(contact) << n.slot[i];
        }
    }
    if (meshes_.count > 0) {
        double fm[3] = {f0, f1, f2};
        add_meshes(x, velocity_, fm, mask);
        f0 = fm[0];
        f1 = fm[1];
        f2 = fm[2];
    }
    contact_mask_ = mask;
    law_change_.shift = AxisVector{};
    if (shifted_mask_ != 0) [[unlikely]]
        sum_pose_shifts(x, velocity_);
    if (ramping_ > 0) step_ramps();

    if (config_.axes < 2) f1 = 0.0;
    if (config_.axes < 3) f2 = 0.0;
    if (!std::isfinite(f0) || !std::isfinite(f1) || !std::isfinite(f2)) {
        force = AxisVector{};
        return false;
    }
    force = {f0, f1, f2};
    return true;
}

void SceneObjects::add_law(const AffineLaw& l, const double (&x)[3], const double (&v)[3], double (&f)[3]) noexcept {
    for (std::size_t r = 0; r < 3; ++r) {
        f[r] += l.c[r] - (l.K[r][0] * x[0] + l.K[r][1] * x[1] + l.K[r][2] * x[2]) -
                (l.B[r][0] * v[0] + l.B[r][1] * v[1] + l.B[r][2] * v[2]);
    }
}

void SceneObjects::rendered_gains(std::array<AxisVector, 3>& K, std::array<AxisVector, 3>& B) const noexcept {
    AffineLaw l;
    for (const Slot& slot : slots_) {
        if (slot.current.active) add_linear(l, slot.current.params, slot.current.ramp);
        if (slot.fading.active) add_linear(l, slot.fading.params, slot.fading.ramp);
    }
    K = l.K;
    B = l.B;
}

void SceneObjects::rendered_gains(const AxisVector& x, const AxisVector& v, std::array<AxisVector, 3>& K,
                                  std::array<AxisVector, 3>& B, std::uint64_t& engaged) const noexcept {
    AffineLaw l;
    engaged = 0;
    for (std::size_t s = 0; s < kSceneObjectCapacity; ++s) {
        for (const Entry* e : {&slots_[s].current, &slots_[s].fading}) {
            if (!e->active) continue;
            const ObjectParams& p = e->params;
            bool acts = true;
            if (p.kind == ObjectKind::Plane && !p.bilateral) {
                const double pen = p.offset - dot(p.direction, x);
                acts = pen > 0.0 && e->ramp * e->ramp * p.K * pen - e->ramp * p.B * dot(p.direction, v) > 0.0;
            } else if (p.kind == ObjectKind::Field) {
                const AxisVector d{x[0] - p.point[0], x[1] - p.point[1], x[2] - p.point[2]};
                acts = dot(d, d) <= p.radius * p.radius;
            } else if (p.kind == ObjectKind::Mesh) {  // its proxy's state: in contact at the last tick
                acts = ((contact_mask_ >> s) & 1U) != 0;
            }
            if (!acts) continue;
            add_linear(l, p, e->ramp);
            if (engages_conditionally(p)) engaged |= std::uint64_t{1} << s;
        }
    }
    K = l.K;
    B = l.B;
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
