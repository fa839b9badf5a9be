// SPDX-License-Identifier: Apache-2.0
#include "daemon/hapticd_main.hpp"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <iostream>
#include <map>
#include <memory>
#include <optional>
#include <sstream>
#include <string_view>

#include <unistd.h>

#include <nlohmann/json.hpp>

#include "daemon/daemon.hpp"
#include "daemon/record_replay.hpp"
#include "devices/device_factory.hpp"
#include "devices/device_list.hpp"
#include "daemon/fatal_signal.hpp"
#include "daemon/check_device_main.hpp"
#include "daemon/experiment_main.hpp"
#include "daemon/exit_codes.hpp"
#include "identification/identification_run.hpp"
#include "config/options.hpp"
#include "loop/realtime_setup.hpp"
#include "daemon/report.hpp"
#include "daemon/systemd_notify.hpp"
#include "scene/safety.hpp"
#include "scene/scene.hpp"
#include "server/serve_runtime.hpp"
#include "daemon/recorder.hpp"
#include "daemon/recording_reader.hpp"
#include "loop/trace.hpp"
#include "tuning/object_checks.hpp"
#include "tuning/tuning.hpp"

namespace hapticd {

namespace {

struct ResolvedWall {
    WallSpec spec;
    WallGeometry geometry;
    TuningResult tuning;
};

// Closes the device on every path out (close() leaves zero force).
struct DeviceCloser {
    Device* device = nullptr;
    ~DeviceCloser() {
        if (device != nullptr) device->close();
    }
};

// Every wall stable over the profile's plant set (docs/robust-stability.md): the masses mass_range widened by
// mass_margin, with the wall's own mass (its axis's with a mass matrix) and the loop's velocity estimator. A
// criterion's optimum that is not is derated to the largest fraction of it that is (GainChecker::set_stable_factor);
// explicit gains that are not are refused (ErrorKind::UnstableGains) unless --passivity-control renders unstable
// gains on purpose.
void certify_over_plant_set(TuningResult& t, const TuningPlant& wall_plant, const DeviceProfile& p,
                            const std::string& what, bool allow_unstable) {
    GainCheckPlant cp;
    static_cast<TuningPlant&>(cp) = wall_plant;
    if (p.mass_range.size() == 2 && p.mass_model.isotropic)
        cp.mass_range = std::make_pair(p.mass_range[0], p.mass_range[1]);
    cp.mass_margin = p.mass_margin;
    const GainChecker checker(cp);
    const auto [c_min, c_max] = checker.mass_scales();
    PlantSetCertificate c;
    c.mass_min = c_min * cp.mass;
    c.mass_max = c_max * cp.mass;
    c.exact = checker.certified();
    double failing_mass = 0.0;
    if (checker.pair_is_stable(t.K, t.B, cp.mass, failing_mass)) {
        t.plant_set = c;
        return;
    }
    if (allow_unstable) return;  // --passivity-control: the controller keeps the wall bounded (no certificate)
    std::ostringstream m;
    m << what << ": K = " << t.K << " N/m, B = " << t.B << " N s/m"
      << (t.explicit_gains ? std::string() : " (the optimum of criterion " + t.criterion + ")")
      << " are unstable with the mass " << failing_mass << " kg of " << checker.set_text() << " (device profile '"
      << p.path << "': mass_range, mass_margin)";
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
    t.plant_set = c;
}

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
        const std::string criterion = spec->criterion.value_or(o.criterion);
        if (!is_accepted_criterion(criterion)) {
            throw StartupError(code, origin + " '" + text + "': criterion = " + criterion +
                                         " is invalid; accepted: " + accepted_criteria_text());
        }
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
            auto it = tuned.find(criterion + axis_key);
            if (it == tuned.end()) {
                it = tuned
                         .emplace(criterion + axis_key,
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
              << (o.gains_set ? std::string() : " (the optimum of criterion " + criterion + ")")
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
    b.velocity = p.velocity_estimator;  // tune_wall_robust refuses any but the backward difference
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

// replay: null, or the recording whose command line argv is (--replay, replay_main): then the run is that
// recording's, in lockstep on its PlaybackDevice, without server, trace, summary or recorder, and the exit code
// is the comparison's (daemon/record_replay.hpp).
// The replay's exit code (0 identical, 11 not) and its lines: the first tick whose force differs (both values,
// %.17g), or the first batch taken otherwise than recorded, or a run that ended before the recording's last tick.
int replay_verdict(const Recording& r, const RunResult& run, const PlaybackDevice& device, const ReplayFeeder* feeder) {
    const std::uint64_t taken = feeder != nullptr ? feeder->batches_taken() : 0;
    bool same = true;
    char line[512];
    if (device.mismatched_ticks() > 0) {
        const auto& m = device.first_mismatch();
        std::snprintf(
            line, sizeof line,
            "%llu of %llu ticks differ; the first is tick %llu: force[%zu] recorded %.17g N, replayed %.17g N",
            static_cast<unsigned long long>(device.mismatched_ticks()),
            static_cast<unsigned long long>(device.ticks_compared()), static_cast<unsigned long long>(m.tick), m.axis,
            m.recorded, m.replayed);
        std::cerr << "hapticd: error: replay of '" << r.path << "': " << line << "\n";
        same = false;
    }
    if (feeder != nullptr && feeder->mismatch()) {
        std::cerr << "hapticd: error: replay of '" << r.path << "': " << feeder->mismatch_text() << "\n";
        same = false;
    }
    if (device.ticks_compared() != r.ticks.size() || taken != r.batches.size()) {
        std::cerr << "hapticd: error: replay of '" << r.path << "': the replay ran " << device.ticks_compared()
                  << " ticks and took " << taken << " batches; the recording has " << r.ticks.size() << " ticks and "
                  << r.batches.size() << " batches"
                  << (run.fault != StateFault::None
                          ? " (the replay faulted at tick " + std::to_string(run.fault_tick) + ")"
                          : std::string())
                  << "\n";
        same = false;
    }
    if (!same) return kExitReplayMismatch;
    std::cout << "hapticd: replay of '" << r.path << "': " << device.ticks_compared() << " ticks, " << taken
              << " batches: every force identical to the recording (bit for bit)" << std::endl;
    return kExitOk;
}

int run_main(int argc, const char* const* argv, const Recording* replay = nullptr) {
    Options o = parse_options(argc, argv, kExitCodeHelp);
    if (replay != nullptr) {
        o.lockstep = true;
        o.quiet = true;
        o.trace.clear();
        o.summary_json.clear();
        o.record.clear();
        o.replay.clear();
        o.serve_wait_commit = false;
        o.dry_run = false;
        o.list_devices = false;
    } else if (!o.replay.empty()) {
        throw StartupError(ErrorKind::Usage,
                           "--replay takes the options from the recording: only --quiet may be given with it");
    }
    validate_options(o);
    if (o.list_devices) return list_devices(std::cout, o);
    const DeviceProfile profile = load_device_profile(o);
    if (replay != nullptr) check_replayable(*replay, o, profile);
    std::ostream& out = std::cout;

    const double period = 1.0 / o.rate;
    {
        // The force limiter's rate (scene/force_limiter.hpp), on the loop's period as it runs (whole ns).
        const double loop_period = static_cast<double>(std::llround(1e9 / o.rate)) * 1e-9;
        if (o.max_force_rate == 0.0) {
            o.max_force_rate = default_max_force_rate(profile.max_force, loop_period);
        } else if (const std::string e = max_force_rate_error(o.max_force_rate, profile.max_force, loop_period);
                   !e.empty()) {
            throw StartupError(ErrorKind::InvalidParameter,
                               e + " (max_force from device profile '" + profile.path + "', T = 1 / --rate)");
        }
    }
    const double delay = profile.inherent_delay + static_cast<double>(o.delay_buffer) / o.rate;
    const TuningPlant configured_plant{profile.mass, profile.damping, profile.stiffness,
                                       period,       delay,           profile.velocity_estimator};
    // --identify / --identification-file: tune from the identified plant (identification_run.hpp).
    const std::optional<IdentificationStage> ident = run_identification_stage(o, profile, period, std::cout, std::cerr);
    std::optional<TuningResult> configured_tuning;
    std::optional<IdentifiedTuning> ident_tuning;
    if (ident && !o.gains_set) {
        configured_tuning = tune_wall(o.criterion, configured_plant);
        ident_tuning = tune_identified(o.criterion, ident->result, period, static_cast<double>(o.delay_buffer) / o.rate,
                                       profile.velocity_estimator);
    }
    const TuningPlant plant =
        !ident ? configured_plant
        : ident_tuning
            ? ident_tuning->plant
            : TuningPlant{ident->result.mass,
                          std::max(0.0, ident->result.damping),
                          std::max(0.0, ident->result.stiffness),
                          period,
                          ident->result.delay_periods * period + static_cast<double>(o.delay_buffer) / o.rate,
                          profile.velocity_estimator};
    const std::optional<TuningBox> box =
        o.robust && !o.gains_set ? std::optional<TuningBox>(robust_box(o, profile, ident, period)) : std::nullopt;
    const std::vector<ResolvedWall> walls = resolve_walls(o, profile, plant, box);

    const std::int64_t period_ns = std::llround(1e9 / o.rate);
    std::uint64_t max_ticks = 0;
    if (o.duration_set) {
        max_ticks = static_cast<std::uint64_t>(std::ceil(o.duration * o.rate - 1e-9));
        if (max_ticks == 0) max_ticks = 1;
    }
    if (replay != nullptr)
        max_ticks = replay->ticks.size();  // the recorded run's last tick wrote zero force, as this one's will
                                           // (after the same stop window, or at once after a fault)

    RunReport report;
    report.options = &o;
    report.profile = &profile;
    report.period = period;
    report.delay = delay;
    for (const auto& w : walls) {
        WallSpec canonical = w.spec;
        canonical.mode = w.geometry.mode;
        report.walls.push_back({to_string(canonical), w.tuning});
    }

    if (!o.quiet) {
        out << "hapticd: device '" << profile.name << "' (" << profile.path << ")"
            << (o.simulate || profile.driver == "sim" ? ", simulated" : "") << ": mass ";
        if (profile.mass_model.isotropic) {
            out << profile.mass << (profile.rotary ? " kg m^2" : " kg");
        } else {
            out << profile.mass_model.describe();
        }
        out << ", damping " << profile.damping << ", stiffness " << profile.stiffness << "; rate " << o.rate
            << " Hz (T = " << period * 1e3 << " ms), delay " << delay * 1e3 << " ms = " << delay / period
            << " periods (device " << profile.inherent_delay * 1e3 << " ms + buffer " << o.delay_buffer << ")\n";
        out << "hapticd: velocity estimate " << to_string(profile.velocity_estimator)
            << ": every damper acts on it, and the tuning and every check analyse the loop with it\n";
        if (std::abs(static_cast<double>(period_ns) - 1e9 / o.rate) > 1e-6) {
            out << "hapticd: note: the scheduler period is " << period_ns << " ns (1e9/rate rounded to whole ns); "
                << "the wall and the tuning use T = 1/rate exactly\n";
        }
        if (walls.empty()) out << "hapticd: no walls in the scene: nothing to tune, zero force\n";
        if (ident) {
            out << identification_text(*ident, profile, period) << "\n";
            if (configured_tuning && ident_tuning) {
                out << "hapticd: tuned from the identified plant: K = " << ident_tuning->tuning.K << " +- "
                    << ident_tuning->K_stderr << ", B = " << ident_tuning->tuning.B << " +- " << ident_tuning->B_stderr
                    << " (from the profile: K = " << configured_tuning->K << ", B = " << configured_tuning->B << ")\n";
            }
        }
        for (const auto& r : report.walls) {
            out << "hapticd: wall " << r.spec << ": " << tuning_line(r.tuning, profile.rotary) << "\n";
            const std::string encoder = encoder_line(r.tuning, profile.rotary);
            if (!encoder.empty()) out << "hapticd: wall " << r.spec << ": " << encoder << "\n";
        }
        if (o.gains_set) {
            for (const auto& w : walls) {
                if (w.spec.criterion)
                    out << "hapticd: note: explicit gains override the wall's criterion=" << *w.spec.criterion << "\n";
            }
        }
    }

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

    std::ofstream summary;
    if (!o.summary_json.empty()) {
        summary.open(o.summary_json);
        if (!summary)
            throw StartupError(ErrorKind::Usage, "summary-json = '" + o.summary_json + "': cannot open for writing");
    }
    const std::vector<HandEventRecord>* hand_events = nullptr;  // the simulated hand's schedule, once run
    auto write_summary = [&](int code) {
        report.exit_code = code;
        if (summary.is_open()) {
            nlohmann::json j = summary_json(report);
            if (ident) {
                j["identified"] = identification_summary_json(*ident, profile, period,
                                                              configured_tuning ? &*configured_tuning : nullptr,
                                                              ident_tuning ? &*ident_tuning : nullptr);
            }
            if (hand_events != nullptr) j["hand_events"] = hand_events_json(*hand_events, period);
            summary << j.dump(2) << "\n";
            summary.close();
            if (!summary) std::cerr << "hapticd: error: writing summary-json '" << o.summary_json << "' failed\n";
        }
    };
    if (o.dry_run) {  // tuning only: no device needed
        write_summary(kExitOk);
        return kExitOk;
    }
    std::unique_ptr<Device> device =
        replay != nullptr ? std::make_unique<PlaybackDevice>(*replay, capabilities_from_profile(profile), profile.name)
                          : make_device(profile, o, scenario, period);
    auto* playback = replay != nullptr ? static_cast<PlaybackDevice*>(device.get()) : nullptr;

    std::vector<VirtualWall> scene_walls;
    for (const auto& w : walls) {
        try {
            scene_walls.emplace_back(w.geometry, w.tuning.K, w.tuning.B, period);
        } catch (const std::invalid_argument& e) {
            throw StartupError(ErrorKind::InvalidParameter, e.what());
        }
    }
    Scene scene(std::move(scene_walls), static_cast<std::size_t>(profile.axes), profile.max_force,
                profile.velocity_estimator, period);

    install_stop_signal_handlers();
    std::unique_ptr<TraceWriter> trace;
    if (!o.trace.empty()) {
        try {
            trace = std::make_unique<TraceWriter>(o.trace, static_cast<std::size_t>(o.trace_capacity), o.lockstep);
        } catch (const std::exception& e) {
            throw StartupError(ErrorKind::Usage, e.what());
        }
    }

    std::unique_ptr<Recorder> recorder;
    if (!o.record.empty()) {
        try {
            recorder = std::make_unique<Recorder>(o.record, recording_header(argc, argv, o, profile).dump(),
                                                  static_cast<std::size_t>(o.record_capacity), o.lockstep);
        } catch (const std::exception& e) {
            throw StartupError(ErrorKind::Usage, e.what());
        }
    }

    DeviceCloser closer;
    if (const DeviceStatus s = device->open(); s != DeviceStatus::Ok) {
        throw StartupError(ErrorKind::Device, "device '" + profile.name + "': open failed: " + device->last_error());
    }
    closer.device = device.get();
    if (const DeviceStatus s = device->home(); s != DeviceStatus::Ok) {
        throw StartupError(ErrorKind::Device, "device '" + profile.name + "': homing failed: " + device->last_error());
    }

    DaemonConfig cfg;
    cfg.loop.period_ns = period_ns;
    cfg.loop.lockstep = o.lockstep;
    cfg.loop.spin_ns = static_cast<std::int64_t>(std::llround(o.spin_us * 1e3));
    cfg.max_ticks = max_ticks;
    cfg.max_force = profile.max_force;
    cfg.max_force_rate = o.max_force_rate;
    cfg.end_without_stop_window = replay != nullptr && !replay->ticks.empty() && replay->ticks.back().fault != 0;
    cfg.delay_samples = static_cast<std::size_t>(o.delay_buffer);
    cfg.watchdog.max_consecutive_overruns = static_cast<std::uint32_t>(o.watchdog_overruns);
    cfg.watchdog.max_skipped_periods = static_cast<std::uint64_t>(o.watchdog_stall_periods);
    cfg.watchdog_enabled = !o.lockstep;
    cfg.trace_axis = o.trace_axis >= 0 ? static_cast<std::size_t>(o.trace_axis)
                     : walls.empty()   ? 0
                                       : walls.front().geometry.axis;
    std::optional<PassivityController> passivity;
    if (o.passivity_control) {
        PassivityControlConfig pc;
        pc.period = period;
        // Default cap beta <= 2 / (N + 1), N the delay buffer: measured in docs/passivity.md (larger caps chatter).
        pc.damping_cap = o.passivity_damping_cap > 0.0
                             ? o.passivity_damping_cap
                             : 2.0 / (static_cast<double>(o.delay_buffer) + 1.0) * profile.mass / period;
        pc.velocity_guard = o.passivity_velocity_guard;
        pc.max_force = profile.max_force;
        pc.axes = static_cast<std::size_t>(profile.axes);
        try {
            passivity.emplace(pc);
        } catch (const std::invalid_argument& e) {
            throw StartupError(ErrorKind::InvalidParameter, e.what());
        }
        cfg.passivity = &*passivity;
        if (!o.quiet) out << "hapticd: " << describe(pc) << "\n";
    }
    cfg.recorder = recorder.get();
    // --replay --serve: the loop's object slots and their rings, fed from the recording (no server).
    std::unique_ptr<CommitRing> replay_ring, replay_departures;
    std::unique_ptr<SceneObjects> replay_objects;
    std::unique_ptr<ReplayFeeder> feeder;
    if (replay != nullptr && o.serve) {
        replay_ring = std::make_unique<CommitRing>(replay_ring_capacity(*replay));
        replay_departures = std::make_unique<CommitRing>(replay_ring_capacity(*replay));
        replay_objects = std::make_unique<SceneObjects>(scene_objects_config(o, profile, period), *replay_ring,
                                                        replay_departures.get());
        feeder = std::make_unique<ReplayFeeder>(*replay, *replay_objects, *replay_ring, *replay_departures);
        replay_objects->set_observer(feeder.get());
        cfg.feeder = feeder.get();
    }
    auto daemon = std::make_unique<Daemon>(*device, scene, trace.get(), cfg);
    if (replay_objects) daemon->attach(ServerHooks{replay_objects.get(), nullptr});
    std::unique_ptr<ServeRuntime> serving;  // --serve: client objects, state stream, control socket
    if (o.serve && replay == nullptr) {
        std::vector<ConfigWallInfo> config_walls;
        for (const auto& w : walls) {
            config_walls.push_back({w.geometry.axis, w.geometry.position, w.geometry.direction,
                                    w.geometry.mode == WallMode::Bilateral, w.tuning.K, w.tuning.B});
        }
        serving = std::make_unique<ServeRuntime>(o, profile, period, delay, config_walls);
        daemon->attach(serving->hooks());
        if (recorder) serving->hooks().objects->set_observer(recorder.get());
        serving->start();
    }
    // From here a fatal signal or std::terminate zeroes the device where the driver can and marks the state
    // (daemon/fatal_signal.hpp); the targets are cleared before the state and the device go away.
    install_fatal_signal_handlers(device.get(), serving ? serving->hooks().state : nullptr);
    struct FatalTargetsCleared {
        ~FatalTargetsCleared() { clear_fatal_signal_targets(); }
    } fatal_targets_cleared;

    if (!o.lockstep) {
        report.realtime_requested = true;
        report.realtime = apply_realtime(RealtimeRequest{o.rt_priority, o.mlock, o.cpu});
        if (!o.quiet) {
            out << "hapticd: real-time: SCHED_FIFO "
                << (report.realtime.fifo ? "priority " + std::to_string(o.rt_priority) : std::string("off"))
                << ", memory " << (report.realtime.memory_locked ? "locked" : "not locked") << ", CPU "
                << (report.realtime.pinned ? std::to_string(o.cpu) : std::string("not pinned"))
                << (o.spin_us > 0.0
                        ? ", spinning the last " + std::to_string(std::llround(o.spin_us)) + " us before each tick"
                        : std::string())
                << "\n";
        }
        if (!report.realtime.failures.empty()) {
            std::cerr << "hapticd: warning: real-time setup did not take effect: " << report.realtime.failures
                      << "; running with normal scheduling (see docs/hapticd.md, 'Running without root')\n";
        }
    }
    if (!o.quiet) {
        out << "hapticd: running" << (o.lockstep ? " in lockstep" : "")
            << (max_ticks ? " for " + std::to_string(max_ticks) + " ticks" : std::string(" until SIGINT/SIGTERM"))
            << ", scenario " << to_string(scenario.kind);
        if (profile.driver == "sim" || o.simulate) {
            out << " (simulated hand: b_H " << scenario.hand.damping << " N s/m, k_H " << scenario.hand.stiffness
                << " N/m"
                << (scenario.hand.mass > 0.0 ? ", m_H +" + std::to_string(scenario.hand.mass) + " kg" : std::string())
                << (scenario.schedule.empty() ? std::string() : "; schedule " + describe(scenario.schedule)) << ")";
        }
        out << std::endl;
    }

    // Under systemd (Type=notify): READY=1 now that tuning, device open and homing are done; WATCHDOG=1 while
    // the loop's heartbeat advances; STOPPING=1 after the loop (daemon/systemd_notify.hpp).
    SystemdNotifier notifier;
    std::ostringstream ready_status;
    ready_status << "device '" << profile.name << "' open and homed, " << walls.size() << " wall(s) tuned"
                 << (walls.empty() ? std::string() : " (" + tuning_line(walls.front().tuning, profile.rotary) + ")")
                 << ", loop running at " << o.rate << " Hz";
    notifier.ready(ready_status.str(), daemon->loop().heartbeat());
    if (serving && o.serve_wait_commit) serving->wait_for_first_commit();
    report.run = daemon->run();
    if (serving) serving->stop();
    notifier.stopping("loop ended after " + std::to_string(daemon->loop().counters().ticks) + " ticks");
    report.ran = true;
    report.loop = &daemon->loop();
    if (report.run.fault == StateFault::Device) report.device_error = device->last_error();
    clear_fatal_signal_targets();
    device->close();  // zero force (the last tick already wrote zero when the device still listened)
    closer.device = nullptr;
    if (trace) {
        report.trace_error = !trace->close();
        report.trace_dropped = trace->dropped();
        report.trace_written = trace->written();
        if (report.trace_error) std::cerr << "hapticd: error: writing trace '" << o.trace << "' failed\n";
        if (report.trace_dropped > 0) {
            std::cerr << "hapticd: warning: " << report.trace_dropped << " trace records dropped (trace ring full; "
                      << "raise --trace-capacity)\n";
        }
    }
    if (recorder) {
        const bool ok = recorder->close();
        if (!ok)
            std::cerr << "hapticd: error: writing recording '" << o.record << "' failed (it is marked incomplete)\n";
        if (recorder->dropped_ticks() + recorder->dropped_batches() > 0) {
            std::cerr << "hapticd: warning: " << recorder->dropped_ticks() << " tick and "
                      << recorder->dropped_batches()
                      << " batch records dropped (recorder ring full; raise --record-capacity, or record with "
                         "--lockstep): the "
                      << "recording '" << o.record << "' is marked incomplete and cannot be replayed\n";
        }
        if (!o.quiet) {
            out << "hapticd: recorded " << recorder->ticks_written() << " ticks and " << recorder->batches_written()
                << " batches to '" << o.record << "'\n";
        }
    }
    if (replay != nullptr) return replay_verdict(*replay, report.run, *playback, feeder.get());
    report.saturated_ticks = report.run.limiter.saturated_ticks;
    if (const auto* sim = dynamic_cast<const SimDevice*>(device.get()); sim != nullptr && !sim->hand_events().empty()) {
        hand_events = &sim->hand_events();
        if (!o.quiet) out << hand_events_text(*hand_events, period);
    }
    if (passivity) {
        report.passivity_control = true;
        report.passivity = passivity->stats();
    }
    if (const DeviceCounters c = device->counters();
        c.packets_malformed + c.packets_short + c.garbage_bytes > 0 && !o.quiet) {
        std::cerr << "hapticd: warning: device '" << profile.name << "': " << c.packets_malformed << " malformed and "
                  << c.packets_short << " short packets dropped, " << c.garbage_bytes
                  << " bytes skipped while resynchronising (" << c.packets_ok << " good packets)\n";
    }

    int code = kExitOk;
    switch (report.run.fault) {
        case StateFault::None:
            break;
        case StateFault::Device:
            code = kExitDeviceError;
            std::cerr << "hapticd: error: device '" << profile.name << "' failed at tick " << report.run.fault_tick
                      << ": " << report.device_error << "; zero force, loop stopped\n";
            break;
        case StateFault::NonFinite:
            code = kExitRunFault;
            std::cerr << "hapticd: error: fault at tick " << report.run.fault_tick << ": "
                      << to_string(report.run.scene_fault) << "; zero force, loop stopped\n";
            break;
        case StateFault::Watchdog:
            code = kExitRunFault;
            std::cerr << "hapticd: error: watchdog fault at tick " << report.run.fault_tick << ": more than "
                      << o.watchdog_overruns << " consecutive overruns or a stall of more than "
                      << o.watchdog_stall_periods << " periods; zero force, loop stopped\n";
            break;
        case StateFault::FatalSignal:
        case StateFault::Terminate:
            break;  // written only into the shared memory, by daemon/fatal_signal.cpp, as the process ends
    }
    if (!o.quiet) {
        if (report.run.stopped_by_signal) out << "hapticd: stopped by signal " << report.run.signal << "\n";
        out << statistics_text(report);
    }
    write_summary(code);
    return code;
}

// hapticd --replay FILE [--quiet]: reads the recording, enters its working directory and runs its command line
// (run_main with the recording). Exit 10 for a recording that cannot be read or rebuilt.
int replay_main(int argc, const char* const* argv) {
    std::string file;
    bool quiet = false;
    for (int i = 1; i < argc; ++i) {
        const std::string_view a = argv[i];
        if (a == "--replay" && i + 1 < argc) {
            file = argv[++i];
        } else if (a.starts_with("--replay=")) {
            file = std::string(a.substr(9));
        } else if (a == "--quiet") {
            quiet = true;
        } else {
            throw StartupError(
                ErrorKind::Usage,
                "--replay takes the options from the recording: only --quiet may be given with it (got '" +
                    std::string(a) + "')");
        }
    }
    if (file.empty()) throw StartupError(ErrorKind::Usage, "--replay needs a FILE (a recording made with --record)");
    Recording r;
    try {
        r = read_recording(file);
    } catch (const RecordingError& e) {
        throw StartupError(ErrorKind::BadRecording, e.what());
    }
    const nlohmann::json& args = r.header.contains("argv") ? r.header["argv"] : nlohmann::json();
    if (!args.is_array() ||
        !std::all_of(args.begin(), args.end(), [](const nlohmann::json& a) { return a.is_string(); })) {
        throw StartupError(ErrorKind::BadRecording,
                           "recording '" + file + "': corrupt header: 'argv' is not an array of strings");
    }
    const std::string cwd = r.header.value("cwd", std::string());
    if (!cwd.empty() && ::chdir(cwd.c_str()) != 0) {
        throw StartupError(ErrorKind::BadRecording,
                           "recording '" + file + "': cannot enter its working directory '" + cwd +
                               "' (the relative paths of its command line are relative to it)");
    }
    std::vector<std::string> strings{"hapticd"};
    for (const auto& a : args) strings.push_back(a.get<std::string>());
    std::vector<const char*> pointers;
    for (const auto& a : strings) pointers.push_back(a.c_str());
    if (!quiet) {
        std::cout << "hapticd: replaying '" << file << "': " << r.ticks.size() << " ticks, " << r.batches.size()
                  << " batches, recorded with:";
        for (std::size_t i = 1; i < strings.size(); ++i) {
            const bool quote = strings[i].empty() || strings[i].find_first_of(" \t'\"") != std::string::npos;
            std::cout << " " << (quote ? "'" + strings[i] + "'" : strings[i]);
        }
        std::cout << std::endl;
    }
    return run_main(static_cast<int>(pointers.size()), pointers.data(), &r);
}

}  // namespace

int hapticd_main(int argc, const char* const* argv) noexcept {
    // `hapticd experiment boundary|optimal ...`: the Sect. V experiments (docs/experiments.md).
    if (argc > 1 && std::string_view(argv[1]) == "experiment") return experiment_main(argc - 1, argv + 1);
    // `hapticd check-device`: the measured force sign, before the first real run (docs/devices.md).
    if (argc > 1 && std::string_view(argv[1]) == "check-device") return check_device_main(argc - 1, argv + 1);
    clear_stop_request();
    try {
        for (int i = 1; i < argc; ++i) {
            const std::string_view a = argv[i];
            if (a == "--replay" || a.starts_with("--replay=")) return replay_main(argc, argv);
        }
        return run_main(argc, argv);
    } catch (const StartupError& e) {
        if (e.what()[0] != '\0') std::cerr << "hapticd: error: " << e.what() << "\n";
        return exit_code(e.kind());
    } catch (const std::exception& e) {
        std::cerr << "hapticd: internal error: " << e.what() << "\n";
        return kExitInternal;
    } catch (...) {
        std::cerr << "hapticd: internal error (unknown exception)\n";
        return kExitInternal;
    }
}

}  // namespace hapticd
