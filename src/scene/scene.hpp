// SPDX-License-Identifier: Apache-2.0
// The scene: the walls of the configuration and what one tick of wall rendering does with them.
// Each tick: check the sampled position, estimate the velocity (unless backward), let every wall add its force on its
// axis (a unilateral wall out of contact costs one subtraction and a comparison) and check the sum is finite. A
// non-finite position or force latches the fault state: zero force from that tick on, until reset(). The sum is not
// saturated here: the force limiter (force_limiter.hpp) is the one stage that saturates and rate-limits the force
// written to the device.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include <hapticopt/criterion.hpp>

#include "common/axis_vector.hpp"
#include "common/velocity_estimator_spec.hpp"
#include "scene/velocity_filter.hpp"
#include "scene/wall.hpp"

namespace hapticd {

// One wall as written in the configuration, e.g. "axis=0 position=0.0 direction=+1 mode=bilateral
// criterion=CE1". Keys: axis (0..2), position (m), direction (+1|-1), mode (unilateral|bilateral;
// unset: the global --bilateral), criterion (a name of hapticopt::Criterion, parsed here; unset: the global
// --criterion).
struct WallSpec {
    std::size_t axis = 0;
    double position = 0.0;
    double direction = 1.0;
    std::optional<WallMode> mode;
    std::optional<hapticopt::Criterion> criterion;
};

// Parses one wall specification. On error returns std::nullopt and sets `error` to a message naming the
// key, its value and the accepted range.
std::optional<WallSpec> parse_wall_spec(const std::string& text, std::string& error);
std::string to_string(const WallSpec& spec);

enum class SceneFault : std::uint8_t { None, NonFinitePosition, NonFiniteForce };
std::string_view to_string(SceneFault fault) noexcept;

class Scene {
  public:
    // `velocity`: the estimate the walls' dampers act on (backward: each wall's own difference of its penetration,
    // the analysed law; otherwise one VelocityFilter of every axis, each wall taking its axis's estimate times its
    // direction). Throws std::invalid_argument naming the parameter.
    Scene(std::vector<VirtualWall> walls, std::size_t axes, double max_force,
          const VelocityEstimatorSpec& velocity = {}, double period = 1e-3);

    // Force on the device for the sampled position. Real-time safe (no allocation, no exceptions).
    SceneFault evaluate(const AxisVector& position, AxisVector& force) noexcept;

    [[nodiscard]] SceneFault fault() const noexcept { return fault_; }
    // The walls in contact at the last evaluate(): bit i for walls()[i] (the first 64), set while the handle
    // is behind its surface (penetration x > 0; the same flag as a client plane's, SceneObjects::contact_mask).
    // Zero after a fault.
    [[nodiscard]] std::uint64_t contact_mask() const noexcept { return contact_mask_; }
    [[nodiscard]] const std::vector<VirtualWall>& walls() const noexcept { return walls_; }
    // Wall i's gains from the next evaluate() on (--retune, daemon/wall_retuner.hpp): gains the caller validated
    // (each a VirtualWall's at start-up); i < walls().size(). Real-time safe.
    void set_wall_gains(std::size_t i, double stiffness, double damping) noexcept {
        walls_[i].set_gains(stiffness, damping);
    }
    // The device's limit per axis, for the force limiter (Daemon takes it when DaemonConfig::max_force is 0).
    [[nodiscard]] double max_force() const noexcept { return max_force_; }
    void reset() noexcept;

  private:
    std::vector<VirtualWall> walls_;
    std::size_t axes_;
    double max_force_;
    std::optional<VelocityFilter> velocity_;  // none: backward difference per wall
    SceneFault fault_ = SceneFault::None;
    std::uint64_t contact_mask_ = 0;
};

}  // namespace hapticd
