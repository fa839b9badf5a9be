// SPDX-License-Identifier: Apache-2.0
// SceneObjects' moves through a first-order hold and the activation rule for planes appearing around the handle
// (scene_objects.hpp, the last two points of "How a tick is computed"); positions only, never gains.
#include "scene/scene_objects.hpp"

#include <algorithm>
#include <cmath>

#include "scene/scene_objects_detail.hpp"

namespace hapticd {

using scene_objects_detail::dot;
using scene_objects_detail::interpolate_orientation;
using scene_objects_detail::norm1;

// A commanded pose of the slot's object (a Move of the same object). Without interpolation it is rendered at
// once; otherwise from the pose rendered now to the commanded one in a straight line over n ticks, n the
// client's update interval as the loop measures it: the mean of the ticks between this object's successive
// poses, an exponential average with weight 1/4 (two poses applied in one tick count 0 and the late one
// before them its whole wait, so the mean stays the true one while one interval alone would have jumped a
// whole interval ahead), rounded, 1 .. the largest hold. The damping's reference rate is the commanded
// poses' velocity (below). An approaching plane (activation) keeps approaching, now towards this pose.
void SceneObjects::begin_glide(std::size_t s, const ObjectParams& commanded) noexcept {
    const std::uint64_t bit = std::uint64_t{1} << s;
    ObjectParams& p = slots_[s].current.params;
    const double since = static_cast<double>(ticks_ - pose_tick_[s]);
    pose_tick_[s] = ticks_;
    pose_interval_[s] = pose_interval_[s] > 0.0 ? 0.75 * pose_interval_[s] + 0.25 * since : since;
    const double interval = std::floor(pose_interval_[s] + 0.5);
    moved_mask_ |= bit;
    Glide& g = glides_[s];
    const Pose previous = g.to;
    g.to = pose_of(commanded);
    if (g.approaching && (gliding_mask_ & bit) != 0) {
        p.point = commanded.point;  // a plane's pose is its offset; the rest is carried along unchanged
        p.force = commanded.force;
        p.orientation = commanded.orientation;
        return;
    }
    if (move_hold_max_ == 0) {
        note_pose_change(s);
        p.offset = commanded.offset;
        p.point = commanded.point;
        p.force = commanded.force;
        p.orientation = commanded.orientation;
        p.offset_rate = 0.0;
        p.point_rate = AxisVector{};
        gliding_mask_ &= ~bit;
        return;
    }
    g.from = pose_of(p);
    g.step = 0;
    g.settling = false;
    g.steps = interval < 1.0 ? 1U : interval > move_hold_max_ ? move_hold_max_ : static_cast<std::uint32_t>(interval);
    g.approaching = false;
    // The reference rate: the commanded poses' velocity over the ticks that really passed between them (a
    // client samples its path when it sends), averaged with the previous estimate (weight 1/2 each: one
    // pose's timing noise halved); two poses in one tick keep the estimate.
    if (since >= 1.0) {
        const double per_second = inverse_period_ / since;
        const bool first = (gliding_mask_ & bit) == 0 && g.offset_rate == 0.0;
        const double keep = first ? 0.0 : 0.5;
        g.offset_rate = keep * g.offset_rate + (1.0 - keep) * (g.to.offset - previous.offset) * per_second;
        for (std::size_t a = 0; a < 3; ++a) {
            g.point_rate[a] = keep * g.point_rate[a] + (1.0 - keep) * (g.to.point[a] - previous.point[a]) * per_second;
        }
    }
    gliding_mask_ |= bit;
}

// A Set: the slot's new object starts at its commanded pose, at rest; a unilateral plane into an empty slot is
// checked against the handle at its first tick (activate_new_planes).
void SceneObjects::note_new_object(std::size_t s, const ObjectParams& commanded, bool slot_was_empty) noexcept {
    const std::uint64_t bit = std::uint64_t{1} << s;
    cancel_glide(s);
    glides_[s].to = pose_of(commanded);
    pose_tick_[s] = ticks_;
    pose_interval_[s] = 0.0;
    if (slot_was_empty && activation_step_ > 0.0) activation_mask_ |= bit;
}

void SceneObjects::cancel_glide(std::size_t s) noexcept {
    const std::uint64_t bit = std::uint64_t{1} << s;
    gliding_mask_ &= ~bit;
    activation_mask_ &= ~bit;
    glides_[s].approaching = false;
    glides_[s].offset_rate = 0.0;
    glides_[s].point_rate = AxisVector{};
    slots_[s].current.params.offset_rate = 0.0;
    slots_[s].current.params.point_rate = AxisVector{};
}

// The god-object rule: a new unilateral plane with the handle behind its surface (p = offset - n.x > 0) is
// rendered with its surface at the handle (offset n.x, p = 0) and approaches its commanded offset by
// activation_speed T per tick. Other new objects, and planes the handle is in front of, render as commanded.
void SceneObjects::activate_new_planes(const AxisVector& x) noexcept {
    for (std::uint64_t m = activation_mask_; m != 0; m &= m - 1) {
        const auto s = static_cast<std::size_t>(__builtin_ctzll(m));
        ObjectParams& p = slots_[s].current.params;
        if (!slots_[s].current.active || p.kind != ObjectKind::Plane || p.bilateral) continue;
        const double at_handle = dot(p.direction, x);
        if (!(p.offset - at_handle > 0.0)) continue;  // in front of it (or NaN: as commanded)
        Glide& g = glides_[s];
        g.to = pose_of(p);
        p.offset = at_handle;
        g.from = pose_of(p);
        g.approaching = true;
        gliding_mask_ |= std::uint64_t{1} << s;
        scene_changed_ = true;  // a Set re-classifies anyway
    }
    activation_mask_ = 0;
}

// Out of add_forces' hot path: the scenes without moving or appearing objects pay one test.
__attribute__((noinline)) void SceneObjects::glide_tick(const AxisVector& x) noexcept {
    if (activation_mask_ != 0) activate_new_planes(x);
    if (gliding_mask_ != 0) advance_glides();
}

// One tick of a first-order hold (returns true when it has ended):
//  * ticks 1 .. n: from + (to - from) k / n, the rates those of the commanded poses;
//  * ticks n + 1 .. 2n, while no next pose has come: on along the same line, to + rate (k - n) T (a pose
//    one tick late would otherwise stop the surface for a tick: at 12.6 mm/s that is 12.6 um, as much as a
//    hand's contact deflection on a CE2 wall, and the contact tears open);
//  * no pose after 2n ticks (the client stopped): back to the last commanded pose in a straight line over n
//    ticks, the rates those of that return, then at rest. The overshoot is at most one interval's motion.
bool SceneObjects::advance_hold(Glide& g, ObjectParams& p) const noexcept {
    ++g.step;
    const double n = static_cast<double>(g.steps);
    if (g.step <= g.steps) {
        const bool there = g.step == g.steps;
        const double w = static_cast<double>(g.step) / n;
        p.offset = there ? g.to.offset : g.from.offset + w * (g.to.offset - g.from.offset);
        for (std::size_t a = 0; a < 3; ++a) {
            p.point[a] = there ? g.to.point[a] : g.from.point[a] + w * (g.to.point[a] - g.from.point[a]);
            p.force[a] = there ? g.to.force[a] : g.from.force[a] + w * (g.to.force[a] - g.from.force[a]);
        }
        interpolate_orientation(g.from.orientation, g.to.orientation, there ? 1.0 : w, p.orientation);
        p.offset_rate = g.offset_rate;
        p.point_rate = g.point_rate;
        if (there && g.settling) {
            p.offset_rate = g.offset_rate = 0.0;
            p.point_rate = g.point_rate = AxisVector{};
            return true;
        }
        return false;
    }
    if (g.step <= 2 * g.steps && !g.settling) {
        const double ahead = static_cast<double>(g.step - g.steps) * config_.period;
        p.offset = g.to.offset + g.offset_rate * ahead;
        for (std::size_t a = 0; a < 3; ++a) p.point[a] = g.to.point[a] + g.point_rate[a] * ahead;
        p.orientation = g.to.orientation;
        if (g.step < 2 * g.steps) return false;
    }
    // Back to the commanded pose.
    g.from = pose_of(p);
    g.step = 0;
    g.settling = true;
    const double per_second = inverse_period_ / n;
    g.offset_rate = (g.to.offset - g.from.offset) * per_second;
    for (std::size_t a = 0; a < 3; ++a) g.point_rate[a] = (g.to.point[a] - g.from.point[a]) * per_second;
    p.offset_rate = g.offset_rate;
    p.point_rate = g.point_rate;
    return false;
}

// One tick of every glide, written into the object's params and handed to apply_moves as a move (~20 flops
// per gliding object):
//  * approach (activation): the offset advances by min(activation_speed T, gap T / kActivationTailTime)
//    towards its target (at once if the target is behind the rendered surface or within
//    kActivationArrival), offset_rate = that step / T;
//  * first-order hold (advance_hold).
void SceneObjects::advance_glides() noexcept {
    for (std::uint64_t m = gliding_mask_; m != 0; m &= m - 1) {
        const auto s = static_cast<std::size_t>(__builtin_ctzll(m));
        const std::uint64_t bit = std::uint64_t{1} << s;
        Glide& g = glides_[s];
        ObjectParams& p = slots_[s].current.params;
        note_pose_change(s);
        bool done = false;
        if (g.approaching) {
            // v T per tick while the gap exceeds v tau, then the fraction T / tau of the gap (speed gap / tau,
            // continuous at gap = v tau): the surface slows to a stop instead of stopping within one tick.
            const double gap = g.to.offset - p.offset;
            done = !(gap > kActivationArrival);  // reached, or the target is behind the rendered surface: there at once
            const double step = std::min(activation_step_, gap * activation_tail_fraction_);
            p.offset = done ? g.to.offset : p.offset + step;
            p.offset_rate = done ? 0.0 : step * inverse_period_;
            g.approaching = !done;
        } else {
            done = advance_hold(g, p);
        }
        if (done) gliding_mask_ &= ~bit;
        moved_mask_ |= bit;
    }
}

}  // namespace hapticd
