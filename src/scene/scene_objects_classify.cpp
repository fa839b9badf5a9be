// SPDX-License-Identifier: Apache-2.0
// SceneObjects' classification (scene_objects.hpp, "Switching surfaces, by a safe radius"): which entries go to
// the affine laws, the pressed planes' law and the near lists, the safe radius and P, and the moves that update
// them without re-classifying.
#include "scene/scene_objects.hpp"

#include <cmath>
#include <limits>

#include "scene/scene_objects_detail.hpp"

namespace hapticd {

using scene_objects_detail::dot;
using scene_objects_detail::norm1;

namespace {

constexpr double kEps = std::numeric_limits<double>::epsilon();

// An object's switching surface seen from x: the signed distance (plane: the penetration offset - n.x;
// field: ||x - x0|| - radius, negative inside; a spring has none: 0) and the scale of the terms it is
// computed from, for the rounding tolerance (x1 = ||x||_1). Used by classify() and, for a moved object,
// by apply_moves(), so that both bound the same distance.
struct SurfaceDistance {
    double d = 0.0;
    double scale = 0.0;
};
SurfaceDistance surface_distance(const ObjectParams& p, const AxisVector& x, double x1) noexcept {
    if (p.kind == ObjectKind::Plane) return {p.offset - dot(p.direction, x), std::fabs(p.offset) + x1};
    if (p.kind == ObjectKind::Field) {
        AxisVector r{};
        for (std::size_t a = 0; a < 3; ++a) r[a] = x[a] - p.point[a];
        return {std::sqrt(dot(r, r)) - p.radius, norm1(p.point) + p.radius + x1};
    }
    return {};
}

}  // namespace

// After moves only: the moved objects' constant terms c_i are recomputed and replaced in their law's sum
// (replace_constant), their copies in the near lists are updated, and each moved surface's distance to
// the reference point x_ref is taken anew (one dot product or norm): a bound it kept at the classification
// (the safe radius rho for a far surface, P for a pressed plane) becomes min(bound, new distance). The
// others did not move, so their distances, and the minimum over them, are unchanged: the bounds stay
// exact minima or become smaller, never too large. A surface that moved across x_ref, or to within
// kNearDistance of it, changes how its object is classified (flag, near list): that re-classifies. K and B
// are unchanged. Cost: ~50 flops per moved object, whatever the number of objects.
void SceneObjects::apply_moves() noexcept {
    for (std::uint64_t m = moved_mask_; m != 0; m &= m - 1) {
        const auto s = static_cast<std::size_t>(__builtin_ctzll(m));
        const ObjectParams& p = slots_[s].current.params;
        if (p.kind == ObjectKind::Mesh) continue;  // evaluated every tick from its params: nothing to update
        const double w = slots_[s].current.ramp;
        EntryPlace& place = place_[2 * s];
        const SurfaceDistance sd = surface_distance(p, reference_, reference_norm1_);
        const double d = sd.d;
        const double ad = std::fabs(d);
        scale_ = sd.scale > scale_ ? sd.scale : scale_;
        switch (place.list) {
            case EntryPlace::Linear:
                replace_constant(linear_, entry_c_[2 * s], linear_constant(p, w));
                if (p.kind == ObjectKind::Plane) {  // bilateral, far: its flag is d > 0
                    if (!(ad >= kNearDistance) || (d > 0.0) != (((static_mask_ >> s) & 1U) != 0)) scene_changed_ = true;
                    rho_ = ad < rho_ ? ad : rho_;
                } else if (p.kind == ObjectKind::Field) {  // inside, far from its sphere
                    if (!(d <= -kNearDistance)) scene_changed_ = true;
                    rho_ = ad < rho_ ? ad : rho_;
                }
                break;
            case EntryPlace::Pressed: {
                pressed_planes_.offset[place.index] = p.offset;
                pressed_planes_.rate[place.index] = p.offset_rate;
                pressed_rate_ = std::fabs(p.offset_rate) > pressed_rate_ ? std::fabs(p.offset_rate) : pressed_rate_;
                replace_constant(pressed_, entry_c_[2 * s], linear_constant(p, w));
                least_pressed_ =
                    d < least_pressed_ ? d : least_pressed_;  // may fall to <= 0: the tick's test then fails
                break;
            }
            case EntryPlace::NearPlane:
                near_planes_.offset[place.index] = p.offset;
                near_planes_.rate[place.index] = p.offset_rate;
                break;
            case EntryPlace::NearFlag:
                near_flags_.offset[place.index] = p.offset;
                replace_constant(linear_, entry_c_[2 * s], linear_constant(p, w));
                break;
            case EntryPlace::NearField:
                break;              // evaluated from its params, which the move has updated
            case EntryPlace::None:  // a unilateral plane far out of contact, or a field far outside
                if (p.kind == ObjectKind::Plane ? !(d <= -kNearDistance) : !(d >= kNearDistance)) scene_changed_ = true;
                rho_ = ad < rho_ ? ad : rho_;
                break;
        }
        if (!std::isfinite(d)) scene_changed_ = true;
    }
    set_bounds();
    moved_mask_ = 0;
}

// The safe radius and P from the exact minima rho_ and least_pressed_, less the rounding tolerance: the
// distances carry a rounding error below ~3 eps (scale + ||x - x_ref||_1); 16 eps (scale + 2 rho) bounds it
// with room for the norm of the displacement.
void SceneObjects::set_bounds() noexcept {
    safe_radius_ = std::isfinite(rho_) ? rho_ - 16.0 * kEps * (scale_ + 2.0 * rho_) : rho_;
    pressed_depth_ = pressed_.any ? least_pressed_ - 16.0 * kEps * (scale_ + 2.0 * std::fabs(least_pressed_)) : 0.0;
}

namespace {

// A plane's geometry and slot appended to a near list (NearPlanes or NearFlags); count grows by one.
template <class List>
void append_plane(List& n, const ObjectParams& p, std::size_t slot) noexcept {
    n.nx[n.count] = p.direction[0];
    n.ny[n.count] = p.direction[1];
    n.nz[n.count] = p.direction[2];
    n.offset[n.count] = p.offset;
    n.slot_bit[n.count++] = std::uint64_t{1} << slot;
}

}  // namespace

// Zero planes after the last, up to a multiple of four (add_unilateral takes four at a time); count is
// unchanged. A zero plane has pen = 0: no contact, no force, a zero flag bit.
void SceneObjects::pad_planes(NearPlanes& n) noexcept {
    for (std::size_t i = n.count; i % 4 != 0; ++i) {
        n.nx[i] = n.ny[i] = n.nz[i] = n.offset[i] = n.K[i] = n.B[i] = n.rate[i] = 0.0;
        n.slot_bit[i] = 0;
    }
}

void SceneObjects::classify(const AxisVector& x) noexcept {
    ++classifications_;
    linear_ = AffineLaw{};
    pressed_ = AffineLaw{};
    linear_members_.count = 0;
    pressed_members_.count = 0;
    pressed_planes_.count = 0;
    double least_pressed = std::numeric_limits<double>::infinity();
    double tau = 0.0;
    double pressed_rate = 0.0;
    near_planes_.count = 0;
    near_flags_.count = 0;
    near_fields_.count = 0;
    meshes_.count = 0;
    static_mask_ = 0;
    pressed_mask_ = 0;
    ramping_ = 0;
    moved_mask_ = 0;
    place_.fill(EntryPlace{});
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
                add_linear(linear_, p, w);
                entry_c_[k] = linear_constant(p, w);
                linear_members_.entry[linear_members_.count++] = static_cast<std::uint8_t>(k);
                place_[k] = EntryPlace{EntryPlace::Linear, 0};
            };
            switch (p.kind) {
                case ObjectKind::Plane: {
                    const SurfaceDistance sd = surface_distance(p, x, x1);
                    const double d = sd.d;
                    const double ad = std::fabs(d);
                    scale = sd.scale > scale ? sd.scale : scale;
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
                    } else if (d >= kNearDistance && w * w * p.K > 0.0 && std::isfinite(p.B / (w * p.K))) {
                        // pressed deep: in contact within the safe radius; summed while its clamp is idle
                        add_linear(pressed_, p, w);
                        entry_c_[k] = linear_constant(p, w);
                        pressed_members_.entry[pressed_members_.count++] = static_cast<std::uint8_t>(k);
                        NearPlanes& n = pressed_planes_;
                        place_[k] = EntryPlace{EntryPlace::Pressed, static_cast<std::uint8_t>(n.count)};
                        n.K[n.count] = w * w * p.K;
                        n.B[n.count] = w * p.B;
                        n.rate[n.count] = p.offset_rate;
                        append_plane(n, p, s);
                        pressed_mask_ |= bit;
                        pressed_rate =
                            std::fabs(p.offset_rate) > pressed_rate
                                ? std::fabs(p.offset_rate)
                                : pressed_rate;  // their surfaces do not bound rho: the tick's test covers them
                        least_pressed = ad < least_pressed ? ad : least_pressed;
                        const double t = p.B / (w * p.K);  // b / k = r B / (r^2 K)
                        tau = t > tau ? t : tau;
                    } else {
                        NearPlanes& n = near_planes_;
                        place_[k] = EntryPlace{EntryPlace::NearPlane, static_cast<std::uint8_t>(n.count)};
                        n.K[n.count] = w * w * p.K;  // the ramp's weights: r^2 for the stiffness, r for the damping
                        n.B[n.count] = w * p.B;
                        n.rate[n.count] = p.offset_rate;
                        append_plane(n, p, s);
                    }
                    break;
                }
                case ObjectKind::Spring:
                    sum_linear();
                    static_mask_ |= bit;
                    break;
                case ObjectKind::Mesh:  // its proxy every tick (add_meshes); no surface bounds the safe radius
                    meshes_.entry[meshes_.count++] = static_cast<std::uint8_t>(k);
                    break;
                case ObjectKind::Field: {
                    const SurfaceDistance sd = surface_distance(p, x, x1);
                    const double e_dist = sd.d;
                    const double ae = std::fabs(e_dist);
                    scale = sd.scale > scale ? sd.scale : scale;
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
    pad_planes(near_planes_);
    pad_planes(pressed_planes_);
    start_constants(linear_, linear_members_);
    start_constants(pressed_, pressed_members_);
    reference_ = x;
    reference_norm1_ = x1;
    scale_ = scale;
    rho_ = rho;
    least_pressed_ = least_pressed;
    set_bounds();
    pressed_tau_ = tau;
    pressed_rate_ = pressed_rate;
    scene_changed_ = false;
}

}  // namespace hapticd
