// SPDX-License-Identifier: Apache-2.0
// Online identification of the moving mass and a grip / release decision, one update per tick, allocation-free and
// constant time (for the loop: no allocation, no lock, no exception after construction).
//
// Model: the handle is a mass m pushed by the force the device writes, u_j at tick j acting during
// [(j + n) T, (j + n + 1) T) (zero-order hold, the device's whole delay n), and by the hand's force F_H, unknown:
//   m x'' = u(t - n T) + F_H(t).
// Second difference over h periods (exact for a piecewise-constant force, no differentiation of the encoder):
//   D_j = y_{j+h} - 2 y_j + y_{j-h} = integral_{-hT}^{hT} (hT - |s|) x''(jT + s) ds
//       = (1/m) U_j + H_j,   U_j = sum_{i=-h}^{h-1} T^2 (h - |i + 1/2|) u_{j+i-n},
// H_j the same kernel over F_H / m. D_j is known h ticks later; the encoder's rounding e (step q) enters D_j as
// e_{j+h} - 2 e_j + e_{j-h} (variance q^2 / 2 for independent roundings), not divided by T^2: the kernel
// integrates over 2h periods, so the signal grows as h^2 while the rounding does not.
// Mass estimate: least squares of D_j = theta U_j + c with exponential forgetting (time constant tau): theta = 1 / m,
// c absorbing a constant hand force. Sums are updated, not windowed (no subtraction of old terms, no drift), and
// restart at each change of the decision (so that the released estimate rests on released data only).
// Decision: the released hypothesis is exact and checkable. Released, the handle is the known mass m_r with no hand
// force, so the residual r_j = D_j - U_j / m_r is the encoder's rounding alone, |r_j| <= 2 q, plus the mass's
// tolerance: |r_j| <= 2 q + eps |U_j| / m_r (eps the relative uncertainty of m_r). Held, the hand's force H_j and the
// heavier mass (U_j (1/m - 1/m_r)) add to it. With hysteresis: released once the bound holds for `confirm_release`
// consecutive ticks; gripped once |r_j| exceeds twice the bound for `confirm_grip` consecutive ticks.
// What it cannot see (measured in tests/identification/test_online_mass.cpp; docs/robust-stability.md):
//  * a held handle at rest, with no force from the hand and none from the wall (U = 0, H = 0): it reads as released;
//    so does a hand whose force is below the rounding's 2 q / (h T)^2 m_r (0.2 N at h = 10 on the Falcon);
//  * the mass while held: the arm's spring and damper are part of H_j and correlated with U (the wall's force is
//    itself a spring and damper on x), so the regression's mass is biased while held; it is unbiased released.
// The decision is always on the mass's side; the re-tuning switches on it, never on the estimate.
#pragma once

#include <array>
#include <cstdint>

namespace hapticd {

struct OnlineMassSettings {
    double period = 1e-3;            // T, s (> 0)
    int delay_ticks = 0;             // n, the device's whole delay in periods (0 .. kMaxDelayTicks)
    int half_width = 10;             // h, periods (1 .. kMaxHalfWidth)
    double time_constant = 0.05;     // tau of the forgetting, s (> 0)
    double min_excitation = 0.1;     // N: sqrt(var U) / (h T)^2 needed for a mass estimate
    double released_mass = 0.22;     // m_r, kg (> 0)
    double mass_tolerance = 0.1;     // eps, relative (0 .. 0.5)
    double position_step = 4.85e-5;  // q, the encoder's step, m (>= 0)
    int confirm_release = 20;        // ticks (1 .. 100000)
    int confirm_grip = 3;            // ticks (1 .. 100000)
    bool start_gripped = true;
};

class OnlineMassIdentifier {
  public:
    static constexpr int kMaxDelayTicks = 64;
    static constexpr int kMaxHalfWidth = 200;

    // Throws std::invalid_argument naming the setting and its accepted range (construction only).
    explicit OnlineMassIdentifier(const OnlineMassSettings& settings);

    // One tick: the position read at tick j (before the force) and the force written at tick j (N).
    // Non-finite input is ignored (the tick is skipped). noexcept, constant time O(h), no allocation.
    void update(double position, double force) noexcept;

    // The latest mass estimate, kg (0 until the first estimate), and the excitation it rests on, N.
    [[nodiscard]] double mass() const noexcept { return mass_; }
    [[nodiscard]] double excitation() const noexcept { return excitation_; }
    // The released hypothesis's residual r_j and its bound (m), at the latest centre tick.
    [[nodiscard]] double residual() const noexcept { return residual_; }
    [[nodiscard]] double residual_bound() const noexcept { return residual_bound_; }
    [[nodiscard]] bool gripped() const noexcept { return gripped_; }
    // Ticks since the decision last changed (or since the start).
    [[nodiscard]] std::int64_t ticks_since_change() const noexcept { return ticks_since_change_; }
    [[nodiscard]] const OnlineMassSettings& settings() const noexcept { return settings_; }

  private:
    static constexpr int kCapacity = 2 * kMaxHalfWidth + kMaxDelayTicks + 2;
    OnlineMassSettings settings_;
    std::array<double, kCapacity> positions_{};
    std::array<double, kCapacity> forces_{};
    std::int64_t count_ = 0;  // ticks received
    double forget_ = 0;       // per-tick forgetting factor exp(-T / tau)
    double s0_ = 0, su_ = 0, sd_ = 0, suu_ = 0, sud_ = 0;
    double mass_ = 0;
    double excitation_ = 0;
    double residual_ = 0, residual_bound_ = 0;
    int agree_ = 0, disagree_ = 0;  // consecutive ticks within the bound / beyond twice the bound
    bool gripped_ = true;
    std::int64_t ticks_since_change_ = 0;
};

}  // namespace hapticd
