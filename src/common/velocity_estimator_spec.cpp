// SPDX-License-Identifier: Apache-2.0
#include "common/velocity_estimator_spec.hpp"

#include <charconv>
#include <cmath>
#include <cstdio>

namespace hapticd {

namespace {

constexpr const char* kForms = "accepted: backward, lowpass:<F>Hz (0 < F <= 1 / (2 T)), window:<N> (1 <= N <= 50)";

}  // namespace

std::optional<VelocityEstimatorSpec> parse_velocity_estimator(std::string_view text, std::string& error) {
    auto fail = [&]() -> std::optional<VelocityEstimatorSpec> {
        error = "velocity_estimator = '" + std::string(text) + "' is invalid; " + kForms;
        return std::nullopt;
    };
    VelocityEstimatorSpec spec;
    if (text == "backward") return spec;
    if (text.starts_with("lowpass:")) {
        std::string_view value = text.substr(8);
        if (!value.ends_with("Hz")) return fail();
        value.remove_suffix(2);
        double f = 0.0;
        const auto [end, ec] = std::from_chars(value.data(), value.data() + value.size(), f);
        if (ec != std::errc{} || end != value.data() + value.size() || !std::isfinite(f) || !(f > 0.0)) return fail();
        spec.kind = hapticopt::VelocityEstimatorKind::lowpass;
        spec.cutoff_hz = f;
        return spec;
    }
    if (text.starts_with("window:")) {
        const std::string_view value = text.substr(7);
        int n = 0;
        const auto [end, ec] = std::from_chars(value.data(), value.data() + value.size(), n);
        if (ec != std::errc{} || end != value.data() + value.size() || n < 1 || n > kMaxLoopVelocityWindow) {
            return fail();
        }
        spec.kind = hapticopt::VelocityEstimatorKind::window;
        spec.window = n;
        return spec;
    }
    return fail();
}

std::string to_string(const VelocityEstimatorSpec& spec) {
    switch (spec.kind) {
        case hapticopt::VelocityEstimatorKind::backward:
            return "backward";
        case hapticopt::VelocityEstimatorKind::lowpass: {
            char buffer[64];
            std::snprintf(buffer, sizeof buffer, "lowpass:%.17gHz", spec.cutoff_hz);
            return buffer;
        }
        case hapticopt::VelocityEstimatorKind::window:
            return "window:" + std::to_string(spec.window);
    }
    return "backward";
}

}  // namespace hapticd
