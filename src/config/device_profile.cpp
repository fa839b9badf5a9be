// SPDX-License-Identifier: Apache-2.0
// The device profile (options.hpp: DeviceProfile): where it is looked for, its keys read with their range
// checks, and the options that override or restrict them (--velocity-estimator, --force-noise-budget,
// --identify, --robust, --passivity-control).
#include "config/options.hpp"

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <filesystem>
#include <regex>
#include <utility>

#include <CLI/CLI.hpp>

#include "config/apply_config_file.hpp"
#include "config/config_locations.hpp"
#include "config/option_ranges.hpp"

namespace hapticd {

namespace fs = std::filesystem;

std::vector<std::string> device_profile_dirs(const Options& o) {
    std::vector<std::string> dirs;
    if (!o.config_path.empty()) dirs.push_back((fs::path(o.config_path).parent_path() / "devices").string());
    for (const auto& dir : config_search_dirs()) dirs.push_back((fs::path(dir) / "devices").string());
    return dirs;
}

std::string resolve_device_profile_path(const Options& o) {
    const std::string& d = o.device;
    if (d.find('/') != std::string::npos || (d.size() > 5 && d.substr(d.size() - 5) == ".toml")) {
        return d;
    }
    static const std::regex name_re(R"([A-Za-z0-9_-]+)");
    if (!std::regex_match(d, name_re)) {
        throw StartupError(
            ErrorKind::Usage,
            "device = '" + d + "' is invalid; accepted: a profile name ([A-Za-z0-9_-]+) or a path to a .toml file");
    }
    // The first devices/<name>.toml of device_profile_dirs(); the last candidate (for the error) when none exists.
    const std::vector<std::string> dirs = device_profile_dirs(o);
    for (const auto& dir : dirs) {
        const fs::path candidate = fs::path(dir) / (d + ".toml");
        std::error_code ec;
        if (fs::exists(candidate, ec)) return candidate.string();
    }
    return (fs::path(dirs.back()) / (d + ".toml")).string();
}

DeviceProfile load_device_profile(const Options& o) {
    DeviceProfile p;
    p.path = resolve_device_profile_path(o);
    if (!fs::is_regular_file(p.path)) {
        throw StartupError(ErrorKind::BadConfig, "device profile '" + p.path + "' (device = '" + o.device +
                                                     "') does not exist or is not a file");
    }
    CLI::App app{"hapticd device profile"};
    app.set_help_flag();
    app.add_option("--name", p.name);
    app.add_option("--description", p.description);
    app.add_option("--driver", p.driver)->check(CLI::IsMember({"sim", "falcon", "hid", "lwr"}));
    MassKeys mass_keys;
    add_mass_keys(app, mass_keys);
    app.add_option("--damping", p.damping);
    app.add_option("--stiffness", p.stiffness);
    app.add_option("--inherent_delay", p.inherent_delay);
    auto* max_force = app.add_option("--max_force", p.max_force);
    app.add_option("--axes", p.axes);
    app.add_option("--workspace_min", p.workspace_min);
    app.add_option("--workspace_max", p.workspace_max);
    app.add_option("--rotary", p.rotary);
    app.add_option("--position_noise", p.position_noise);
    std::vector<double> position_resolution;
    app.add_option("--position_resolution", position_resolution);
    std::vector<double> coulomb_friction;
    app.add_option("--coulomb_friction", coulomb_friction);
    std::string velocity_estimator = "backward";
    app.add_option("--velocity_estimator", velocity_estimator);
    double force_noise_budget = 0.0;
    auto* noise_budget = app.add_option("--force_noise_budget", force_noise_budget);
    app.add_option("--noise_seed", p.noise_seed);
    app.add_option("--fail_at_tick", p.fail_at_tick);
    app.add_option("--mass_range", p.mass_range);
    app.add_option("--mass_margin", p.mass_margin);
    app.add_option("--arm_stiffness_per_mass", p.arm_stiffness_per_mass);
    app.add_option("--arm_damping_per_mass", p.arm_damping_per_mass);
    app.add_option("--damping_range", p.damping_range);
    app.add_option("--retune", p.retune);
    app.add_option("--stiffness_range", p.stiffness_range);
    app.add_option("--inherent_delay_range", p.inherent_delay_range);
    add_real_device_keys(app, p.real);
    const KeyLocations where = apply_config_file(app, "device profile '" + p.path + "'", p.path, true);
    read_mass_keys_given(app, mass_keys);
    if (max_force->count() == 0) {
        throw StartupError(ErrorKind::BadConfig, "device profile '" + p.path + "': missing key 'max_force'");
    }
    if (p.name.empty()) p.name = fs::path(p.path).stem().string();
    check_range(where, "damping", p.damping, 0.0, 1e9, false, "finite, >= 0 N s/m");
    check_range(where, "stiffness", p.stiffness, 0.0, 1e12, false, "finite, >= 0 N/m");
    check_range(where, "inherent_delay", p.inherent_delay, 0.0, 1.0, false, "0 .. 1 s");
    check_range(where, "max_force", p.max_force, 0.0, 1e6, true, "finite, > 0 N (N m)");
    if (p.axes < 1 || p.axes > 3) invalid(where, "axes", std::to_string(p.axes), "1 .. 3");
    const auto axes = static_cast<std::size_t>(p.axes);
    // The mass: one value, one per axis or a matrix (config/profile_keys.hpp), and the stiffness limit.
    const ProfileMass plant_mass = validate_mass_keys(where, axes, mass_keys, p.damping, p.stiffness);
    p.mass_model = plant_mass.mass;
    p.max_stiffness = plant_mass.max_stiffness;
    p.mass = p.mass_model.of_axis(0);
    if (!p.mass_model.isotropic) {
        // These model one mass (identification fits one, the robust box and the passivity cap use one).
        for (auto [set, option] : {std::pair{o.identify, "--identify"}, std::pair{o.robust, "--robust"},
                                   std::pair{o.passivity_control, "--passivity-control"}}) {
            if (set) {
                throw StartupError(ErrorKind::Usage,
                                   where.prefix(mass_keys.mass_given ? "mass" : "mass_matrix") + std::string(option) +
                                       " models one mass for every axis; this profile's mass is anisotropic (" +
                                       p.mass_model.describe() + "); accepted: a profile with one mass");
            }
        }
        if (!p.mass_range.empty()) {
            invalid(where, "mass_range", "[" + std::to_string(p.mass_range[0]) + ", ...]",
                    "no mass_range with an anisotropic mass (--robust models one mass)");
        }
    }
    for (auto* ws : {&p.workspace_min, &p.workspace_max}) {
        if (!ws->empty() && ws->size() != axes) {
            invalid(where, ws == &p.workspace_min ? "workspace_min" : "workspace_max",
                    std::to_string(ws->size()) + " values", "one value per axis (" + std::to_string(axes) + ")");
        }
        for (double v : *ws) {
            check_range(where, ws == &p.workspace_min ? "workspace_min" : "workspace_max", v, -1e3, 1e3, false,
                        "finite, |x| <= 1000 m");
        }
    }
    check_range(where, "position_noise", p.position_noise, 0.0, 1.0, false, "0 .. 1 m");
    if (position_resolution.size() > 1 && position_resolution.size() != axes) {
        invalid(where, "position_resolution", std::to_string(position_resolution.size()) + " values",
                "one value, or one per axis (" + std::to_string(axes) + ")");
    }
    for (std::size_t a = 0; a < axes; ++a) {
        if (position_resolution.empty()) break;
        const double q = position_resolution[position_resolution.size() == 1 ? 0 : a];
        check_range(where, "position_resolution", q, 0.0, 1.0, false, "0 .. 1 m (rad) per axis");
        p.position_resolution[a] = q;
    }
    if (coulomb_friction.size() > 1 && coulomb_friction.size() != axes) {
        invalid(where, "coulomb_friction", std::to_string(coulomb_friction.size()) + " values",
                "one value, or one per axis (" + std::to_string(axes) + ")");
    }
    for (std::size_t a = 0; a < axes; ++a) {
        if (coulomb_friction.empty()) break;
        const double f = coulomb_friction[coulomb_friction.size() == 1 ? 0 : a];
        check_range(where, "coulomb_friction", f, 0.0, 1e6, false, "finite, 0 .. 1e6 N (N m) per axis");
        p.coulomb_friction[a] = f;
    }
    bool budget_given = noise_budget->count() > 0;
    if (o.force_noise_budget) {
        // --force-noise-budget overrides the key; 0 removes the budget.
        const double budget = *o.force_noise_budget;
        if (!std::isfinite(budget) || budget < 0.0 || budget > 1e6) {
            throw StartupError(ErrorKind::InvalidParameter, "--force-noise-budget = " + shortest_text(budget) +
                                                                " is invalid; accepted range: 0 (none) or finite, "
                                                                "> 0 N (N m)");
        }
        budget_given = budget > 0.0;
        force_noise_budget = budget;
    }
    if (budget_given) {
        check_range(where, "force_noise_budget", force_noise_budget, 0.0, 1e6, true, "finite, > 0 N (N m)");
        if (std::none_of(p.position_resolution.begin(),
                         p.position_resolution.begin() + static_cast<std::ptrdiff_t>(axes),
                         [](double q) { return q > 0.0; })) {
            invalid(where, "force_noise_budget", shortest_text(force_noise_budget),
                    "a budget with position_resolution > 0 (the encoder step whose rounding causes the noise)");
        }
        p.force_noise_budget = force_noise_budget;
    }
    {
        // --velocity-estimator overrides the profile's key (its error then names the option).
        const bool from_option = !o.velocity_estimator.empty();
        if (from_option) velocity_estimator = o.velocity_estimator;
        std::string error;
        const auto estimator = parse_velocity_estimator(velocity_estimator, error);
        if (!estimator) {
            throw StartupError(ErrorKind::InvalidParameter, from_option ? "--velocity-estimator: " + error
                                                                        : where.prefix("velocity_estimator") + error);
        }
        const double nyquist = o.rate / 2.0;
        if (estimator->kind == hapticopt::VelocityEstimatorKind::lowpass && estimator->cutoff_hz > nyquist) {
            invalid(where, "velocity_estimator", velocity_estimator,
                    "lowpass:<F>Hz with F <= " + std::to_string(nyquist) + " Hz (the Nyquist frequency of --rate)");
        }
        p.velocity_estimator = *estimator;
        // The passivity controller's observer analyses the backward difference only, and it does not bound the
        // force noise (--robust analyses the loop's estimator and meets the budget: robust_optimum.hpp).
        for (auto [set, option] : {std::pair{o.passivity_control, "--passivity-control"}}) {
            if (set && !estimator->is_backward()) {
                throw StartupError(ErrorKind::Usage, where.prefix("velocity_estimator") + std::string(option) +
                                                         " models the backward difference only; the "
                                                         "velocity_estimator is " +
                                                         velocity_estimator +
                                                         "; accepted: --velocity-estimator backward with " + option);
            }
            if (set && p.force_noise_budget) {
                throw StartupError(ErrorKind::Usage, where.prefix("force_noise_budget") + std::string(option) +
                                                         " does not bound the force noise; the force_noise_budget "
                                                         "is " +
                                                         shortest_text(*p.force_noise_budget) +
                                                         " N; accepted: --force-noise-budget 0 with " + option);
            }
        }
    }
    validate_real_device_keys(where, p.driver, p.real);
    struct RangeKey {
        const char* key;
        const std::vector<double>* range;
        double nominal;
        double lo;
        double hi;
        bool lo_open;
        const char* accepted;
    };
    for (const RangeKey& r :
         {RangeKey{"mass_range", &p.mass_range, p.mass, 0.0, 1e6, true, "finite, > 0 kg"},
          RangeKey{"damping_range", &p.damping_range, p.damping, 0.0, 1e9, false, "finite, >= 0 N s/m"},
          RangeKey{"stiffness_range", &p.stiffness_range, p.stiffness, 0.0, 1e12, false, "finite, >= 0 N/m"},
          RangeKey{"inherent_delay_range", &p.inherent_delay_range, p.inherent_delay, 0.0, 1.0, false, "0 .. 1 s"}}) {
        const std::vector<double>& v = *r.range;
        if (v.empty()) continue;
        if (v.size() != 2) invalid(where, r.key, std::to_string(v.size()) + " values", "[min, max]");
        for (double x : v) check_range(where, r.key, x, r.lo, r.hi, r.lo_open, r.accepted);
        if (!(v[0] <= r.nominal && r.nominal <= v[1])) {
            invalid(where, r.key, "[" + std::to_string(v[0]) + ", " + std::to_string(v[1]) + "]",
                    "min <= nominal value (" + std::to_string(r.nominal) + ") <= max");
        }
    }
    check_range(where, "mass_margin", p.mass_margin, 0.0, 1.0, false, "0 .. 1 (relative)");
    check_range(where, "arm_stiffness_per_mass", p.arm_stiffness_per_mass, 0.0, 1e6, false, "0 .. 1e6 s^-2 (k_H / m)");
    check_range(where, "arm_damping_per_mass", p.arm_damping_per_mass, 0.0, 1e4, false, "0 .. 1e4 s^-1 (b_H / m)");
    return p;
}

}  // namespace hapticd
