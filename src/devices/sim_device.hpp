// SPDX-License-Identifier: Apache-2.0
// The simulated device held by a simulated hand: the continuous plant of eq. 1 of the paper,
//   M x'' + b (x' - x_H') + k (x - x_H) = F_H + u,   m = m_L + m_H,  b = b_L + b_H,  k = k_H,
// advanced exactly (zero-order hold) by one period per tick. u is the force written by the loop; it acts after
// the device's inherent delay (which may be a non-integer number of periods: the period is then split into two
// exactly-integrated sub-intervals). The hand (SimHand, SimScenario) holds the handle around its rest position x_H
// and adds its intent force F_H; both are held constant over a period (their value at the period's middle).
// M is one mass for every axis, a mass per axis, or a full symmetric positive-definite matrix. With b and k
// scalar the plant separates in the eigenvectors Q of M = Q diag(m_i) Q^T: y = Q^T x obeys
// m_i y_i'' + b y_i' + k y_i = (Q^T (F_H + u + ...))_i, each mode its own exact ZOH (Q = I for a diagonal M).
//
// Coulomb friction (SimDeviceConfig::coulomb_friction, f_c per axis): the axis equation gains f_c sgn(x') on the
// left, and at rest (x' = 0) the friction is whatever force in [-f_c, f_c] holds the handle (one value for static
// and sliding friction). Per axis and per (sub-)interval of constant input u (the loop's force and the hand's):
// - at rest, the net force without friction is u - k x (the dampers' forces vanish at x' = 0; the hand's spring
//   and damper, and its moving rest position, are in u and k): |u - k x| <= f_c sticks for the rest of the
//   interval (x, x' unchanged); otherwise the handle slides off in the direction of the net force;
// - sliding in direction s, the friction is the constant force -s f_c, so the motion is the exact ZOH solution
//   with u - s f_c. The velocity obeys m v'' + b v' + k v = 0, so its zeros are at least pi / omega_d apart
//   (none after a first one when not underdamped): the interval is cut into pieces of at most half that, each
//   holding at most one zero, found by a sign change at the piece's end and located by bisection to rounding
//   (60 halvings) on the exact solution; there the velocity is set to 0 and the rest rule above decides.
// Exact: everything but the located stop times (bisection to about 1e-16 of a piece) and the rounding of the
// series matrix exponential used for the pieces (zoh_plant.hpp, discretize_series). Approximated: as without
// friction, the hand's intent and moving rest are held over a period (their value at its middle). Not modelled:
// a static friction above the sliding one (Stribeck), friction on the modes of a coupled (non-diagonal) mass
// matrix: coulomb_friction > 0 with a non-diagonal mass_matrix is refused (std::invalid_argument), since friction
// acts along the axes and would couple the modes that the exact per-mode ZOH keeps apart. An interval with more
// than 64 stops (none in practice: each slide lasts at least until the velocity's next zero) ends at rest.
// Cost: a located stop is ~60 series exponentials, ~30 us; the tick's compute time of the simulated Falcon
// chattering with f_c = 0.02 N is 2.1 us mean, 31 us p99, against 0.08 us without friction (docs/limit-cycles.md).
//
// Grip and release (SimScenario::schedule, config/hand_schedule.hpp; docs/simulated-hand.md "Grip and release"):
// each event takes effect at the first period boundary at or after its time (t = n T), never inside a period.
// - release: the hand's mass m_H = hand.release_mass + hand.mass leaves the handle (M -> M - m_H I), k_H = b_H = 0,
//   and its intent force F_H is off (read_external_force gives 0). The handle keeps its position and velocity
//   (the hand leaves with the handle's velocity, taking its momentum m_H v with it).
// - grip: the hand's mass joins moving with the handle's velocity (a perfectly inelastic grip of a hand that
//   moves with the handle: position and velocity are continuous, the momentum becomes (M + m_H I) v); k_H and b_H
//   (the last arm values) come back, the intent force F_H resumes, and the hand's rest x_H is set to the handle's
//   position at the grip (plus the intent's motion from there on): the spring adds no force at the grip. The
//   damper acts on x' - x_H' as always, so a handle moving at the grip is braked by b_H (x' - x_H').
// - arm: k_H and/or b_H change from that boundary on (while released: from the next grip); x_H stays.
// Every plant the schedule reaches (masses, b, k, their modes and ZOH steps) is discretised in the constructor:
// an event in the tick switches a pointer and rotates the state into the new modes (the identity for a diagonal
// M), with no allocation. Between events the integration is the exact ZOH above.
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "config/hand_schedule.hpp"
#include "devices/device.hpp"
#include "devices/zoh_plant.hpp"

namespace hapticd {

// The hand's impedance (docs/simulated-hand.md). Its mass m_H is part of a profile's mass (profiles hold the
// device with its expected arm, m = m_L + m_H, Table II of the paper); `mass` adds to that. Zero everywhere:
// a free device pushed by the intent's force only.
struct SimHand {
    double mass = 0.0;       // kg, added to the profile's mass
    double damping = 0.0;    // b_H, N s/m
    double stiffness = 0.0;  // k_H, N/m
    // kg of the plant's mass that is the hand's: with `mass` it leaves the handle at a release (0: only `mass`).
    double release_mass = 0.0;
};

// The hand's intent (the scenario): where it holds the handle and what force it adds. The hand's rest
// position is where the handle starts, on the scenario axis relative to the first wall's surface.
enum class Scenario : std::uint8_t {
    Step,  // at rest on the wall surface; external force step_force into the wall from t = 0 (the paper's step)
    Push,  // starts push_distance outside the wall moving towards it at push_speed (a collision); the hand's
           // rest moves with it until it is on the surface
    Hold,  // starts at rest hold_distance outside; the human pushes with hold_force from t = 0
    Rest,  // at rest in the workspace centre, no force: the hand only holds the handle
    Path,  // the hand's rest position follows centre + path_amplitude sin(2 pi path_frequency t) along the axis
};

std::string_view to_string(Scenario scenario) noexcept;

struct SimScenario {
    Scenario kind = Scenario::Step;
    std::size_t axis = 0;          // the axis the scenario acts on
    double surface = 0.0;          // wall surface on that axis, m
    double direction = 1.0;        // +1: the wall is entered moving in +axis direction; -1: in -axis direction
    double step_force = 1.0;       // N
    double push_speed = 0.1;       // m/s
    double push_distance = 0.002;  // m
    double push_force = 0.0;       // N, external force during the push (0: free collision)
    double hold_force = 2.0;       // N
    double hold_distance = 0.001;  // m
    AxisVector centre{};  // the workspace centre: the hand's rest position off the scenario axis (all axes: Rest, Path)
    double path_amplitude = 0.01;     // m
    double path_frequency = 0.5;      // Hz
    SimHand hand;                     // the impedance holding the handle (zero: none)
    std::vector<HandEvent> schedule;  // releases, grips, arm changes (empty: the hand holds throughout)
};

// One event of the schedule as it happened (tick < 0: not reached yet).
struct HandEventRecord {
    HandEvent event;
    std::int64_t tick = -1;  // the period boundary it took effect at: t = tick T (the first at or after event.time)
    double mass = 0.0;       // the moving mass after it, kg (M_00 for a mass matrix)
    double stiffness = 0.0;  // k_H after it, N/m (0 while released)
    double damping = 0.0;    // b_H after it, N s/m (0 while released)
    double position = 0.0;   // the handle on the scenario axis at the event, m
    double velocity = 0.0;   // m/s
};

struct SimDeviceConfig {
    DeviceCapabilities capabilities;  // capabilities.inherent_delay is simulated
    PlantParameters plant;            // b, k; and the mass of every axis unless mass_matrix is set
    // M on the device's axes (rows/columns beyond them ignored), symmetric positive definite.
    std::optional<std::array<AxisVector, kMaxAxes>> mass_matrix;
    double period = 1e-3;              // s
    double position_noise = 0.0;       // standard deviation of additive Gaussian noise, m (0: off)
    AxisVector position_resolution{};  // per axis, quantisation step of the reported position, m (0: off)
    AxisVector coulomb_friction{};     // per axis, Coulomb friction f_c, N (N m) (0: none; model above)
    std::uint64_t noise_seed = 1;
    std::int64_t fail_at_tick = -1;  // fault injection for tests: Disconnected from this tick on (-1: never)
    SimScenario scenario;
};

class SimDevice final : public Device {
  public:
    // Throws std::invalid_argument naming the parameter for a mass_matrix that is not symmetric positive
    // definite, a hand with a negative or non-finite parameter, a negative or non-finite coulomb_friction, or
    // coulomb_friction > 0 with a non-diagonal mass_matrix.
    explicit SimDevice(const SimDeviceConfig& config);

    DeviceStatus open() override;
    DeviceStatus home() override;
    void close() noexcept override;

    DeviceStatus read_position(AxisVector& position) noexcept override;
    DeviceStatus write_force(const AxisVector& force) noexcept override;
    // The simulated plant's commanded force is memory of this process: zeroing it is a store.
    bool zero_force_from_signal_handler() noexcept override;
    DeviceStatus read_external_force(AxisVector& force) noexcept override;

    [[nodiscard]] const DeviceCapabilities& capabilities() const noexcept override { return config_.capabilities; }
    [[nodiscard]] std::string_view name() const noexcept override { return "sim"; }
    [[nodiscard]] std::string last_error() const override;

    // Exact (noise-free) state, for tests and diagnostics.
    [[nodiscard]] double true_position(std::size_t axis) const noexcept { return rest_[axis] + physical(x_, axis); }
    [[nodiscard]] double true_velocity(std::size_t axis) const noexcept { return physical(v_, axis); }
    // The schedule's events, each with the tick it took effect at once reached (the schedule restarts at open/home).
    [[nodiscard]] const std::vector<HandEventRecord>& hand_events() const noexcept { return events_; }
    [[nodiscard]] bool hand_held() const noexcept { return plant_->held; }
    // The moving mass now (M_aa with the hand's part when held), kg.
    [[nodiscard]] double moving_mass(std::size_t axis) const noexcept { return plant_->axis_mass[axis]; }

  private:
    // The plant between two events: eq. 1's masses, b and k with the hand on or off, per mode.
    struct ModalPlant {
        std::array<ZohStep, kMaxAxes> full{};      // h = T
        std::array<ZohStep, kMaxAxes> first{};     // h = phi T       (fractional part of the delay)
        std::array<ZohStep, kMaxAxes> second{};    // h = (1 - phi) T
        std::array<AxisVector, kMaxAxes> modes{};  // Q, columns the modes (modes[axis][mode]); identity if M diagonal
        std::array<PlantParameters, kMaxAxes> mode_plant{};  // m_i, b, k of each mode
        AxisVector slide_piece{};  // per mode, the longest piece holding at most one zero of the velocity, s
        PlantParameters total{};   // b and k of eq. 1 (plant + hand); mass: the isotropic one
        AxisVector axis_mass{};    // M_aa
        bool held = true;
        double hand_damping = 0.0, hand_stiffness = 0.0;  // b_H, k_H (0 while released)
    };
    // The plant with `mass_delta` on M's diagonal and the hand's b_H, k_H; `what` names it in errors. Sets
    // diagonal_ (every plant of one device has the same off-diagonal M).
    ModalPlant build_plant(double mass_delta, bool held, double hand_damping, double hand_stiffness, double phi,
                           const std::string& what);
    void apply_event(std::size_t index, std::int64_t tick) noexcept;
    void reset_state() noexcept;
    void advance_period(std::int64_t tick) noexcept;  // integrates [tick T, (tick+1) T)
    // (Q y)[axis]: a modal vector in the device's axes.
    [[nodiscard]] double physical(const AxisVector& modal, std::size_t axis) const noexcept;
    // The hand's force on the handle, held over the period starting at `tick` (intent + the moving rest).
    [[nodiscard]] AxisVector hand_force(std::int64_t tick) const noexcept;
    // The intent's motion of the hand's rest at time t: x_H - rest_ - hand_offset_ on the scenario axis.
    [[nodiscard]] double intent_motion(double t) const noexcept;
    [[nodiscard]] const AxisVector& written(std::int64_t tick) const noexcept;
    double noise() noexcept;

    SimDeviceConfig config_;
    std::vector<ModalPlant> plants_;     // [0]: from the start (held); [i + 1]: after the schedule's event i
    const ModalPlant* plant_ = nullptr;  // the one in effect
    std::vector<HandEventRecord> events_;
    std::vector<std::int64_t> due_;  // per event, the boundary it takes effect at (the first n with n T >= time)
    std::size_t next_event_ = 0;
    bool diagonal_ = true;
    AxisVector intent_{};       // the intent's force F_H while held
    AxisVector hand_offset_{};  // x_H minus (rest_ + the intent's motion): set at a grip, 0 before the first
    void apply(const std::array<ZohStep, kMaxAxes>& steps, double h, const AxisVector& written_force,
               const AxisVector& hand) noexcept;
    // Advances axis `a` by h under the constant input u with its Coulomb friction (the model above); `whole` is
    // the ZOH step of length h.
    void apply_with_friction(std::size_t a, const ZohStep& whole, double h, double u) noexcept;
    double h_first_ = 0.0, h_second_ = 0.0;  // phi T, (1 - phi) T
    std::int64_t delay_periods_ = 0;         // integer part n of t_inh / T
    bool fractional_ = false;
    std::vector<AxisVector> history_;  // written forces of ticks tick-n-1 .. tick, ring of n + 2
    AxisVector zero_{};
    AxisVector x_{}, v_{}, rest_{}, external_{};  // x_, v_: modal displacement from rest_ and velocity
    std::int64_t next_tick_ = 0;
    std::int64_t tick_ = -1;
    bool open_ = false;
    DeviceStatus error_ = DeviceStatus::Ok;
    std::uint64_t rng_ = 1;
    bool have_spare_ = false;
    double spare_ = 0.0;
};

}  // namespace hapticd
