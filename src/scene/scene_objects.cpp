// SPDX-License-Identifier: Apache-2.0
#include "scene/scene_objects.hpp"

#include <cmath>
#include <cstring>
#include <limits>
#include <stdexcept>
#include <string>

namespace hapticd {

namespace {

double dot(const AxisVector& a, const AxisVector& b) noexcept { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }
double norm1(const AxisVector& a) noexcept { return std::fabs(a[0]) + std::fabs(a[1]) + std::fabs(a[2]); }
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
    }
    return false;
}

namespace {

// True when the batch only moves objects: no Set, no Remove (a Move that is not a move of the slot's
// object changes its gains without a ramp and counts as a change; the server never sends one).
bool only_moves_in(const ObjectCommit& c) noexcept {
    for (std::uint32_t i = 0; i < c.count && i < kSceneObjectCapacity; ++i) {
        if (c.updates[i].action != SlotUpdate::Action::Move) return false;
    }
    return true;
}

std::uint64_t slots_of(const ObjectCommit& c) noexcept {
    std::uint64_t m = 0;
    for (std::uint32_t i = 0; i < c.count && i < kSceneObjectCapacity; ++i) {
        if (c.updates[i].slot < kSceneObjectCapacity) m |= std::uint64_t{1} << c.updates[i].slot;
    }
    return m;
}

}  // namespace

bool SceneObjects::ramp_running() const noexcept {
    if (ramp_step_ >= 1.0) return false;  // no ramps at all
    for (const Slot& slot : slots_) {
        if (slot.fading.active || (slot.current.active && slot.current.ramp < 1.0)) return true;
    }
    return false;
}

// Batches are taken in ring order, at most commits_per_tick per tick. One that adds, changes or removes
// objects (it starts ramps) while another batch's ramps are running, or while an earlier such batch is
// held, is held (copied into held_, in order) and applied at the first tick with no ramp running: at most
// one batch ramps at a time, from the scene every earlier batch has reached, which is what the server
// checked (docs/protocol.md, section 5). Batches of moves only are never held: one whose slots no held
// batch touches is applied at once (it changes no gain, and the held batches no slot of it); one that
// moves an object a held batch adds or changes waits in the ring behind it, and the batches after it too.
// last_commit_seq stays below the oldest held batch's seq until it is applied ("every batch up to this seq
// is applied"). Departures go first (take_departures), at every step: the ring's front is read before the
// departure ring is looked at, so a departure the server sent before that batch is seen first.
void SceneObjects::apply_commits() noexcept {
    if (departures_ != nullptr) (void)take_departures();
    if (held_count_ == 0 && ring_.front() == nullptr) return;  // the usual tick: nothing to do
    for (std::size_t n = 0; n < config_.commits_per_tick; ++n) {
        const ObjectCommit* c = ring_.front();
        if (departures_ != nullptr && take_departures()) continue;
        if (held_count_ > 0 && !ramp_running()) {
            apply(held_[held_first_]);
            pop_held();
            continue;
        }
        if (c == nullptr) break;
        if (only_moves_in(*c)) {
            if ((slots_of(*c) & held_slots_) != 0) break;  // waits behind the held batch that touches its slot
        } else if (held_count_ > 0 || ramp_running()) {
            if (held_count_ == held_.size()) break;  // full: it waits in the ring
            held_[(held_first_ + held_count_) % held_.size()] = *c;
            ++held_count_;
            held_slots_ |= slots_of(*c);
            ++stats_.commits_held;
            if (observer_ != nullptr) observer_->on_taken(*c, CommitSource::Ring);
            ring_.pop();
            continue;
        }
        if (observer_ != nullptr) observer_->on_taken(*c, CommitSource::Ring);
        apply(*c);
        ring_.pop();
    }
    const std::uint64_t before_held = held_count_ > 0 ? held_[held_first_].seq - 1 : applied_seq_;
    stats_.last_commit_seq = before_held < applied_seq_ ? before_held : applied_seq_;
}

void SceneObjects::pop_held() noexcept {
    held_first_ = (held_first_ + 1) % held_.size();
    --held_count_;
    held_slots_ = 0;
    for (std::size_t i = 0; i < held_count_; ++i) held_slots_ |= slots_of(held_[(held_first_ + i) % held_.size()]);
}

// Every departure waiting in the second ring, in order. For each: the ramps in progress jump to their end,
// every batch the server sent before it (held here, or still in the ring: seq below the departure's) is
// applied at once, in order, at its final state — the scene the server's model had when it planned the
// departure, which it checked — and then the departure's ramp-out starts from there, the scenes
// plan_departure checked. Bounded: each batch is applied once, the rings and held_ hold 64 each.
bool SceneObjects::take_departures() noexcept {
    bool any = false;
    for (const ObjectCommit* d = departures_->front(); d != nullptr; d = departures_->front()) {
        finish_ramps();
        while (held_count_ > 0) {
            apply(held_[held_first_], true);
            ++stats_.commits_jumped;
            pop_held();
        }
        for (const ObjectCommit* c = ring_.front(); c != nullptr && c->seq < d->seq; c = ring_.front()) {
            if (observer_ != nullptr) observer_->on_taken(*c, CommitSource::Jumped);
            apply(*c, true);
            ++stats_.commits_jumped;
            ring_.pop();
        }
        if (observer_ != nullptr) observer_->on_taken(*d, CommitSource::Departure);
        apply(*d);
        ++stats_.departures_applied;
        departures_->pop();
        any = true;
    }
    if (any) stats_.last_commit_seq = applied_seq_;
    return any;
}

// Every ramp in progress at its end: objects ramping in at weight 1, fading ones gone.
void SceneObjects::finish_ramps() noexcept {
    bool changed = false;
    for (Slot& slot : slots_) {
        if (slot.fading.active) {
            slot.fading.active = false;
            changed = true;
        }
        if (slot.current.active && slot.current.ramp < 1.0) {
            slot.current.ramp = 1.0;
            changed = true;
        }
    }
    if (changed) {
        scene_changed_ = true;
        ++slot_table_version_;
        count_occupied();
    }
}

// The slot's current object starts to fade out from its ramp factor now (1 unless a batch was applied
// while its ramp ran, which apply_commits prevents); without ramps it is gone at once.
void SceneObjects::start_fading(Slot& slot) noexcept {
    slot.fading = slot.current;
    slot.fading.active = ramp_step_ < 1.0;
    slot.fading.start = slot.current.ramp;
    slot.fading.steps = 0;
}

void SceneObjects::apply(const ObjectCommit& commit, bool at_once) noexcept {
    bool only_moves = true;
    for (std::uint32_t i = 0; i < commit.count && i < kSceneObjectCapacity; ++i) {
        const SlotUpdate& u = commit.updates[i];
        if (u.slot >= kSceneObjectCapacity) continue;  // the server never sends one; ignore rather than crash
        Slot& slot = slots_[u.slot];
        switch (u.action) {
            case SlotUpdate::Action::Set:
                only_moves = false;
                note_new_object(u.slot, u.params, !slot.current.active);
                if (slot.current.active) start_fading(slot);  // cross-fade from wherever the old one is
                if (at_once) slot.fading.active = false;
                slot.current.active = true;
                slot.current.ramp = ramp_step_ >= 1.0 || at_once ? 1.0 : 0.0;
                slot.current.steps = 0;
                slot.current.params = u.params;
                break;
            case SlotUpdate::Action::Move:
                if (slot.current.active) {
                    if (is_move(slot.current.params, u.params)) {  // same gains, new place: no ramp
                        begin_glide(u.slot, u.params);
                    } else {
                        only_moves = false;
                        cancel_glide(u.slot);
                        slot.current.params = u.params;
                    }
                }
                break;
            case SlotUpdate::Action::Remove:
                only_moves = false;
                cancel_glide(u.slot);
                if (slot.current.active) {
                    start_fading(slot);
                    slot.current.active = false;
                }
                if (at_once) slot.fading.active = false;
                break;
            case SlotUpdate::Action::Cut:
                only_moves = false;
                cancel_glide(u.slot);
                slot.current.active = false;
                slot.fading.active = false;
                break;
        }
    }
    if (!only_moves) {
        scene_changed_ = true;
        ++slot_table_version_;
        count_occupied();
    }
    ++stats_.commits_applied;
    applied_seq_ = commit.seq > applied_seq_ ? commit.seq : applied_seq_;
}

namespace {

// Knuth's TwoSum (TAOCP vol. 2, section 4.2.2, theorem B): s = fl(a + b) and the exact error e, a + b = s + e.
// 6 flops, exact in any rounding-to-nearest arithmetic without reassociation.
void two_sum(double a, double b, double& s, double& e) noexcept {
    s = a + b;
    const double bv = s - a;
    e = (a - (s - bv)) + (b - bv);
}

}  // namespace

// A moved entry's constant term replaced in its law's running sum: sum - before + after, each step by
// TwoSum with the errors kept in carry, so that c = sum + carry is the exact sum of the entries' terms up to
// eps |c| + (moves + 1) eps^2 (sum of the terms' magnitudes) — a compensated sum (Neumaier 1974, Higham 2002
// section 4.3): a client moving a proxy every tick for days drifts by nothing that matters, without a
// re-sum of the n entries (whose chain of additions cost ~70 ns for 64 entries).
void SceneObjects::replace_constant(AffineLaw& l, AxisVector& stored, const AxisVector& now) noexcept {
    for (std::size_t a = 0; a < 3; ++a) {
        double s1 = 0.0, e1 = 0.0, s2 = 0.0, e2 = 0.0;
        two_sum(l.sum[a], -stored[a], s1, e1);
        two_sum(s1, now[a], s2, e2);
        l.sum[a] = s2;
        l.carry[a] += e1 + e2;
        l.c[a] = l.sum[a] + l.carry[a];
    }
    stored = now;
}

void SceneObjects::start_constants(AffineLaw& l, const Members& m) const noexcept {
    l.sum = sum_constants(m);
    l.carry = AxisVector{};
    l.c = l.sum;
}

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

void SceneObjects::count_occupied() noexcept {
    std::uint32_t n = 0;
    std::uint64_t mask = 0;
    for (std::size_t s = 0; s < kSceneObjectCapacity; ++s) {
        const bool used = slot_object_id(s) != 0;
        n += used ? 1U : 0U;
        mask |= static_cast<std::uint64_t>(used) << s;
    }
    occupied_ = n;
    occupied_mask_ = mask;
}

// The members' constant terms summed in four partial sums (entries i = 0, 1, 2, 3 mod 4), then
// (s0 + s1) + (s2 + s3): four independent chains of additions instead of one (a classification's sum).
// Rounding: at most (n / 4 + 2) eps times the sum of the magnitudes (Higham 2002, section 4.2), within the
// bound of recursive summation.
AxisVector SceneObjects::sum_constants(const Members& m) const noexcept {
    double s[4][3] = {};
    std::size_t i = 0;
    for (; i + 4 <= m.count; i += 4) {
        for (std::size_t j = 0; j < 4; ++j) {
            const AxisVector& c = entry_c_[m.entry[i + j]];
            s[j][0] += c[0];
            s[j][1] += c[1];
            s[j][2] += c[2];
        }
    }
    for (std::size_t j = 0; i < m.count; ++i, ++j) {
        const AxisVector& c = entry_c_[m.entry[i]];
        s[j][0] += c[0];
        s[j][1] += c[1];
        s[j][2] += c[2];
    }
    return {(s[0][0] + s[1][0]) + (s[2][0] + s[3][0]), (s[0][1] + s[1][1]) + (s[2][1] + s[3][1]),
            (s[0][2] + s[1][2]) + (s[2][2] + s[3][2])};
}

// One linear object's term w (c_i - K_i x - B_i v) of the affine law:
//   plane (bilateral), spring to a plane:  K_i = k u u^T,       B_i = b u u^T,       c_i = k u (u.point)
//   spring to a line (direction u):        K_i = k (I - u u^T), B_i = b (I - u u^T), c_i = k (point - u (u.point))
//   spring to a point:                     K_i = k I,           B_i = b I,           c_i = k point
//   field, handle inside:                  K_i = -J,            B_i = b I,           c_i = F0 - J x0
// (a plane's u.point is its offset). With the ramp factor r the stiffness terms are weighted r^2, the
// damping and a field's constant force r (ramp_weights): add_linear adds r^2 K_i and r B_i;
// linear_constant gives r^2 k (..) or r F0 - r^2 J x0.
void SceneObjects::add_linear(AffineLaw& l, const ObjectParams& p, double r) noexcept {
    const double w = r * r;  // the stiffness weight
    const double wk = w * p.K, wb = r * p.B;
    const AxisVector& u = p.direction;
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
    // The damping relative to the object's motion: + r B (the rate in the damped directions).
    const double wb = ramp * p.B;
    if (p.kind == ObjectKind::Plane) {
        for (std::size_t r = 0; r < 3; ++r) c[r] += wb * p.offset_rate * u[r];
    } else if (p.kind == ObjectKind::Spring && p.constraint == SpringConstraint::Plane) {
        const double ur = dot(u, p.point_rate);
        for (std::size_t r = 0; r < 3; ++r) c[r] += wb * ur * u[r];
    } else if (p.kind == ObjectKind::Spring && p.constraint == SpringConstraint::Line) {
        const double ur = dot(u, p.point_rate);
        for (std::size_t r = 0; r < 3; ++r) c[r] += wb * (p.point_rate[r] - u[r] * ur);
    } else {
        for (std::size_t r = 0; r < 3; ++r) c[r] += wb * p.point_rate[r];
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

// Ramp factors are counted in whole ticks, r = j step (in) and start - j step (out), not summed step by
// step: the same arithmetic as GainChecker::ramp_is_stable, so the loop renders the very weights the
// server checked (a sum of j steps drifts by up to j eps and can take one tick more to reach 1).
void SceneObjects::step_ramps() noexcept {
    for (std::size_t s = 0; s < kSceneObjectCapacity; ++s) {
        Slot& slot = slots_[s];
        if (slot.current.active && slot.current.ramp < 1.0) {
            const double r = static_cast<double>(++slot.current.steps) * ramp_step_;
            slot.current.ramp = r >= 1.0 ? 1.0 : r;
        }
        if (slot.fading.active) {
            const double r = slot.fading.start - static_cast<double>(++slot.fading.steps) * ramp_step_;
            slot.fading.ramp = r > 0.0 ? r : 0.0;
            slot.fading.active = r > 0.0;
        }
    }
    scene_changed_ = true;
    ++slot_table_version_;
    count_occupied();
}

// f += sum_i max(k_i p_i - b_i n_i.v, 0) n_i over the planes with p_i = offset_i - n_i.x > 0, mask |= their
// slots' bits. Four planes at a time in the lanes of a 4-double vector (GCC's vector extension: two SSE2
// registers on baseline x86-64, one AVX2 register in the avx2 clone chosen at load time), with the clamp and
// the contact test as lane masks, not branches: the flags of planes the handle moves across flip from tick
// to tick and a branch on them mispredicts; the flags are each lane's slot bit ANDed with its contact mask
// and ORed across lanes once at the end (a shift per lane took about a third of the loop's samples in
// perf). The lists are padded with zero planes to a multiple of four (pen = 0: no contact, no force). Each lane is its
// own partial sum, added (l0 + l1) + (l2 + l3) at the end. Rounding: at most (n / 4 + 2) eps of the magnitudes (Higham
// 2002, section 4.2).
namespace {
using Lanes = double __attribute__((vector_size(32)));
using LaneMask = std::int64_t __attribute__((vector_size(32)));
// Into a reference, not returned: a 32-byte vector return value has another ABI with AVX than without.
void load_lanes(Lanes& r, const double* p) noexcept { std::memcpy(&r, p, sizeof r); }
}  // namespace

// The sanitizers' runtimes are not set up when an ifunc resolver runs (at load time), so a TSan binary
// with target_clones crashed before main: sanitizer builds take the baseline version only.
#if defined(__SANITIZE_THREAD__) || defined(__SANITIZE_ADDRESS__)
#define HAPTICD_UNILATERAL_CLONES
#else
#define HAPTICD_UNILATERAL_CLONES __attribute__((target_clones("avx2", "default")))
#endif
HAPTICD_UNILATERAL_CLONES
void SceneObjects::add_unilateral(const NearPlanes& n, const double (&x)[3], const double (&v)[3], double (&f)[3],
                                  std::uint64_t& mask) noexcept {
    const double x0 = x[0], x1 = x[1], x2 = x[2], v0 = v[0], v1 = v[1], v2 = v[2];
    Lanes a0{}, a1{}, a2{};
    LaneMask m{};
    for (std::size_t i = 0; i < n.count; i += 4) {
        Lanes nx, ny, nz, offset, K, B, rate;
        LaneMask bits;
        load_lanes(nx, &n.nx[i]);
        load_lanes(ny, &n.ny[i]);
        load_lanes(nz, &n.nz[i]);
        load_lanes(offset, &n.offset[i]);
        load_lanes(K, &n.K[i]);
        load_lanes(B, &n.B[i]);
        load_lanes(rate, &n.rate[i]);
        std::memcpy(&bits, &n.slot_bit[i], sizeof bits);
        const Lanes pen = offset - (nx * x0 + ny * x1 + nz * x2);
        const Lanes vn = nx * v0 + ny * v1 + nz * v2 - rate;  // relative to the surface's motion
        const Lanes fn = K * pen - B * vn;
        const LaneMask contact = pen > 0.0;
        const LaneMask keep = contact & (fn > 0.0);  // unilateral: never pulls
        const Lanes s = reinterpret_cast<Lanes>(reinterpret_cast<LaneMask>(fn) & keep);
        a0 += s * nx;
        a1 += s * ny;
        a2 += s * nz;
        m |= contact & bits;  // a lane's contact mask is all ones or all zeros
    }
    f[0] += (a0[0] + a0[1]) + (a0[2] + a0[3]);
    f[1] += (a1[0] + a1[1]) + (a1[2] + a1[3]);
    f[2] += (a2[0] + a2[1]) + (a2[2] + a2[3]);
    mask |= static_cast<std::uint64_t>((m[0] | m[1]) | (m[2] | m[3]));
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
    contact_mask_ = mask;
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
        return;
    }
    if (move_hold_max_ == 0) {
        p.offset = commanded.offset;
        p.point = commanded.point;
        p.force = commanded.force;
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
