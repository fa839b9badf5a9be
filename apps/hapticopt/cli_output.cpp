// SPDX-License-Identifier: Apache-2.0
#include "cli_output.hpp"

#include <cmath>
#include <cstdio>

namespace hapticopt::cli {

nlohmann::json islands_json(const EstimatorStabilityRegion& region) {
    nlohmann::json islands = nlohmann::json::array();
    for (const StableIsland& i : region.islands()) {
        islands.push_back({{"alpha_min", i.alpha_min},
                           {"alpha_max", i.alpha_max},
                           {"beta_min", i.beta_min},
                           {"beta_max", i.beta_max}});
    }
    return islands;
}

nlohmann::json number_or_null(double value) {
    return std::isfinite(value) ? nlohmann::json(value) : nlohmann::json(nullptr);
}

void PlantOptions::add_to(CLI::App& app) {
    app.add_option("--gamma", gamma, "normalised physical stiffness k T^2/m (>= 0)")->capture_default_str();
    app.add_option("--delta", delta, "normalised physical damping b T/m (>= 0)")->capture_default_str();
    app.add_option("--delay", delay, "delay d = t_d/T in periods (>= 0, may be fractional)")->capture_default_str();
}

void VelocityOption::add_to(CLI::App& app) {
    app.add_option(
           "--velocity", text,
           "velocity estimator: backward (the paper's), lowpass:NU (first-order low-pass after the backward "
           "difference, normalised cutoff nu = f_c T > 0; lowpass:20Hz with --period), window:N (difference over "
           "N >= 1 periods)")
        ->capture_default_str();
}

VelocityEstimator VelocityOption::parse(double period) const {
    const char* fn = "hapticopt --velocity";
    auto number = [&](const std::string& s, double& v) {
        std::size_t used = 0;
        try {
            v = std::stod(s, &used);
        } catch (const std::exception&) {
            return false;
        }
        return used == s.size() && !s.empty();
    };
    if (text == "backward") return VelocityEstimator::backward_difference();
    if (text.rfind("lowpass:", 0) == 0) {
        std::string value = text.substr(8);
        const bool hertz = value.size() > 2 && value.compare(value.size() - 2, 2, "Hz") == 0;
        if (hertz) value.resize(value.size() - 2);
        double v = 0;
        if (!number(value, v)) {
            throw InvalidParameter(fn, "lowpass cutoff", std::nan(""),
                                   "lowpass:NU with NU > 0, or lowpass:FHz with --period");
        }
        if (hertz) {
            if (!(period > 0))
                throw InvalidParameter(fn, "period (needed by lowpass:FHz)", period, "--period T > 0 [s]");
            v *= period;
        }
        return VelocityEstimator::low_pass(v);
    }
    if (text.rfind("window:", 0) == 0) {
        double v = 0;
        if (!number(text.substr(7), v) || v != std::floor(v)) {
            throw InvalidParameter(fn, "window", v, "window:N with an integer 1 <= N <= 1000");
        }
        if (!(v >= 1 && v <= kMaxVelocityWindow)) throw InvalidParameter(fn, "window", v, "1 <= N <= 1000 periods");
        return VelocityEstimator::moving_window(static_cast<int>(v));
    }
    throw InvalidParameter(fn, "velocity (" + text + ")", std::nan(""),
                           "backward, lowpass:NU, lowpass:FHz or window:N");
}

nlohmann::json velocity_json(const VelocityEstimator& e) {
    nlohmann::json out;
    switch (e.kind) {
        case VelocityEstimatorKind::backward:
            out["kind"] = "backward";
            break;
        case VelocityEstimatorKind::lowpass:
            out["kind"] = "lowpass";
            out["cutoff"] = e.cutoff;
            break;
        case VelocityEstimatorKind::window:
            out["kind"] = "window";
            out["window"] = e.window;
            break;
    }
    return out;
}

std::string velocity_text(const VelocityEstimator& e) {
    char buffer[64];
    switch (e.kind) {
        case VelocityEstimatorKind::lowpass:
            std::snprintf(buffer, sizeof buffer, "lowpass nu = %.6g", e.cutoff);
            return buffer;
        case VelocityEstimatorKind::window:
            std::snprintf(buffer, sizeof buffer, "window N = %d", e.window);
            return buffer;
        case VelocityEstimatorKind::backward:
            break;
    }
    return "backward";
}

}  // namespace hapticopt::cli
