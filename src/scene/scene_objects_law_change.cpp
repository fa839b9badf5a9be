// SPDX-License-Identifier: Apache-2.0
// What the clients' objects changed in the law a tick renders, for the force limiter (SceneObjects::law_change(),
// scene/force_limiter.hpp). Batches other than moves, departures and ramp steps change the law as a whole
// (scene_objects_batches.cpp sets whole_change_pending_); a move changes one object's pose at the same gains, and
// its change of the force is computed here exactly, at the tick's handle position x and velocity estimate v:
//   J = sum over the objects moved since the last tick of  f_i(x, v; pose now) - f_i(x, v; pose before),
// with f_i the object's law as the tick renders it (scene_objects.hpp, "Force laws"; the ramp's weights r^2 on
// stiffness terms, r on damping and a field's F0):
//   plane, unilateral   n max(0, r^2 K p - r B (n.v - offset_rate)) while p = offset - n.x > 0, else 0
//   field               r F0 + r^2 J (x - x0) - r B (v - point_rate) while ||x - x0|| <= radius, else 0
//   plane, bilateral; springs   affine in (x, v) with the same gains before and after: J is the change of the
//                               constant term (linear_constant), the same at every x and v.
// A moved mesh's proxy does not follow its pose affinely: a whole change. Cost: one object's law twice per moved
// object and tick, nothing on a tick without moves.
#include <cmath>

#include "scene/scene_objects.hpp"
#include "scene/scene_objects_detail.hpp"

namespace hapticd {

using scene_objects_detail::dot;

namespace {

// The force of one unilateral plane or field at (x, v) with ramp factor r, as the tick renders it.
AxisVector conditional_law(const ObjectParams& p, double r, const AxisVector& x, const AxisVector& v) noexcept {
    AxisVector f{};
    if (p.kind == ObjectKind::Plane) {
        const double pen = p.offset - dot(p.direction, x);
        const double fn = r * r * p.K * pen - r * p.B * (dot(p.direction, v) - p.offset_rate);
        if (pen > 0.0 && fn > 0.0) {
            for (std::size_t a = 0; a < 3; ++a) f[a] = fn * p.direction[a];
        }
        return f;
    }
    const AxisVector d{x[0] - p.point[0], x[1] - p.point[1], x[2] - p.point[2]};
    if (dot(d, d) <= p.radius * p.radius) {
        for (std::size_t a = 0; a < 3; ++a) {
            f[a] = r * p.force[a] + r * r * dot(p.jacobian[a], d) - r * p.B * (v[a] - p.point_rate[a]);
        }
    }
    return f;
}

}  // namespace

// Before the slot's current object changes its pose: keeps it as it was before the first move since the last tick.
void SceneObjects::note_pose_change(std::size_t s) noexcept {
    const std::uint64_t bit = std::uint64_t{1} << s;
    if (slots_[s].current.params.kind == ObjectKind::Mesh) {
        whole_change_pending_ = true;
        return;
    }
    if ((shifted_mask_ & bit) == 0) before_move_[s] = slots_[s].current.params;
    shifted_mask_ |= bit;
}

void SceneObjects::sum_pose_shifts(const AxisVector& x, const AxisVector& v) noexcept {
    for (std::uint64_t m = shifted_mask_; m != 0; m &= m - 1) {
        const auto s = static_cast<std::size_t>(__builtin_ctzll(m));
        const Entry& e = slots_[s].current;
        if (!e.active) continue;  // removed or cut in the same tick: a whole change
        const ObjectParams& now = e.params;
        const ObjectParams& was = before_move_[s];
        AxisVector change{};
        if (engages_conditionally(now)) {
            const AxisVector a = conditional_law(now, e.ramp, x, v), b = conditional_law(was, e.ramp, x, v);
            for (std::size_t k = 0; k < 3; ++k) change[k] = a[k] - b[k];
        } else {
            const AxisVector a = linear_constant(now, e.ramp), b = linear_constant(was, e.ramp);
            for (std::size_t k = 0; k < 3; ++k) change[k] = a[k] - b[k];
        }
        for (std::size_t k = 0; k < 3; ++k) law_change_.shift[k] += change[k];
    }
    shifted_mask_ = 0;
}

}  // namespace hapticd
