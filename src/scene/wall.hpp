// SPDX-License-Identifier: Apache-2.0
// One virtual wall: exactly the analysed discrete spring-damper (backward difference),
//     f_j = K x_j + B (x_j - x_{j-1}) / T,
// or, with another velocity estimator (the scene's VelocityFilter), f_j = K x_j + B v_j with v_j its estimate along
// the normal,
// with x the penetration along the wall normal (x > 0 inside the wall) and f > 0 pushing out.
// Bilateral (the paper's analysis): the law everywhere. Unilateral (default): the law only while
// penetrating (x_j > 0), and only pushing out (f >= 0); outside, no force and no arithmetic beyond
// remembering x_j for the next difference.
#pragma once

#include <cstddef>
#include <string_view>

#include "common/axis_vector.hpp"

namespace hapticd {

enum class WallMode : unsigned char { Unilateral, Bilateral };
std::string_view to_string(WallMode mode) noexcept;

struct WallGeometry {
    std::size_t axis = 0;    // device axis the wall acts on
    double position = 0.0;   // surface position on that axis, m
    double direction = 1.0;  // +1: solid for coordinates > position; -1: solid below position
    WallMode mode = WallMode::Unilateral;
};

class VirtualWall {
  public:
    // Throws std::invalid_argument for non-finite or negative gains, period <= 0, |direction| != 1.
    VirtualWall(const WallGeometry& geometry, double stiffness, double damping, double period);

    [[nodiscard]] double penetration(const AxisVector& position) const noexcept {
        return geometry_.direction * (position[geometry_.axis] - geometry_.position);
    }

    // Force along the normal for penetration x_j (updates the difference history). The first call
    // takes x_{-1} = x_0 (no velocity estimate from before the start; for the paper's step, x_0 = 0).
    double normal_force(double x) noexcept {
        const double prev = primed_ ? x_prev_ : x;
        primed_ = true;
        x_prev_ = x;
        if (geometry_.mode == WallMode::Unilateral) {
            if (!(x > 0.0)) {
                return 0.0;  // not in contact
            }
            const double f = stiffness_ * x + damping_ * (x - prev) / period_;
            return f > 0.0 ? f : 0.0;
        }
        return stiffness_ * x + damping_ * (x - prev) / period_;
    }

    // The same law with the velocity along the normal given (rate: the loop's velocity estimate of the handle
    // projected on the normal, scene/velocity_filter.hpp) instead of the backward difference; x_j is remembered as
    // above.
    double normal_force(double x, double rate) noexcept {
        primed_ = true;
        x_prev_ = x;
        if (geometry_.mode == WallMode::Unilateral) {
            if (!(x > 0.0)) {
                return 0.0;
            }
            const double f = stiffness_ * x + damping_ * rate;
            return f > 0.0 ? f : 0.0;
        }
        return stiffness_ * x + damping_ * rate;
    }

    // Force on the device along its axis (device frame).
    double device_force(const AxisVector& position) noexcept {
        return -geometry_.direction * normal_force(penetration(position));
    }

    // New gains from the next normal_force on (daemon/wall_retuner.hpp): the caller passes gains it validated at
    // start-up (finite, >= 0: a VirtualWall was constructed with them); the difference history is kept.
    void set_gains(double stiffness, double damping) noexcept {
        stiffness_ = stiffness;
        damping_ = damping;
    }

    void reset() noexcept {
        primed_ = false;
        x_prev_ = 0.0;
    }

    [[nodiscard]] const WallGeometry& geometry() const noexcept { return geometry_; }
    [[nodiscard]] double stiffness() const noexcept { return stiffness_; }
    [[nodiscard]] double damping() const noexcept { return damping_; }

  private:
    WallGeometry geometry_;
    double stiffness_;
    double damping_;
    double period_;
    double x_prev_ = 0.0;
    bool primed_ = false;
};

}  // namespace hapticd
