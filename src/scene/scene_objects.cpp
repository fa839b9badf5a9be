#include "scene/scene_objects.hpp"

#include <cmath>
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
    ramp_step_ = config_.ramp_time > 0.0 ? config_.period / config_.ramp_time : 1.0;
    if (ramp_step_ > 1.0) ramp_step_ = 1.0;
}

void SceneObjects::apply_commits() noexcept {
    for (std::size_t n = 0; n < config_.commits_per_tick; ++n) {
        if (!ring_.try_pop(incoming_)) return;
        for (std::uint32_t i = 0; i < incoming_.count && i < kSceneObjectCapacity; ++i) {
            const SlotUpdate& u = incoming_.updates[i];
            if (u.slot >= kSceneObjectCapacity) continue;  // the server never sends one; ignore rather than crash
            Slot& slot = slots_[u.slot];
            switch (u.action) {
                case SlotUpdate::Action::Set:
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
                        slot.current.params = u.params;  // same gains, new place: no ramp
                    }
                    break;
                case SlotUpdate::Action::Remove:
                    if (slot.current.active) {
                        slot.fading = slot.current;
                        slot.fading.active = ramp_step_ < 1.0;  // no ramp: removed at once
                        slot.current.active = false;
                    }
                    break;
            }
        }
        ++stats_.commits_applied;
        stats_.last_commit_seq = incoming_.seq;
    }
}

AxisVector SceneObjects::entry_force(const ObjectParams& p, const AxisVector& x, bool& contact) const noexcept {
    AxisVector f{};
    switch (p.kind) {
        case ObjectKind::Plane: {
            const double pen = p.offset - dot(p.direction, x);
            const double dpen = -dot(p.direction, velocity_) * config_.period;
            double fn = p.K * pen + p.B * dpen / config_.period;
            if (!p.bilateral) {
                if (!(pen > 0.0)) {
                    contact = false;
                    return f;
                }
                if (fn < 0.0) fn = 0.0;
            }
            contact = pen > 0.0;
            for (std::size_t a = 0; a < 3; ++a) f[a] = fn * p.direction[a];
            return f;
        }
        case ObjectKind::Spring: {
            AxisVector r{}, v{};
            for (std::size_t a = 0; a < 3; ++a) r[a] = x[a] - p.point[a];
            if (p.constraint == SpringConstraint::Point) {
                v = velocity_;
            } else {
                const double rd = dot(r, p.direction);
                const double vd = dot(velocity_, p.direction);
                for (std::size_t a = 0; a < 3; ++a) {
                    if (p.constraint == SpringConstraint::Plane) {
                        r[a] = rd * p.direction[a];
                        v[a] = vd * p.direction[a];
                    } else {
                        r[a] -= rd * p.direction[a];
                        v[a] = velocity_[a] - vd * p.direction[a];
                    }
                }
            }
            contact = true;
            for (std::size_t a = 0; a < 3; ++a) f[a] = -p.K * r[a] - p.B * v[a];
            return f;
        }
        case ObjectKind::Field: {
            AxisVector d{};
            for (std::size_t a = 0; a < 3; ++a) d[a] = x[a] - p.point[a];
            if (!(dot(d, d) <= p.radius * p.radius)) {
                contact = false;
                return f;
            }
            contact = true;
            for (std::size_t a = 0; a < 3; ++a) f[a] = p.force[a] + dot(p.jacobian[a], d) - p.B * velocity_[a];
            return f;
        }
    }
    return f;
}

bool SceneObjects::add_forces(const AxisVector& position, AxisVector& force) noexcept {
    AxisVector x{};
    for (std::size_t a = 0; a < config_.axes && a < 3; ++a) x[a] = position[a];
    if (primed_) {
        for (std::size_t a = 0; a < 3; ++a) velocity_[a] = (x[a] - previous_position_[a]) / config_.period;
    } else {
        velocity_ = AxisVector{};
        primed_ = true;
    }
    previous_position_ = x;

    std::uint64_t mask = 0;
    for (std::size_t s = 0; s < kSceneObjectCapacity; ++s) {
        Slot& slot = slots_[s];
        bool any_contact = false;
        for (Entry* e : {&slot.current, &slot.fading}) {
            if (!e->active) continue;
            bool contact = false;
            const AxisVector f = entry_force(e->params, x, contact);
            for (std::size_t a = 0; a < 3; ++a) force[a] += e->ramp * f[a];
            any_contact = any_contact || contact;
        }
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
        if (any_contact) mask |= (std::uint64_t{1} << s);
    }
    contact_mask_ = mask;

    bool saturated = false;
    for (std::size_t a = 0; a < 3; ++a) {
        if (a >= config_.axes) force[a] = 0.0;
        if (!std::isfinite(force[a])) {
            force = AxisVector{};
            previous_total_ = AxisVector{};
            return false;
        }
        if (force[a] > config_.max_force) {
            force[a] = config_.max_force;
            saturated = true;
        } else if (force[a] < -config_.max_force) {
            force[a] = -config_.max_force;
            saturated = true;
        }
    }
    stats_.saturated_ticks += saturated ? 1U : 0U;
    const double max_step = config_.max_force_rate * config_.period;
    double largest = 0.0;
    for (std::size_t a = 0; a < 3; ++a) largest = std::fmax(largest, std::fabs(force[a] - previous_total_[a]));
    if (largest > max_step) {
        const double scale = max_step / largest;
        for (std::size_t a = 0; a < 3; ++a) force[a] = previous_total_[a] + scale * (force[a] - previous_total_[a]);
        ++stats_.rate_limited_ticks;
    }
    previous_total_ = force;
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

std::uint32_t SceneObjects::occupied() const noexcept {
    std::uint32_t n = 0;
    for (std::size_t s = 0; s < kSceneObjectCapacity; ++s) n += slot_object_id(s) != 0 ? 1U : 0U;
    return n;
}

}  // namespace hapticd
