// The daemon's adapter to hapticopt: optimal wall gains for a criterion and a device, or the check of
// explicit gains against the stability region. Runs at start-up only.
#pragma once

#include <optional>
#include <string>
#include <vector>

namespace hapticd {

struct TuningPlant {
    double mass = 0.0;        // kg (kg m^2)
    double damping = 0.0;     // N s/m
    double stiffness = 0.0;   // N/m
    double period = 1e-3;     // s
    double time_delay = 0.0;  // s, total: device's inherent delay + delay buffer
};

struct TuningResult {
    std::string criterion;          // "CE2", ...
    bool explicit_gains = false;    // K, B given by the user (then `criterion` only names the reported cost)
    double K = 0.0;                 // N/m
    double B = 0.0;                 // N s/m
    double alpha = 0.0;             // K T^2 / m
    double beta = 0.0;              // B T / m
    std::optional<double> cost;     // predicted cost of `criterion` at (alpha, beta)
    double alpha_max = 0.0;         // largest stable alpha of the plant
    [[nodiscard]] double stability_margin() const { return alpha_max > 0.0 ? alpha / alpha_max : 0.0; }
};

// The criteria hapticd accepts (the paper's seven).
const std::vector<std::string>& accepted_criteria();
[[nodiscard]] bool is_accepted_criterion(const std::string& name);

// Optimal gains for the criterion (computes only that criterion). Throws StartupError
// (kExitInvalidParameter) when hapticopt rejects a parameter.
TuningResult tune_wall(const std::string& criterion, const TuningPlant& plant);

// Explicit gains: accepted when inside the stability region (cost of `criterion` predicted when it is an
// energy or overshoot criterion); refused with StartupError(kExitUnstableGains) naming K, B, alpha, beta
// and alpha_max otherwise.
TuningResult check_explicit_gains(double K, double B, const std::string& criterion, const TuningPlant& plant);

}  // namespace hapticd
