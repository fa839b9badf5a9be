// SPDX-License-Identifier: Apache-2.0
// The simulated-hand step (hand_scenario.hpp).
#include "daemon/hand_scenario.hpp"

#include <algorithm>
#include <iostream>
#include <sstream>

#include "common/startup_error.hpp"
#include "config/hand_schedule.hpp"
#include "devices/device_factory.hpp"
#include "tuning/object_checks.hpp"

namespace hapticd {

SimScenario make_scenario(const Options& o, const DeviceProfile& profile, const std::vector<ResolvedWall>& walls,
                          const RunReport& report, double period, double delay) {
    SimScenario scenario;
    scenario.kind = scenario_kind(o);
    if (!walls.empty()) {
        scenario.axis = walls.front().geometry.axis;
        scenario.surface = walls.front().geometry.position;
        scenario.direction = walls.front().geometry.direction;
    }
    scenario.step_force = o.step_force;
    scenario.push_speed = o.push_speed;
    scenario.push_distance = o.push_distance;
    scenario.push_force = o.push_force;
    scenario.hold_force = o.hold_force;
    scenario.hold_distance = o.hold_distance;
    scenario.path_amplitude = o.path_amplitude;
    scenario.path_frequency = o.path_frequency;
    scenario.hand = simulated_hand(o, profile);
    scenario.schedule = parse_hand_schedule(o.hand_schedule);  // checked by validate_options
    const bool releases = std::any_of(scenario.schedule.begin(), scenario.schedule.end(),
                                      [](const HandEvent& e) { return e.kind == HandEventKind::Release; });
    if (!scenario.schedule.empty() && profile.driver != "sim" && !o.simulate) {
        std::cerr << "hapticd: warning: hand-schedule acts on the simulated hand only: ignored on device '"
                  << profile.name << "' (driver " << profile.driver << "; --simulate simulates it)\n";
    }
    if (releases && o.hand_release_mass < 0.0 && profile.mass_range.empty() &&
        (profile.driver == "sim" || o.simulate)) {
        throw StartupError(ErrorKind::InvalidParameter,
                           "hand-schedule = '" + o.hand_schedule + "' releases the hand, but device profile '" +
                               profile.path +
                               "' has no mass_range to take the hand's mass from; accepted: --hand-release-mass M "
                               "(kg of the profile's mass that leaves the handle, 0 .. the profile's mass)");
    }
    if (releases && profile.mass_model.isotropic && !(scenario.hand.release_mass < profile.mass)) {
        std::ostringstream what;
        what << "hand-release-mass = " << scenario.hand.release_mass << " kg (with hand-mass " << scenario.hand.mass
             << " kg) leaves no moving mass at the release of hand-schedule = '" << o.hand_schedule
             << "'; accepted range: 0 .. below the profile's mass " << profile.mass << " kg";
        throw StartupError(ErrorKind::InvalidParameter, what.str());
    }
    if ((profile.driver == "sim" || o.simulate) && profile.mass_model.isotropic) {
        warn_unstable_with_hand(report, profile, scenario, period, delay);
    }
    for (std::size_t a = 0; a < kMaxAxes && a < profile.workspace_min.size() && a < profile.workspace_max.size(); ++a) {
        scenario.centre[a] = 0.5 * (profile.workspace_min[a] + profile.workspace_max[a]);
    }
    return scenario;
}

// The walls were tuned and checked for the profile's plant (the device with the arm's mass); the simulated
// hand adds b_H, k_H (and m_H). Usually that keeps them stable (docs/simulated-hand.md), not always: say so. The
// same for each plant the hand's schedule reaches (released: the mass without the hand's, no k_H, b_H).
void warn_unstable_with_hand(const RunReport& report, const DeviceProfile& profile, const SimScenario& scenario,
                             double period, double delay) {
    const SimHand& hand = scenario.hand;
    auto unstable_walls = [&](double mass, double b_H, double k_H, const std::string& with) {
        if (mass == profile.mass && b_H == 0.0 && k_H == 0.0) return;  // the profile's own plant: checked
        GainCheckPlant plant;
        plant.mass = mass;
        plant.damping = profile.damping + b_H;
        plant.stiffness = profile.stiffness + k_H;
        plant.period = period;
        plant.time_delay = delay;
        plant.velocity = profile.velocity_estimator;
        const GainChecker checker(plant);
        for (const auto& r : report.walls) {
            if (!checker.pair_is_stable(r.tuning.K, r.tuning.B, plant.mass)) {
                std::cerr << "hapticd: warning: wall " << r.spec << " (K = " << r.tuning.K << ", B = " << r.tuning.B
                          << ") is not stable " << with
                          << ": the checks are made for the profile's plant (docs/simulated-hand.md)\n";
            }
        }
    };
    std::ostringstream held;
    held << "with the simulated hand (m_H +" << hand.mass << " kg, b_H " << hand.damping << " N s/m, k_H "
         << hand.stiffness << " N/m); give the hand more damping";
    unstable_walls(profile.mass + hand.mass, hand.damping, hand.stiffness, held.str());
    double b_H = hand.damping, k_H = hand.stiffness;
    bool on = true;
    for (const HandEvent& e : scenario.schedule) {
        if (e.kind == HandEventKind::Release) on = false;
        if (e.kind == HandEventKind::Grip) on = true;
        if (e.stiffness) k_H = *e.stiffness;
        if (e.damping) b_H = *e.damping;
        if (e.kind == HandEventKind::Arm && !on) continue;  // takes effect at the next grip, checked there
        std::ostringstream with;
        const double mass = on ? profile.mass + hand.mass : profile.mass - hand.release_mass;
        with << "after the simulated hand's " << to_string(e.kind) << " at " << e.time << " s (moving mass " << mass
             << " kg, b_H " << (on ? b_H : 0.0) << " N s/m, k_H " << (on ? k_H : 0.0) << " N/m)";
        unstable_walls(mass, on ? b_H : 0.0, on ? k_H : 0.0, with.str());
    }
}

// The hand's events as they happened (SimDevice::hand_events): one line each.
std::string hand_events_text(const std::vector<HandEventRecord>& events, double period) {
    std::ostringstream out;
    for (const HandEventRecord& r : events) {
        out << "hapticd: simulated hand: " << to_string(r.event.kind) << "@" << r.event.time;
        if (r.tick < 0) {
            out << ": not reached\n";
            continue;
        }
        out << " at tick " << r.tick << " (t = " << static_cast<double>(r.tick) * period << " s): moving mass "
            << r.mass << " kg, k_H " << r.stiffness << " N/m, b_H " << r.damping
            << " N s/m; handle at x = " << r.position << " m, v = " << r.velocity << " m/s\n";
    }
    return out.str();
}

nlohmann::json hand_events_json(const std::vector<HandEventRecord>& events, double period) {
    nlohmann::json list = nlohmann::json::array();
    for (const HandEventRecord& r : events) {
        nlohmann::json j{{"event", std::string(to_string(r.event.kind))}, {"time", r.event.time}};
        if (r.tick >= 0) {
            j["tick"] = r.tick;
            j["applied_time"] = static_cast<double>(r.tick) * period;
            j["mass"] = r.mass;
            j["hand_stiffness"] = r.stiffness;
            j["hand_damping"] = r.damping;
            j["position"] = r.position;
            j["velocity"] = r.velocity;
        } else {
            j["tick"] = nullptr;
        }
        list.push_back(j);
    }
    return list;
}

}  // namespace hapticd
