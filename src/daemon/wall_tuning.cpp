// SPDX-License-Identifier: Apache-2.0
// The tuning step (wall_tuning.hpp). certify_over_plant_set, resolve_walls and robust_box moved here from
// hapticd_main.cpp unchanged.
#include "daemon/wall_tuning.hpp"

#include <algorithm>
#include <map>
#include <sstream>
#include <stdexcept>
#include <string>
#include <tuple>

#include "common/startup_error.hpp"
#include "tuning/object_checks.hpp"

namespace hapticd {

namespace {

// Every wall stable over the profile's plant set (docs/robust-stability.md): the masses mass_range widened by
// mass_margin, with the wall's own mass (its axis's with a mass matrix) and the loop's velocity estimator. A
// criterion's optimum that is not is derated to the largest fraction of it that is (GainChecker::set_stable_factor);
// explicit gains that are not are refused (ErrorKind::UnstableGains) unless --passivity-control renders unstable
// gains on purpose.
void certify_over_plant_set(TuningResult& t, const TuningPlant& wall_plant, const DeviceProfile& p,
                            const std::string& what, bool allow_unstable) {
    GainCheckPlant cp;
    static_cast<TuningPlant&>(cp) = wall_plant;
    // The set holds the mass the wall is tuned for: an identified mass (--identify) may lie outside mass_range.
    if (p.mass_range.size() == 2 && p.mass_model.isotropic)
        cp.mass_range = std::make_pair(std::min(p.mass_range[0], cp.mass), std::max(p.mass_range[1], cp.mass));
    cp.mass_margin = p.mass_margin;
    cp.arm_stiffness_per_mass = p.arm_stiffness_per_mass;
    cp.arm_damping_per_mass = p.arm_damping_per_mass;
    // The set's total delays: inherent_delay_range plus the buffer's whole periods (what the wall's delay adds to the
    // device's), holding the wall's own delay.
    if (p.inherent_delay_range.size() == 2) {
        const double buffer = cp.time_delay - p.inherent_delay;
        cp.delay_range = std::make_pair(std::min(p.inherent_delay_range[0] + buffer, cp.time_delay),
                                        std::max(p.inherent_delay_range[1] + buffer, cp.time_delay));
    }
    const GainChecker checker = [&] {
        try {
            return GainChecker(cp);
        } catch (const std::invalid_argument& e) {
            throw StartupError(ErrorKind::BadConfig, "device profile '" + p.path + "': " + e.what());
        }
    }();
    const auto [c_min, c_max] = checker.mass_scales();
    PlantSetCertificate c;
    c.mass_min = c_min * cp.mass;
    c.mass_max = c_max * cp.mass;
    c.exact = checker.certified();
    c.arm_stiffness_per_mass = cp.arm_stiffness_per_mass;
    c.arm_damping_per_mass = cp.arm_damping_per_mass;
    std::tie(c.delay_min, c.delay_max) = checker.delay_range();
    c.delay_exact = checker.delay_certified();
    double failing_mass = 0.0;
    if (checker.pair_is_stable(t.K, t.B, cp.mass, failing_mass)) {
        c.arm_certified = checker.pair_certified(t.K, t.B, cp.mass);
        t.plant_set = c;
        return;
    }
    if (allow_unstable) return;  // --passivity-control: the controller keeps the wall bounded (no certificate)
    const PairVerdict v = checker.check_pair(t.K, t.B, cp.mass);
    std::ostringstream m;
    m << what << ": K = " << t.K << " N/m, B = " << t.B << " N s/m"
      << (t.explicit_gains ? std::string()
                           : " (the optimum of criterion " + std::string(hapticopt::to_string(t.criterion)) + ")")
      << " are unstable with " << checker.plant_text(v) << " of " << checker.set_text() << " (device profile '"
      << p.path << "': mass_range, mass_margin, arm_stiffness_per_mass, arm_damping_per_mass, inherent_delay_range)";
    if (t.explicit_gains)
        throw StartupError(ErrorKind::UnstableGains, m.str() + "; accepted: gains stable over the set");
    const double T = cp.period;
    const double f = checker.set_stable_factor(cp.mass, t.K * T * T / cp.mass, t.B * T / cp.mass);
    if (!(f > 0.0))
        throw StartupError(ErrorKind::UnstableGains, m.str() + ", and no fraction of them is stable over it");
    t.K *= f;
    t.B *= f;
    t.alpha *= f;
    t.beta *= f;
    t.cost.reset();  // the criterion's cost is predicted at its optimum only
    c.derating = f;
    c.arm_certified = checker.pair_certified(t.K, t.B, cp.mass);
    t.plant_set = c;
}

}  // namespace

std::vector<ResolvedWall> resolve_walls(const Options& o, const DeviceProfile& p, const TuningPlant& plant,
                                        const std::optional<TuningBox>& box) {
    const ErrorKind code = o.walls_from_command_line ? ErrorKind::Usage : ErrorKind::BadConfig;
    const std::string origin = o.walls_from_command_line ? "--wall" : "config file '" + o.config_path + "': wall";
    std::vector<ResolvedWall> walls;
    std::map<std::string, TuningResult> tuned;  // each criterion the scene uses, computed once
    for (const auto& text : o.walls) {
        std::string error;
        const auto spec = parse_wall_spec(text, error);
        if (!spec) throw StartupError(code, origin + ": " + error);
        if (spec->axis >= static_cast<std::size_t>(p.axes)) {
            throw StartupError(code, origin + " '" + text + "': axis = " + std::to_string(spec->axis) +
                                         " is invalid; accepted range: 0 .. " + std::to_string(p.axes - 1) +
                                         " (device '" + p.name + "' has " + std::to_string(p.axes) + " axes)");
        }
        ResolvedWall w;
        w.spec = *spec;
        w.geometry.axis = spec->axis;
        w.geometry.position = spec->position;
        w.geometry.direction = spec->direction;
        w.geometry.mode = spec->mode.value_or(o.bilateral ? WallMode::Bilateral : WallMode::Unilateral);
        const hapticopt::Criterion criterion = spec->criterion.value_or(o.criterion);
        const std::string criterion_name(hapticopt::to_string(criterion));
        // An axis-aligned wall acts with the mass along its axis, 1 / (M^-1)_aa (config/profile_keys.hpp).
        TuningPlant wall_plant = plant;
        std::string axis_key;
        if (!p.mass_model.isotropic) {
            wall_plant.mass = p.mass_model.of_axis(spec->axis);
            axis_key = "@axis" + std::to_string(spec->axis);
        }
        // The noise budget bounds the force noise of the wall's axis's encoder step.
        wall_plant.position_resolution = p.position_resolution[spec->axis];
        wall_plant.force_noise_budget = p.force_noise_budget;
        if (p.force_noise_budget) axis_key = "@axis" + std::to_string(spec->axis);
        if (o.gains_set) {
            auto it = tuned.find("explicit" + axis_key);
            if (it == tuned.end()) {
                it = tuned
                         .emplace("explicit" + axis_key, check_explicit_gains(o.stiffness, o.damping, o.criterion,
                                                                              wall_plant, o.passivity_control))
                         .first;
            }
            w.tuning = it->second;
        } else {
            auto it = tuned.find(criterion_name + axis_key);
            if (it == tuned.end()) {
                it = tuned
                         .emplace(criterion_name + axis_key,
                                  box ? tune_wall_robust(criterion, *box) : tune_wall(criterion, wall_plant))
                         .first;
            }
            w.tuning = it->second;
        }
        certify_over_plant_set(w.tuning, wall_plant, p, origin + " '" + text + "'", o.passivity_control);
        predict_encoder_effects(w.tuning, wall_plant, p.position_resolution[spec->axis],
                                p.coulomb_friction[spec->axis]);
        if (p.max_stiffness && w.tuning.K > *p.max_stiffness) {
            std::ostringstream m;
            m << origin << " '" << text << "': K = " << w.tuning.K << " N/m"
              << (o.gains_set ? std::string() : " (the optimum of criterion " + criterion_name + ")")
              << " exceeds the device's stiffness limit (device profile '" << p.path
              << "': max_stiffness = " << *p.max_stiffness << " N/m); accepted range: K <= " << *p.max_stiffness
              << " N/m";
            throw StartupError(ErrorKind::InvalidParameter, m.str());
        }
        walls.push_back(w);
    }
    return walls;
}

// The box of --robust: the identified values +- 3 standard errors after an identification, else the profile's
// *_range keys (a missing key: the nominal value, exact). Physical bounds are kept (mass > 0, b, k, delay >= 0).
TuningBox robust_box(const Options& o, const DeviceProfile& p, const std::optional<IdentificationStage>& ident,
                     double period) {
    const double buffer = static_cast<double>(o.delay_buffer) / o.rate;
    TuningBox b;
    b.period = period;
    b.velocity = p.velocity_estimator;
    // The budget judged with the coarsest axis's encoder step (sigma_F grows with q): met on every axis.
    if (p.force_noise_budget) {
        b.force_noise_budget = p.force_noise_budget;
        for (const double q : p.position_resolution) b.position_resolution = std::max(b.position_resolution, q);
    }
    if (ident) {
        const IdentificationResult& r = ident->result;
        constexpr double k = 3.0;  // +- 3 standard errors
        b.mass_min = std::max(0.5 * r.mass, r.mass - k * r.mass_stderr);
        b.mass_max = r.mass + k * r.mass_stderr;
        b.damping_min = std::max(0.0, r.damping - k * r.damping_stderr);
        b.damping_max = std::max(0.0, r.damping + k * r.damping_stderr);
        b.stiffness_min = std::max(0.0, r.stiffness - k * r.stiffness_stderr);
        b.stiffness_max = std::max(0.0, r.stiffness + k * r.stiffness_stderr);
        b.delay_min = std::max(0.0, r.delay_periods - k * r.delay_stderr) * period + buffer;
        b.delay_max = (r.delay_periods + k * r.delay_stderr) * period + buffer;
        return b;
    }
    if (p.mass_range.empty() && p.damping_range.empty() && p.stiffness_range.empty() &&
        p.inherent_delay_range.empty()) {
        throw StartupError(ErrorKind::BadConfig,
                           "device profile '" + p.path +
                               "': --robust needs at least one of the keys mass_range, damping_range, "
                               "stiffness_range, inherent_delay_range ([min, max]), or --identify");
    }
    auto lo = [](const std::vector<double>& r, double nominal) { return r.empty() ? nominal : r[0]; };
    auto hi = [](const std::vector<double>& r, double nominal) { return r.empty() ? nominal : r[1]; };
    b.mass_min = lo(p.mass_range, p.mass);
    b.mass_max = hi(p.mass_range, p.mass);
    b.damping_min = lo(p.damping_range, p.damping);
    b.damping_max = hi(p.damping_range, p.damping);
    b.stiffness_min = lo(p.stiffness_range, p.stiffness);
    b.stiffness_max = hi(p.stiffness_range, p.stiffness);
    b.delay_min = lo(p.inherent_delay_range, p.inherent_delay) + buffer;
    b.delay_max = hi(p.inherent_delay_range, p.inherent_delay) + buffer;
    return b;
}

}  // namespace hapticd
