// SPDX-License-Identifier: Apache-2.0
// The range checks of one object against the device, before any stability test (docs/protocol.md,
// section 5): positions inside the profile's workspace box, planes that meet it, explicit gains below the
// plausibility bounds that keep the stability test's arithmetic finite. Pure functions (the fuzz target
// tests/fuzz/fuzz_server_messages.cpp runs them on every decoded object).
#pragma once

#include <array>
#include <cstddef>
#include <optional>
#include <string>

#include "common/number_text.hpp"
#include "hapticd/client.hpp"

namespace hapticd::server {

struct WorkspaceBox {
    std::size_t axes = 1;
    std::array<double, 3> min{-1e9, -1e9, -1e9};  // m per axis (the profile's workspace_min)
    std::array<double, 3> max{1e9, 1e9, 1e9};
};

struct LimitRefusal {
    client::ErrorCode code = client::ErrorCode::BadMessage;  // BeyondDeviceLimits or BadMessage
    std::string message;
};

// Explicit gains: 0 <= K <= kMaxGainK, 0 <= B <= kMaxGainB, finite. Every stable pair of a real device lies
// orders of magnitude below; alpha = K T^2 / m and beta = B T / m stay finite for any profile.
inline constexpr double kMaxGainK = 1e12;  // N/m
inline constexpr double kMaxGainB = 1e9;   // N s/m

// Every refusal prints numbers with common/number_text.hpp's short_number (6 significant digits).
using hapticd::short_number;

// `field`[a] inside [min_a, max_a] on the device's axes (beyond_device_limits naming the field and the range).
[[nodiscard]] std::optional<LimitRefusal> check_in_workspace(const client::Vec3& v, const std::string& field,
                                                             const WorkspaceBox& box);

// The plane n.x = offset meets the box: offset between the smallest and the largest n.x over its corners,
// sum_a min(n_a lo_a, n_a hi_a) .. sum_a max(n_a lo_a, n_a hi_a).
[[nodiscard]] std::optional<LimitRefusal> check_plane_in_workspace(const client::Vec3& normal, double offset,
                                                                   const WorkspaceBox& box);

// `kind` names the object ("plane") in the message.
[[nodiscard]] std::optional<LimitRefusal> check_explicit_gains(double K, double B, const std::string& kind);

// A field's damping: 0 <= B <= kMaxGainB (a field without stiffness has no per-object stability test).
[[nodiscard]] std::optional<LimitRefusal> check_field_damping(double B);

}  // namespace hapticd::server
