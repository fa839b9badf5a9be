// SPDX-License-Identifier: Apache-2.0
// --retune's table (retune.hpp).
#include "daemon/retune.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <sstream>
#include <stdexcept>

#include <hapticopt/parameters.hpp>
#include <hapticopt/sampled_plant.hpp>
#include <hapticopt/switching_dwell.hpp>
#include <hapticopt/switching_loop.hpp>

#include "common/startup_error.hpp"
#include "scene/wall.hpp"

namespace hapticd {

namespace {

constexpr const char* kAccepted =
    "accepted: --retune with the config walls tuned for a criterion (no --stiffness/--damping, --robust, "
    "--identify, --identification-file, --passivity-control or --serve) on a profile with one mass and "
    "mass_range";

void refuse(ErrorKind kind, const std::string& why) { throw StartupError(kind, "--retune: " + why + "; " + kAccepted); }

}  // namespace

RetuneTable make_retune_table(const Options& o, const DeviceProfile& p, const TuningPlant& plant,
                              const std::vector<ResolvedWall>& walls, bool identified) {
    if (o.serve) {
        refuse(ErrorKind::Usage,
               "--serve renders client objects whose gains are not in the switch certificate (config walls only)");
    }
    if (o.gains_set) refuse(ErrorKind::Usage, "--stiffness/--damping give one gain pair; re-tuning needs a criterion");
    if (o.robust) refuse(ErrorKind::Usage, "--robust gives one gain pair for the whole set; nothing to switch");
    if (identified) refuse(ErrorKind::Usage, "--identify/--identification-file tune for the identified plant");
    if (o.passivity_control) refuse(ErrorKind::Usage, "--passivity-control changes the law outside the certificate");
    if (walls.empty()) refuse(ErrorKind::Usage, "no config wall to re-tune");
    if (!p.mass_model.isotropic) {
        refuse(ErrorKind::BadConfig,
               "device profile '" + p.path + "': the mass is anisotropic (one mass is identified)");
    }
    if (p.mass_range.size() != 2) {
        refuse(ErrorKind::BadConfig, "device profile '" + p.path +
                                         "' has no mass_range = [released, held] kg (the released mass is its lower "
                                         "end)");
    }
    RetuneTable t;
    t.held_mass = plant.mass;
    t.released_mass = p.mass_range[0];
    if (!(t.released_mass < t.held_mass)) {
        std::ostringstream m;
        m << "device profile '" << p.path << "': mass_range[0] = " << t.released_mass
          << " kg is not below the held mass " << t.held_mass << " kg; accepted: mass_range[0] < mass";
        refuse(ErrorKind::BadConfig, m.str());
    }
    // Row 1: the same walls tuned for the released mass and certified over the same set (resolve_walls).
    TuningPlant released_plant = plant;
    released_plant.mass = t.released_mass;
    try {
        t.released = resolve_walls(o, p, released_plant, std::nullopt);
    } catch (const StartupError& e) {
        std::ostringstream m;
        m << "the released row (the optimum for " << t.released_mass << " kg): " << e.what();
        throw StartupError(e.kind(), "--retune: " + m.str());
    }

    // The switch certificate's family, per wall (distinct gains), in the switched loop's coordinates.
    const double T = plant.period;
    const hapticopt::VelocityEstimator estimator = to_hapticopt_estimator(p.velocity_estimator, T);
    const double delay_periods = plant.time_delay / T;
    std::vector<double> masses;
    std::vector<std::pair<double, double>> arms;  // (k_H / m, b_H / m)
    const PlantSetCertificate& set = *walls.front().tuning.plant_set;
    masses = {set.mass_min, t.released_mass, 0.5 * (t.released_mass + t.held_mass), t.held_mass, set.mass_max};
    std::sort(masses.begin(), masses.end());
    masses.erase(std::unique(masses.begin(), masses.end()), masses.end());
    for (const double k : {0.0, p.arm_stiffness_per_mass}) {
        for (const double b : {0.0, p.arm_damping_per_mass}) {
            if (std::find(arms.begin(), arms.end(), std::make_pair(k, b)) == arms.end()) arms.emplace_back(k, b);
        }
    }
    std::vector<hapticopt::DynamicMatrix<double>> modes;
    std::vector<std::pair<double, double>> pairs;  // (K, B) of both rows, every wall, distinct
    for (std::size_t i = 0; i < walls.size(); ++i) {
        for (const TuningResult* r : std::array<const TuningResult*, 2>{&walls[i].tuning, &t.released[i].tuning}) {
            if (std::find(pairs.begin(), pairs.end(), std::make_pair(r->K, r->B)) == pairs.end())
                pairs.emplace_back(r->K, r->B);
        }
    }
    const double m_ref = t.held_mass;
    try {
        for (const auto& [K, B] : pairs) {
            for (const double m : masses) {
                for (const auto& [k_per_m, b_per_m] : arms) {
                    const hapticopt::NormalizedPlant np{(plant.stiffness / m + k_per_m) * T * T,
                                                        (plant.damping / m + b_per_m) * T, delay_periods};
                    modes.push_back(hapticopt::make_switching_loop(hapticopt::SampledPlant<double>(np), estimator,
                                                                   K * T * T / m_ref, B * T / m_ref, m_ref / m));
                }
            }
        }
    } catch (const std::exception& e) {
        throw StartupError(ErrorKind::InvalidParameter, std::string("--retune: the switched loop: ") + e.what());
    }
    const hapticopt::DwellCertificate c = hapticopt::minimum_dwell(modes);
    t.modes = modes.size();
    t.masses = masses.size();
    t.arms = arms.size();
    t.largest_spectral_radius = c.largest_spectral_radius;
    if (!c.certified) {
        std::ostringstream m;
        m << "--retune: no dwell time is certified for the table over the plant set (largest spectral radius "
          << c.largest_spectral_radius << " over " << modes.size()
          << " modes); accepted: gain rows whose switched loops have a certified dwell";
        throw StartupError(ErrorKind::UnstableGains, m.str());
    }
    t.dwell_ticks = c.dwell_ticks;
    t.rate = c.rate;
    t.constant = c.constant;
    t.min_gap = 2U * static_cast<std::uint64_t>(c.dwell_ticks);

    t.axis = walls.front().geometry.axis;
    OnlineMassSettings& s = t.identifier;
    s.period = T;
    s.delay_ticks = static_cast<int>(std::lround(plant.time_delay / T));
    s.released_mass = t.released_mass;
    s.mass_tolerance = std::min(0.5, p.mass_margin);
    s.position_step = p.position_resolution[t.axis];
    if (s.delay_ticks > OnlineMassIdentifier::kMaxDelayTicks) {
        refuse(ErrorKind::InvalidParameter,
               "the loop's delay of " + std::to_string(s.delay_ticks) +
                   " periods exceeds the identifier's 64 (inherent_delay, --delay-buffer)");
    }
    return t;
}

WallRetuner make_wall_retuner(const RetuneTable& t, const std::vector<ResolvedWall>& walls) {
    GainRow held, released;
    for (std::size_t i = 0; i < walls.size(); ++i) {
        // The same validation as the scene's walls (finite, >= 0).
        (void)VirtualWall(walls[i].geometry, t.released[i].tuning.K, t.released[i].tuning.B, t.identifier.period);
        held.stiffness.push_back(walls[i].tuning.K);
        held.damping.push_back(walls[i].tuning.B);
        released.stiffness.push_back(t.released[i].tuning.K);
        released.damping.push_back(t.released[i].tuning.B);
    }
    return WallRetuner(t.identifier, t.axis, t.min_gap, std::move(held), std::move(released));
}

std::string retune_text(const RetuneTable& t, const std::vector<ResolvedWall>& walls, double period) {
    std::ostringstream m;
    m << "hapticd: re-tuning (--retune): the config walls switch between row 0, held " << t.held_mass
      << " kg, and row 1, released " << t.released_mass << " kg (identified online on axis " << t.axis << ")\n";
    for (std::size_t i = 0; i < walls.size(); ++i) {
        const TuningResult& h = walls[i].tuning;
        const TuningResult& r = t.released[i].tuning;
        m << "hapticd:   wall " << i + 1 << ": row 0 K = " << h.K << " N/m, B = " << h.B << " N s/m; row 1 K = " << r.K
          << " N/m, B = " << r.B << " N s/m";
        if (r.plant_set && r.plant_set->derating < 1.0) m << " (derated to " << r.plant_set->derating << ")";
        if (r.plant_set) {
            m << "; each stable for every mass " << r.plant_set->mass_min << " .. " << r.plant_set->mass_max << " kg";
        }
        m << "\n";
    }
    m << "hapticd:   dwell N_d = " << t.dwell_ticks << " ticks (" << t.dwell_ticks * period
      << " s; average dwell time, Hespanha & Morse 1999, with the Lyapunov bound per mode: lambda = " << t.rate
      << ", M = " << t.constant << ", over " << t.modes << " modes: the gain pairs x " << t.masses << " masses x "
      << t.arms << " arm corners, largest spectral radius " << t.largest_spectral_radius
      << "); the daemon's switches at least 2 N_d = " << t.min_gap << " ticks apart\n";
    return m.str();
}

std::string retune_switches_text(const WallRetuner& r, double period) {
    std::ostringstream m;
    for (std::size_t i = 0; i < r.stored_switches(); ++i) {
        const GainSwitch& s = r.switches()[i];
        m << "hapticd: re-tuning: gains switched to row " << static_cast<int>(s.row)
          << (s.row == WallRetuner::kHeld ? " (held)" : " (released)") << " after tick " << s.tick
          << " (t = " << static_cast<double>(s.tick) * period << " s)\n";
    }
    m << "hapticd: re-tuning: " << r.switch_count() << " switches, row " << static_cast<int>(r.row())
      << " at the end\n";
    return m.str();
}

nlohmann::json retune_json(const RetuneTable& t, const std::vector<ResolvedWall>& walls, const WallRetuner* r,
                           double period) {
    nlohmann::json j;
    j["held_mass"] = t.held_mass;
    j["released_mass"] = t.released_mass;
    nlohmann::json rows = nlohmann::json::array();
    for (int row = 0; row < 2; ++row) {
        nlohmann::json w = nlohmann::json::array();
        for (std::size_t i = 0; i < walls.size(); ++i) {
            const TuningResult& g = row == 0 ? walls[i].tuning : t.released[i].tuning;
            nlohmann::json e{{"K", g.K}, {"B", g.B}};
            if (g.plant_set) e["derating"] = g.plant_set->derating;
            w.push_back(e);
        }
        rows.push_back(w);
    }
    j["rows"] = rows;
    j["dwell_ticks"] = t.dwell_ticks;
    j["dwell_method"] =
        "average dwell time (Hespanha & Morse 1999), Lyapunov bound per mode (hapticopt::minimum_dwell)";
    j["rate"] = t.rate;
    j["constant"] = t.constant;
    j["modes"] = t.modes;
    j["largest_spectral_radius"] = t.largest_spectral_radius;
    j["min_gap_ticks"] = t.min_gap;
    j["axis"] = t.axis;
    if (r != nullptr) {
        nlohmann::json sw = nlohmann::json::array();
        for (std::size_t i = 0; i < r->stored_switches(); ++i) {
            const GainSwitch& s = r->switches()[i];
            sw.push_back({{"tick", s.tick}, {"time_s", static_cast<double>(s.tick) * period}, {"row", s.row}});
        }
        j["switches"] = sw;
        j["switch_count"] = r->switch_count();
        j["row_at_end"] = r->row();
    }
    return j;
}

}  // namespace hapticd
