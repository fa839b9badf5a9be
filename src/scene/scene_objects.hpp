// SPDX-License-Identifier: Apache-2.0
// The clients' scene objects as the loop renders them (docs/protocol.md, section 4): 64 preallocated
// slots, each with the object it renders now and the object it is fading out (a cross-fade on a change of
// gains, the ramp-out on removal). Commits arrive from the server thread through a lock-free SPSC ring and
// are applied whole at the start of a tick (all of a batch in the same tick).
//
// Force laws, per tick, with x_j the sampled position and v_j the loop's velocity estimate of it
// (scene/velocity_filter.hpp: the backward difference (x_j - x_{j-1}) / T unless SceneObjectsConfig::velocity names
// another; the first tick takes v = 0):
//   plane   p = offset - n.x_j:                   f = n (K p - B (n.v_j - offset_rate))  (unilateral: only p > 0, f.n
//   >= 0)
//           — for a fixed plane exactly the analysed wall law f_j = K x_j + B (x_j - x_{j-1}) / T along n;
//   spring  r = P (x_j - point):                  f = -K r - B P (v_j - point_rate)   (P: the constrained directions)
//   field   ||x_j - x0|| <= radius:               f = F0 + J (x_j - x0) - B (v_j - point_rate)
// The damping acts on the handle's velocity relative to the object: v_j less the rate of the object's
// interpolated motion (offset_rate, point_rate; zero for an object at rest). A pose applied at once has no
// rate, so moving an object by Δ in one tick changes its force by K Δ at most. The rates are an input, not a
// gain: they change no K or B the server checks.
// Each entry ramps with a factor r in [0, 1], stepped by T / ramp_s per tick: its stiffness terms (K, a
// field's J) are weighted r^2, its damping and a field's constant force F0 r. Damping leads stiffness so
// that a ramp from zero starts damping-dominated: with a delay, small gains are stable only if
// B / K > ~(t_d + T/2) (beta / alpha > d + 1/2), and a linear ramp of both would start outside the region
// for every object with a lower ratio (tests/scene/test_scene_objects.cpp). The server checks every scene
// a ramp renders (docs/protocol.md, section 5); for those to be the scenes the loop renders, one batch ramps
// at a time: a batch that starts ramps while another's run is held until they end (apply_commits).
// A departure (a client that left) comes through a second ring and is never queued behind other batches:
// the loop brings every batch sent before it to its final state at once (take_departures), then starts
// its ramp-out.
// The summed force (config walls included) is checked finite (a non-finite value latches a fault), not saturated or
// rate-limited: the force limiter (force_limiter.hpp) does both on the force written, after the delay buffer.
//
// How a tick is computed (the cost does not grow with the objects that cannot change the force law):
//  * Linear part, in closed form. Springs, bilateral planes and fields with the handle inside them are
//    affine in (x, v): f = r^2 (c_i - K_i x) - r B_i v (+ r F0 for a field). Their sum is one affine law f = c - K x -
//    B v (3-vectors and 3x3 matrices), summed when the scene changes (a commit, a ramp step, a move) and then evaluated
//    in ~20 flops whatever the number of objects. It equals the per-object sum up to rounding (relative ~n eps of the
//    sum of the magnitudes; tests/scene/test_scene_objects_closed_form.cpp compares the two).
//  * Switching surfaces, by a safe radius. Each object whose law or contact flag switches with x has a
//    surface: the plane (p = 0) or the field's sphere (||x - x0|| = radius). At each re-classification the
//    handle's distance to every surface farther than kNearDistance is taken, and their minimum rho. While the
//    handle stays within rho - tol of where it was classified (||x - x_ref||_2, one norm per tick), no such
//    surface can have been crossed (each distance is 1-Lipschitz in x), so their flags and whether they act are
//    unchanged and they cost nothing. tol = 16 eps (scale of offsets, centres, radii and x) bounds the
//    rounding of the distances, so a flag so kept is the sign a direct evaluation would compute except within
//    rounding of the surface itself. Leaving that radius re-classifies (O(n), once per kNearDistance of motion).
//  * Moves (a commit of Move updates only: the same object, another place) do not re-classify: each moved
//    object's constant term c_i is recomputed and replaced in c by a compensated update (TwoSum, the errors
//    carried: exact up to eps |c| + moves eps^2 sum |c_i|), and its surface's distance to x_ref is taken
//    anew: the safe radius and P become the minimum of what they were and that distance (the other
//    surfaces did not move). Only a surface moved across x_ref or to within kNearDistance of it
//    re-classifies. A client moving a proxy every tick costs ~50 flops, whatever the object count.
//  * Unilateral planes pressed deeper than kNearDistance, in closed form while their clamp cannot act. Such a
//    plane i (penetration p_i at the classification, gains k_i = r^2 K, b_i = r B) pushes k_i p - b_i n.v,
//    affine in (x, v), as long as that is >= 0. At x = x_ref + d, p >= p_i - |n.d| >= p_i - ||d||_1 and
//    n.v - w_i <= ||v||_1 + W (w_i the plane's offset_rate, W their largest |w_i|), so
//    ||d||_1 + tau (||v||_1 + W) <= P, with P = min p_i (less the rounding tol) and
//    tau = max b_i / k_i, proves the clamp idle for all of them: their sum is then a second affine law, checked
//    in 8 flops per tick; the test also proves p > 0, so their flags are set. A tick that fails it (a fast
//    hand, a shallow press, the handle gone out) evaluates them one by one from flat arrays instead: the same
//    force and flags, at the near planes' cost. So their surfaces need not bound the safe radius: pressing a
//    wall never makes the other objects re-classify more often.
//  * Near or nonlinear objects, one by one: unilateral planes the handle is in contact with less than
//    kNearDistance deep or near (the clamp f.n >= 0 depends on v as well), and planes / fields within
//    kNearDistance of their surface (for their flags; a near field's force too). The loop over unilateral
//    planes is branch-free with four partial sums (no chain of dependent additions across planes).
//  * Moves are rendered through a first-order hold (advance_glides): a client's new pose is reached along a
//    straight line over the object's measured update interval (the mean of the ticks between its poses, at
//    most move_interval_max), starting from the pose rendered now, and on along that line for up to one
//    more interval while the next pose is late (then back to the last pose). A client sending poses every
//    5 ms sees each rendered 4 ticks later than a direct application would (one interval less the tick it
//    arrives in); the surface's path is continuous and piecewise linear instead of a staircase of K Delta steps.
//    Each tick of a glide is a move (positions only), handled as above.
//  * A unilateral plane that appears (a Set into an empty slot) with the handle behind its surface starts with
//    its surface at the handle (penetration 0) and moves to its commanded offset at activation_speed
//    (activate_new_planes, then advance_glides): the god-object rule (docs/protocol.md, section 4). Within
//    activation_speed kActivationTailTime of its target its speed is gap / kActivationTailTime (an
//    exponential approach, ending within kActivationArrival), so the damping relative to the surface changes
//    by at most B activation_speed T / kActivationTailTime per tick instead of B activation_speed at once.
//    Moves that arrive meanwhile change where it goes, not how fast. Positions only, never gains.
// No allocation, lock, exception or I/O in anything called per tick.
// The code, one concern per file: scene_objects.cpp (construction, add_forces, the observations),
// scene_objects_batches.cpp (batches, departures, ramps), scene_objects_affine.cpp (the affine laws, compensated
// sums), scene_objects_classify.cpp (classification, safe radius, moves), scene_objects_unilateral.cpp (the
// vectorised unilateral planes), scene_objects_glides.cpp (move holds, activation), scene_objects_law_change.cpp
// (what the scene changed in the law, for the force limiter).
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <vector>

#include <optional>

#include "common/axis_vector.hpp"
#include "common/velocity_estimator_spec.hpp"
#include "mesh/god_object_proxy.hpp"
#include "loop/spsc_ring.hpp"
#include "scene/force_limiter.hpp"
#include "scene/velocity_filter.hpp"

namespace hapticd {

inline constexpr std::size_t kSceneObjectCapacity = 64;
// Objects whose switching surface is nearer than this to the handle at a classification are evaluated one
// by one (m). Larger: fewer re-classifications (one per kNearDistance of hand motion), more objects per tick.
inline constexpr double kNearDistance = 1e-3;
// Batches the loop can hold while another batch's ramps run (SceneObjects::apply_commits): as many as the
// server's queue to the loop holds (serve_runtime.cpp), so holding never makes the queue refuse sooner.
inline constexpr std::size_t kHeldCommitCapacity = 64;

// The activation's end (the god-object rule): the time constant of the exponential approach over its last
// activation_speed x 20 ms (0.2 mm at 0.01 m/s), and the gap below which the surface is placed on its target
// (1 nm: K times it is below 1e-4 N for K up to 1e5 N/m).
inline constexpr double kActivationTailTime = 0.02;  // s
inline constexpr double kActivationArrival = 1e-9;   // m

enum class ObjectKind : std::uint8_t { Plane, Spring, Field, Mesh };
enum class SpringConstraint : std::uint8_t { Point, Line, Plane };

// One object as the loop renders it: plain data, copied through the ring.
struct ObjectParams {
    std::uint32_t id = 0;
    ObjectKind kind = ObjectKind::Plane;
    bool bilateral = false;                                 // plane
    SpringConstraint constraint = SpringConstraint::Point;  // spring
    AxisVector direction{};                                 // plane normal, spring line direction / plane normal (unit)
    double offset = 0.0;                                    // plane, m
    AxisVector point{};                                     // spring anchor, field centre x0, m
    double radius = 0.0;                                    // field, m
    AxisVector force{};                                     // field F0, N
    std::array<AxisVector, 3> jacobian{};                   // field J, N/m (rows)
    double K = 0.0;                                         // N/m (plane, spring, mesh)
    double B = 0.0;                                         // N s/m (plane, spring, field, mesh)
    // mesh: the hierarchy (kept alive by the server's slot table for as long as the loop may render it: the
    // server frees a slot's resources only after the loop has emptied it), the pose's orientation (unit quaternion
    // w, x, y, z; the position is `point`) and the proxy's friction coefficients.
    const mesh::MeshHierarchy* mesh = nullptr;
    std::uint32_t mesh_id = 0;  // mesh: the server's id of that hierarchy (what a recording names it by)
    std::array<double, 4> orientation{1.0, 0.0, 0.0, 0.0};
    double static_friction = 0.0;
    double dynamic_friction = 0.0;
    // mesh: force shading (docs/mesh-rendering.md, "Force shading"): the crease angle in degrees, negative when
    // off, and the hierarchy's corner normals for it (MeshHierarchy::shading: kept alive with the hierarchy;
    // nullptr when off).
    double crease_angle_deg = -1.0;
    const mesh::ShadingNormals* shading = nullptr;
    // The loop's own (clients' objects arrive with zeros): the velocity of the rendered pose while a move is
    // interpolated, d(offset)/dt (m/s) and d(point)/dt (m/s), so that the damping acts on the handle's
    // velocity relative to the object's surface (SceneObjects::advance_glides).
    double offset_rate = 0.0;
    AxisVector point_rate{};
};

// Whether the object renders its law only at some handle positions: a unilateral plane (while the handle is
// behind its surface and the law pushes out) and a field (inside its radius). Bilateral planes and springs
// act everywhere. The server checks every pattern of these engaging and not (docs/protocol.md, section 5,
// tuning/engagement_patterns.hpp); anything that changes when an object engages asks this.
[[nodiscard]] constexpr bool engages_conditionally(const ObjectParams& p) noexcept {
    return (p.kind == ObjectKind::Plane && !p.bilateral) || p.kind == ObjectKind::Field || p.kind == ObjectKind::Mesh;
}

// A Move keeps everything but where the object is (plane offset, spring point, field centre and F0): same
// id, kind, K, B and the fields of its kind that shape its law. The server sends a modify that is one as a
// Move (no ramp); the loop applies a Move only when it is one. Only the fields the object's kind uses are
// compared (a move every tick pays for ~8 comparisons, not for the whole description).
[[nodiscard]] bool is_move(const ObjectParams& before, const ObjectParams& after) noexcept;

struct SlotUpdate {
    enum class Action : std::uint8_t {
        Set,     // a new object, or another description: the old one (if any) fades out, this one ramps in
        Move,    // the same object moved (offset / point / center / F0 only): applied at once, no ramp
        Remove,  // ramp out, then free the slot
        Cut,     // gone at once, its fading entry too (no ramp): a departure with no stable ramp-out
    };
    std::uint8_t slot = 0;
    Action action = Action::Set;
    ObjectParams params;
};

// One batch: applied whole in one tick. Copying one (through the ring) copies its `count` updates only,
// not the 64 slots' worth of storage (~14 KB): a one-object move costs one update's copy.
struct ObjectCommit {
    std::uint64_t seq = 0;
    std::uint32_t count = 0;
    std::array<SlotUpdate, kSceneObjectCapacity> updates{};

    ObjectCommit() = default;
    ObjectCommit(const ObjectCommit& other) noexcept { *this = other; }
    ObjectCommit& operator=(const ObjectCommit& other) noexcept {
        if (this != &other) {
            seq = other.seq;
            count = other.count < kSceneObjectCapacity ? other.count : static_cast<std::uint32_t>(kSceneObjectCapacity);
            for (std::uint32_t i = 0; i < count; ++i) updates[i] = other.updates[i];
        }
        return *this;
    }
};

using CommitRing = SpscRing<ObjectCommit>;

// Which ring apply_commits took a batch from (the values are the recording's, daemon/recording_format.hpp).
enum class CommitSource : std::uint8_t {
    Ring = 0,       // the commit ring: applied now, or held until the ramps in progress end
    Departure = 1,  // the departures ring
    Jumped = 2,     // the commit ring, applied at once ahead of a departure (take_departures)
};

// Told of every batch the loop takes from a ring, in order, before it is popped (--record: daemon/recorder.hpp;
// --replay: daemon/replay.hpp). Called on the loop thread: must be real-time safe.
class CommitObserver {
  public:
    virtual void on_taken(const ObjectCommit& commit, CommitSource source) noexcept = 0;

  protected:
    CommitObserver() = default;
    CommitObserver(const CommitObserver&) = default;
    CommitObserver& operator=(const CommitObserver&) = default;
    ~CommitObserver() = default;
};

// Told of each mesh hierarchy before the first batch that renders it is handed to the loop (--record:
// daemon/recorder.hpp stores its triangles). Called on the server thread, never the loop's: may allocate and lock.
class MeshObserver {
  public:
    virtual void on_mesh(std::uint32_t mesh_id, const std::shared_ptr<const mesh::MeshHierarchy>& hierarchy) = 0;

  protected:
    MeshObserver() = default;
    MeshObserver(const MeshObserver&) = default;
    MeshObserver& operator=(const MeshObserver&) = default;
    ~MeshObserver() = default;
};

struct SceneObjectsConfig {
    double period = 1e-3;     // s
    double ramp_time = 0.03;  // s (0: no ramp)
    std::size_t axes = 3;
    std::size_t commits_per_tick = 8;  // bound on the commits applied in one tick
    double move_interval_max = 0.0;    // s: longest first-order hold of a move (0: moves are applied at once)
    double activation_speed = 0.0;     // m/s: a plane appearing around the handle moves out at this speed (0: at once)
    VelocityEstimatorSpec velocity{};  // the velocity estimate the dampers act on (the server checks with the same)
};

// A mesh object's god-object proxy as the last add_forces() rendered it, in the device frame (the state publishes
// it: docs/protocol.md, section 6): proxy = p + R c and normals R n_i for the proxy c and normals n_i in the mesh's
// frame and the entry's pose (p, R) of that tick.
struct MeshProxyView {
    AxisVector proxy{};                   // m
    std::array<AxisVector, 3> normals{};  // unit, the first `constraints`
    int constraints = 0;                  // 0..3
    std::uint32_t triangle = UINT32_MAX;  // one active face (index in the client's mesh), UINT32_MAX when free
    std::uint32_t object_id = 0;
    bool sliding = false;
    bool converged = true;
};

struct SceneObjectsStats {
    std::uint64_t commits_applied = 0;
    std::uint64_t last_commit_seq = 0;     // every batch up to this seq is applied
    std::uint64_t commits_held = 0;        // batches held until the ramps of an earlier one had ended
    std::uint64_t departures_applied = 0;  // departure batches (the second ring)
    std::uint64_t commits_jumped = 0;      // batches brought to their final state at once ahead of a departure
};

class SceneObjects {
  public:
    // The rings must outlive this object; their consumer is the loop thread (apply_commits()). `departures`
    // (optional) carries the server's departure batches (a client that left): each is applied within the
    // tick it is seen, ahead of the batches held or waiting in `ring` (take_departures). Without it the
    // server sends departures through `ring` and they queue like any batch.
    SceneObjects(const SceneObjectsConfig& config, CommitRing& ring, CommitRing* departures = nullptr);

    // Start of a tick: applies up to commits_per_tick waiting batches; one that starts ramps while another
    // batch's ramps run is held until they have ended (apply_commits in scene_objects_batches.cpp). Real-time safe.
    void apply_commits() noexcept;

    // Before the loop starts (may be null): told of every batch taken from a ring. Must outlive this object.
    void set_observer(CommitObserver* observer) noexcept { observer_ = observer; }

    // Adds the objects' forces to `force` (the config walls' sum). Returns false on a non-finite total (force is
    // then zero). Real-time safe.
    bool add_forces(const AxisVector& position, AxisVector& force) noexcept;

    // Bit s: the object in slot s was in contact at the last add_forces() (its surface's flag as rendered in
    // that tick; an entry whose ramp-out ended with that tick keeps its bit although its slot is now free).
    [[nodiscard]] std::uint64_t contact_mask() const noexcept { return contact_mask_; }
    // Bit s: slot s holds an object now (slot_object_id(s) != 0). The state publishes
    // contact_mask() & occupied_mask(): a contact always names an object of the slot table it is published with.
    [[nodiscard]] std::uint64_t occupied_mask() const noexcept { return occupied_mask_; }
    [[nodiscard]] std::uint32_t slot_object_id(std::size_t slot) const noexcept;
    [[nodiscard]] double slot_ramp(std::size_t slot) const noexcept;
    [[nodiscard]] std::uint32_t occupied() const noexcept { return occupied_; }
    // Changes whenever a slot's object id or ramp factor changes (the state publisher rewrites the slot
    // table only then).
    [[nodiscard]] std::uint64_t slot_table_version() const noexcept { return slot_table_version_; }
    // Bit s: slot s renders a mesh through a proxy the last add_forces() stepped (its current entry, or the mesh
    // fading out of it). O(mesh entries). mesh_proxy(s): that proxy (the current entry's when both are meshes);
    // false when slot s renders none (scene_objects_proxy_view.cpp).
    [[nodiscard]] std::uint64_t mesh_slot_mask() const noexcept;
    bool mesh_proxy(std::size_t slot, MeshProxyView& out) const noexcept;
    // Re-classifications so far (commits, ramp steps, moves, leaving the safe radius): for the benchmarks.
    [[nodiscard]] std::uint64_t classifications() const noexcept { return classifications_; }
    // Ticks whose motion failed the pressed planes' test (they were evaluated one by one): for the tests.
    [[nodiscard]] std::uint64_t pressed_fallbacks() const noexcept { return pressed_fallbacks_; }
    // Ticks that used the pressed planes' summed law.
    [[nodiscard]] std::uint64_t pressed_summed() const noexcept { return pressed_summed_; }
    [[nodiscard]] const SceneObjectsStats& stats() const noexcept { return stats_; }
    // Batches held now until the ramps in progress end (apply_commits).
    [[nodiscard]] std::size_t held() const noexcept { return held_count_; }
    [[nodiscard]] const AxisVector& velocity() const noexcept { return velocity_; }
    // What the scene changed in the law the last add_forces() rendered, for the force limiter
    // (scene/force_limiter.hpp): whole when a batch other than moves was applied for it (apply_commits), a
    // departure, a ramp step, or a mesh moved; otherwise `shift`, the moves' change of the force at that tick's
    // handle position and velocity estimate: for each object moved since the last add_forces(), its law there
    // with its pose now less with its pose before the move (scene_objects_law_change.cpp).
    [[nodiscard]] const LawChange& law_change() const noexcept { return law_change_; }
    // Slots whose rendered pose is still on its way to the commanded one (move interpolation, activation).
    [[nodiscard]] std::uint64_t gliding() const noexcept { return gliding_mask_; }
    // The linear gains of the scene the next add_forces() renders (call it after apply_commits()), every
    // object counted as in contact (the all-engaged pattern the server checks): the sum over the active entries
    // (current and fading) of r^2 K_i and r B_i (add_linear), in the law f = c - K x - B v. An observation for the
    // tests (tests/server/test_rendered_scene_property.cpp); O(64), never called by the loop.
    void rendered_gains(std::array<AxisVector, 3>& K, std::array<AxisVector, 3>& B) const noexcept;
    // The same for the handle at x with the velocity estimate v (the tick's add_forces(x) computes v with the
    // configured estimator, velocity()): only the entries whose law acts there — bilateral planes and springs,
    // unilateral planes with p > 0 whose law r^2 K p - r B n.v pushes out (a clamped plane renders nothing), fields
    // with
    // ||x - x0|| <= radius: the engagement pattern the loop renders at that tick. `engaged`: the slots of
    // the conditional entries among them (engages_conditionally; each has its flag in contact_mask() after
    // that tick). O(64), never called by the loop.
    void rendered_gains(const AxisVector& x, const AxisVector& v, std::array<AxisVector, 3>& K,
                        std::array<AxisVector, 3>& B, std::uint64_t& engaged) const noexcept;

  private:
    struct Entry {
        bool active = false;
        double ramp = 0.0;        // r in [0, 1]: steps x step (ramping in), start - steps x step (fading)
        double start = 1.0;       // fading: the factor it started from
        std::uint32_t steps = 0;  // ticks since its ramp started
        ObjectParams params;
    };
    struct Slot {
        Entry current;  // ramps in to 1 (or sits at 1)
        Entry fading;   // ramps out to 0, then inactive
    };
    using Matrix3 = std::array<AxisVector, 3>;  // rows
    // The summed affine law of the linear objects: f = c - K x - B v.
    struct AffineLaw {
        AxisVector c{};      // sum + carry
        AxisVector sum{};    // the running sum of the entries' w c_i (replaced one by one on moves)
        AxisVector carry{};  // its rounding errors, kept exactly by TwoSum (replace_constant)
        Matrix3 K{};
        Matrix3 B{};
        bool any = false;
    };
    // Entries evaluated one by one each tick (see the header comment), as flat arrays for a tight loop.
    // Unilateral planes: force and flag. near_planes_ holds those within kNearDistance of their surface
    // (in contact or not), pressed_planes_ the deeper ones (used on a tick that fails their test). The ramp's
    // weights are copied here; they change only at a ramp step, which re-classifies. Padded with zero
    // planes to a multiple of four (add_unilateral).
    // slot_bit: 1 << the plane's slot (its contact flag's bit), so that four flags are set with one
    // vector AND and OR.
    struct NearPlanes {
        std::array<double, 2 * kSceneObjectCapacity> nx{}, ny{}, nz{}, offset{}, K{},
            B{};                                              // K, B: times the ramp's weights
        std::array<double, 2 * kSceneObjectCapacity> rate{};  // offset_rate
        std::array<std::uint64_t, 2 * kSceneObjectCapacity> slot_bit{};
        std::size_t count = 0;
    };
    // Bilateral planes near their surface: the flag only (their force is in the affine law).
    struct NearFlags {
        std::array<double, 2 * kSceneObjectCapacity> nx{}, ny{}, nz{}, offset{};
        std::array<std::uint64_t, 2 * kSceneObjectCapacity> slot_bit{};
        std::size_t count = 0;
    };
    // Fields near their sphere: the whole law.
    struct NearFields {
        std::array<const ObjectParams*, 2 * kSceneObjectCapacity> params{};
        std::array<double, 2 * kSceneObjectCapacity> w{};
        std::array<std::uint8_t, 2 * kSceneObjectCapacity> slot{};
        std::size_t count = 0;
    };

    // The entries (2 slot + which) summed in linear_ and in pressed_, in slot order.
    struct Members {
        std::array<std::uint8_t, 2 * kSceneObjectCapacity> entry{};
        std::size_t count = 0;
    };

    // at_once: every ramp the batch would start is at its end already (a Set's object at weight 1 and what it
    // replaces gone, a Remove's object gone): the batch's final scene, which the server checked.
    void apply(const ObjectCommit& commit, bool at_once = false) noexcept;
    bool take_departures() noexcept;
    void finish_ramps() noexcept;
    void pop_held() noexcept;
    void start_fading(Slot& slot) noexcept;
    [[nodiscard]] bool ramp_running() const noexcept;
    void set_bounds() noexcept;
    void step_ramps() noexcept;
    void count_occupied() noexcept;
    static void add_linear(AffineLaw& law, const ObjectParams& p, double w) noexcept;
    // Adds the unilateral planes' forces to f and their contact flags to mask (one by one, branch-free).
    static void add_unilateral(const NearPlanes& n, const double (&x)[3], const double (&v)[3], double (&f)[3],
                               std::uint64_t& mask) noexcept;
    static void pad_planes(NearPlanes& n) noexcept;
    static void add_law(const AffineLaw& l, const double (&x)[3], const double (&v)[3], double (&f)[3]) noexcept;
    static AxisVector linear_constant(const ObjectParams& p, double w) noexcept;
    void apply_moves() noexcept;
    [[nodiscard]] AxisVector sum_constants(const Members& m) const noexcept;
    void start_constants(AffineLaw& l, const Members& m) const noexcept;
    static void replace_constant(AffineLaw& l, AxisVector& stored, const AxisVector& now) noexcept;
    void classify(const AxisVector& x) noexcept;
    // Move interpolation and the activation rule (header comment); positions only.
    struct Pose {
        double offset = 0.0;
        AxisVector point{};
        AxisVector force{};
        std::array<double, 4> orientation{1.0, 0.0, 0.0, 0.0};  // a mesh's (normalised linear interpolation)
    };
    struct Glide {
        Pose from, to;
        std::uint32_t step = 0, steps = 0;  // first-order hold: at tick `step` of `steps` (advance_hold)
        bool settling = false;              // returning to the last commanded pose (no next pose came)
        double offset_rate = 0.0;           // the commanded poses' velocity: the rate the damping is relative to
        AxisVector point_rate{};
        bool approaching = false;  // activation: the offset approaches to.offset at activation_speed
    };
    [[nodiscard]] static Pose pose_of(const ObjectParams& p) noexcept {
        return {p.offset, p.point, p.force, p.orientation};
    }
    void begin_glide(std::size_t slot, const ObjectParams& commanded) noexcept;
    void note_new_object(std::size_t slot, const ObjectParams& commanded, bool slot_was_empty) noexcept;
    void cancel_glide(std::size_t slot) noexcept;
    void activate_new_planes(const AxisVector& x) noexcept;
    void advance_glides() noexcept;
    void glide_tick(const AxisVector& x) noexcept;
    bool advance_hold(Glide& g, ObjectParams& p) const noexcept;

    SceneObjectsConfig config_;
    CommitRing& ring_;
    CommitRing* departures_ = nullptr;
    CommitObserver* observer_ = nullptr;
    std::array<Slot, kSceneObjectCapacity> slots_{};
    // Batches waiting for the ramps in progress to end (apply_commits), a circular queue preallocated in the
    // constructor (~14 KB each: on the heap, not in the object).
    std::vector<ObjectCommit> held_;
    std::size_t held_first_ = 0;
    std::size_t held_count_ = 0;
    std::uint64_t held_slots_ = 0;   // the slots the held batches touch
    std::uint64_t applied_seq_ = 0;  // the largest seq applied
    double ramp_step_ = 1.0;
    double inverse_period_ = 1e3;
    std::optional<VelocityFilter> velocity_filter_;  // built by the constructor (its ring is allocated there)
    AxisVector velocity_{};
    std::uint64_t contact_mask_ = 0;
    SceneObjectsStats stats_;

    // The classification (rebuilt when the scene changes or the handle leaves the safe radius).
    bool scene_changed_ = true;
    std::uint32_t ramping_ = 0;             // entries whose ramp is still moving
    std::uint32_t occupied_ = 0;            // slots with an object
    std::uint64_t occupied_mask_ = 0;       // their bits
    std::uint64_t slot_table_version_ = 0;  // bumped when an id or a ramp factor changes
    AffineLaw linear_;
    // Where each entry (2 slot + 0 current / 1 fading) went at the last classification.
    struct EntryPlace {
        enum List : std::uint8_t { None, Linear, Pressed, NearPlane, NearFlag, NearField } list = None;
        std::uint8_t index = 0;  // in its near list
    };
    std::array<EntryPlace, 2 * kSceneObjectCapacity> place_{};
    std::array<AxisVector, 2 * kSceneObjectCapacity> entry_c_{};  // w c_i of the entries in an affine law
    Members linear_members_;
    Members pressed_members_;
    AffineLaw pressed_;             // the deeply pressed unilateral planes' sum (used while their clamp is idle)
    NearPlanes pressed_planes_;     // the same planes one by one (a tick whose motion fails the test)
    double pressed_depth_ = 0.0;    // P: their least penetration at the classification, less the rounding tol
    double pressed_tau_ = 0.0;      // tau: their largest b / k (s)
    double pressed_rate_ = 0.0;     // their largest |offset_rate| since the classification (m/s)
    std::uint64_t moved_mask_ = 0;  // slots moved (Move commits only) since the last classification
    NearPlanes near_planes_;
    NearFlags near_flags_;
    NearFields near_fields_;
    std::uint64_t static_mask_ = 0;   // flags that stay as classified while inside the safe radius
    std::uint64_t pressed_mask_ = 0;  // the pressed planes' flags (set on a tick that passes their test)
    AxisVector reference_{};          // x where the scene was classified
    double reference_norm1_ = 0.0;    // ||x_ref||_1
    double scale_ = 0.0;              // the rounding scale of the distances (offsets, centres, radii, x_ref)
    double rho_ = 0.0;                // the least distance of a far surface to x_ref (+inf: none)
    double least_pressed_ = 0.0;      // the least penetration of a pressed plane at x_ref
    double safe_radius_ = 0.0;        // rho - tol (may be +inf: no far surface)
    std::uint64_t classifications_ = 0;
    std::uint64_t pressed_fallbacks_ = 0;
    std::uint64_t pressed_summed_ = 0;
    // Meshes (scene_objects_meshes.cpp): each entry k = 2 slot + which renders through the proxy
    // mesh_proxies_[proxy_of_[k]]; start_fading swaps the two entries' indices, so the fading entry keeps its
    // proxy's state without a copy. Constructed in place when a Set brings a mesh (no allocation: the proxy is
    // handed a non-owning pointer to the hierarchy the server keeps alive).
    struct MeshProxy {
        std::optional<mesh::GodObjectProxy> proxy;
        bool fresh = true;  // reset to the handle at its first tick
    };
    std::array<MeshProxy, 2 * kSceneObjectCapacity> mesh_proxies_{};
    std::array<std::uint8_t, 2 * kSceneObjectCapacity> proxy_of_{};
    Members meshes_;  // the mesh entries, listed at each classification (evaluated every tick)
    void bind_mesh(std::size_t entry, const ObjectParams& p) noexcept;
    void add_meshes(const AxisVector& x, const AxisVector& v, double (&f)[3], std::uint64_t& mask) noexcept;
    std::array<Glide, kSceneObjectCapacity> glides_{};
    std::array<std::uint64_t, kSceneObjectCapacity> pose_tick_{};  // tick of the slot's last commanded pose
    std::array<double, kSceneObjectCapacity> pose_interval_{};     // its mean update interval (ticks), see begin_glide
    std::uint64_t gliding_mask_ = 0;     // slots whose rendered pose is on its way to the commanded one
    std::uint64_t activation_mask_ = 0;  // new unilateral planes, to be checked against the handle this tick
    std::uint64_t ticks_ = 0;            // add_forces calls so far
    // law_change() (scene_objects_law_change.cpp): a whole change pending for the next add_forces (a batch, a
    // departure, a ramp step), the slots moved since the last add_forces with their objects as they were before
    // the first of those moves, and what the last add_forces rendered.
    bool whole_change_pending_ = true;  // the objects' law appears with the first tick
    std::uint64_t shifted_mask_ = 0;
    std::array<ObjectParams, kSceneObjectCapacity> before_move_{};
    LawChange law_change_{};
    void note_pose_change(std::size_t slot) noexcept;
    void sum_pose_shifts(const AxisVector& x, const AxisVector& v) noexcept;
    std::uint32_t move_hold_max_ = 0;        // move_interval_max in ticks
    double activation_step_ = 0.0;           // activation_speed T, m per tick
    double activation_tail_fraction_ = 1.0;  // T / kActivationTailTime: the share of the gap taken per tick at the end
};

}  // namespace hapticd
