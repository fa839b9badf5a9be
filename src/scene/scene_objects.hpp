// The clients' scene objects as the loop renders them (docs/protocol.md, section 4): 64 preallocated
// slots, each with the object it renders now and the object it is fading out (a cross-fade on a change of
// gains, the ramp-out on removal). Commits arrive from the server thread through a lock-free SPSC ring and
// are applied whole at the start of a tick (all of a batch in the same tick).
//
// Per tick, with x_j the sampled position and v_j = (x_j - x_{j-1}) / T (backward difference; the first
// tick takes v = 0):
//   plane   p = offset - n.x_j, dp = -n.v_j T:   f = n (K p + B dp / T)   (unilateral: only p > 0, f.n >= 0)
//           — for a fixed plane exactly the analysed wall law f_j = K x_j + B (x_j - x_{j-1}) / T along n;
//   spring  r = P (x_j - point):                  f = -K r - B P v_j       (P: the constrained directions)
//   field   ||x_j - x0|| <= radius:               f = F0 + J (x_j - x0) - B v_j
// The damping acts on the device's own velocity, never on the motion of offset/point/center, so moving an
// object by Δ changes its force by K Δ at most (no step beyond what the motion implies).
// Each entry's force is scaled by its ramp factor s in [0, 1], stepped by T / ramp_s per tick. The summed
// force (config walls included) is saturated per axis and its change per tick limited to max_force_rate T
// (infinity norm, scaled as a whole so the direction is kept); a non-finite value latches a fault.
// No allocation, lock, exception or I/O in anything called per tick.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>

#include "devices/device.hpp"
#include "loop/spsc_ring.hpp"

namespace hapticd {

inline constexpr std::size_t kSceneObjectCapacity = 64;

enum class ObjectKind : std::uint8_t { Plane, Spring, Field };
enum class SpringConstraint : std::uint8_t { Point, Line, Plane };

// One object as the loop renders it: plain data, copied through the ring.
struct ObjectParams {
    std::uint32_t id = 0;
    ObjectKind kind = ObjectKind::Plane;
    bool bilateral = false;                               // plane
    SpringConstraint constraint = SpringConstraint::Point;  // spring
    AxisVector direction{};  // plane normal, spring line direction / plane normal (unit)
    double offset = 0.0;     // plane, m
    AxisVector point{};      // spring anchor, field centre x0, m
    double radius = 0.0;     // field, m
    AxisVector force{};      // field F0, N
    std::array<AxisVector, 3> jacobian{};  // field J, N/m (rows)
    double K = 0.0;          // N/m (plane, spring)
    double B = 0.0;          // N s/m (plane, spring, field)
};

struct SlotUpdate {
    enum class Action : std::uint8_t {
        Set,       // a new object, or another description: the old one (if any) fades out, this one ramps in
        Move,      // the same object moved (offset / point / center / F0 only): applied at once, no ramp
        Remove,    // ramp out, then free the slot
    };
    std::uint8_t slot = 0;
    Action action = Action::Set;
    ObjectParams params;
};

// One batch: applied whole in one tick.
struct ObjectCommit {
    std::uint64_t seq = 0;
    std::uint32_t count = 0;
    std::array<SlotUpdate, kSceneObjectCapacity> updates{};
};

using CommitRing = SpscRing<ObjectCommit>;

struct SceneObjectsConfig {
    double period = 1e-3;          // s
    double ramp_time = 0.03;       // s (0: no ramp)
    double max_force = 10.0;       // N per axis
    double max_force_rate = 1e4;   // N/s, infinity norm of the change of the total force
    std::size_t axes = 3;
    std::size_t commits_per_tick = 8;  // bound on the commits applied in one tick
};

struct SceneObjectsStats {
    std::uint64_t commits_applied = 0;
    std::uint64_t last_commit_seq = 0;
    std::uint64_t rate_limited_ticks = 0;
    std::uint64_t saturated_ticks = 0;
};

class SceneObjects {
public:
    // The ring must outlive this object; its consumer is the loop thread (apply_commits()).
    SceneObjects(const SceneObjectsConfig& config, CommitRing& ring);

    // Start of a tick: applies up to commits_per_tick waiting batches. Real-time safe.
    void apply_commits() noexcept;

    // Adds the objects' forces to `force` (the config walls' sum), then saturates and rate-limits the
    // total. Returns false on a non-finite value (force is then zero). Real-time safe.
    bool add_forces(const AxisVector& position, AxisVector& force) noexcept;

    // Forget the last applied total (after a zero-force tick the next may start from zero again).
    void reset_rate_limit() noexcept { previous_total_ = AxisVector{}; }

    [[nodiscard]] std::uint64_t contact_mask() const noexcept { return contact_mask_; }
    [[nodiscard]] std::uint32_t slot_object_id(std::size_t slot) const noexcept;
    [[nodiscard]] double slot_ramp(std::size_t slot) const noexcept;
    [[nodiscard]] std::uint32_t occupied() const noexcept;
    [[nodiscard]] const SceneObjectsStats& stats() const noexcept { return stats_; }
    [[nodiscard]] const AxisVector& velocity() const noexcept { return velocity_; }

private:
    struct Entry {
        bool active = false;
        double ramp = 0.0;  // s in [0, 1]
        ObjectParams params;
    };
    struct Slot {
        Entry current;  // ramps in to 1 (or sits at 1)
        Entry fading;   // ramps out to 0, then inactive
    };

    AxisVector entry_force(const ObjectParams& p, const AxisVector& x, bool& contact) const noexcept;

    SceneObjectsConfig config_;
    CommitRing& ring_;
    std::array<Slot, kSceneObjectCapacity> slots_{};
    ObjectCommit incoming_{};  // preallocated pop target
    double ramp_step_ = 1.0;
    AxisVector previous_position_{};
    AxisVector velocity_{};
    bool primed_ = false;
    AxisVector previous_total_{};
    std::uint64_t contact_mask_ = 0;
    SceneObjectsStats stats_;
};

}  // namespace hapticd
