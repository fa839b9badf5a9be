// SPDX-License-Identifier: Apache-2.0
#include "server/object_limits.hpp"

#include <algorithm>

namespace hapticd::server {

std::optional<LimitRefusal> check_in_workspace(const client::Vec3& v, const std::string& field,
                                               const WorkspaceBox& box) {
    for (std::size_t a = 0; a < box.axes && a < 3; ++a) {
        if (v[a] < box.min[a] || v[a] > box.max[a]) {
            return LimitRefusal{client::ErrorCode::BeyondDeviceLimits,
                                field + "[" + std::to_string(a) + "] = " + short_number(v[a]) +
                                    " m is outside the device's workspace; accepted range: " +
                                    short_number(box.min[a]) + " .. " + short_number(box.max[a]) + " m"};
        }
    }
    return std::nullopt;
}

std::optional<LimitRefusal> check_plane_in_workspace(const client::Vec3& n, double offset, const WorkspaceBox& box) {
    double lo = 0.0, hi = 0.0;
    for (std::size_t a = 0; a < box.axes && a < 3; ++a) {
        lo += std::min(n[a] * box.min[a], n[a] * box.max[a]);
        hi += std::max(n[a] * box.min[a], n[a] * box.max[a]);
    }
    if (offset >= lo && offset <= hi) return std::nullopt;
    return LimitRefusal{client::ErrorCode::BeyondDeviceLimits,
                        "plane.offset = " + short_number(offset) +
                            " m puts the plane outside the device's workspace; accepted range for this normal: " +
                            short_number(lo) + " .. " + short_number(hi) + " m (n.x over the workspace)"};
}

std::optional<LimitRefusal> check_explicit_gains(double K, double B, const std::string& kind) {
    if (K >= 0.0 && K <= kMaxGainK && B >= 0.0 && B <= kMaxGainB) return std::nullopt;
    return LimitRefusal{client::ErrorCode::BadMessage,
                        kind + ".gains: K = " + short_number(K) + " N/m, B = " + short_number(B) +
                            " N s/m are invalid; accepted range: 0 <= K <= " + short_number(kMaxGainK) +
                            " N/m, 0 <= B <= " + short_number(kMaxGainB) + " N s/m (finite)"};
}

std::optional<LimitRefusal> check_field_damping(double B) {
    if (B >= 0.0 && B <= kMaxGainB) return std::nullopt;
    return LimitRefusal{client::ErrorCode::BadMessage, "field.damping = " + short_number(B) +
                                                           " N s/m is invalid; accepted range: 0 .. " +
                                                           short_number(kMaxGainB) + " N s/m (finite)"};
}

}  // namespace hapticd::server
