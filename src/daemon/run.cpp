// SPDX-License-Identifier: Apache-2.0
// hapticd's run, step by step (run.hpp). The steps live in files of their own:
//   replay          replay_main.cpp    (the options a replay overrides, its object slots, the verdict)
//   identification  identification/identification_run.hpp (run_identification_stage)
//   tuning          wall_tuning.cpp    (resolve_walls, robust_box) and the block below that calls tune_wall
//   re-tuning       retune.cpp         (--retune's table and dwell), wall_retuner.hpp (its part of the tick)
//   simulated hand  hand_scenario.cpp  (make_scenario, the hand's events)
//   device          below (make_device, open_and_home) and devices/
//   record          run_outputs.cpp    (trace, recording, summary file)
//   serve           below (start_serving) and server/serve_runtime.hpp
//   signals         common/stop_flag.hpp, daemon/fatal_signal.hpp (installed below)
//   systemd         daemon/systemd_notify.hpp (below), ready_status_text in run_messages.cpp
//   run             daemon.hpp, tick.cpp (the loop), daemon_config below
//   report          run_messages.cpp (the lines around the run, the fault's exit code), report.cpp (statistics,
//                   summary JSON)
#include "daemon/run.hpp"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <iostream>
#include <memory>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "common/startup_error.hpp"
#include "config/options.hpp"
#include "daemon/daemon.hpp"
#include "daemon/exit_codes.hpp"
#include "daemon/fatal_signal.hpp"
#include "daemon/hand_scenario.hpp"
#include "daemon/replay_main.hpp"
#include "daemon/retune.hpp"
#include "daemon/report.hpp"
#include "daemon/run_messages.hpp"
#include "daemon/run_outputs.hpp"
#include "daemon/socket_lock.hpp"
#include "daemon/systemd_notify.hpp"
#include "daemon/wall_tuning.hpp"
#include "devices/device_factory.hpp"
#include "devices/device_list.hpp"
#include "identification/identification_run.hpp"
#include "scene/safety.hpp"
#include "scene/scene.hpp"
#include "server/serve_runtime.hpp"
#include "tuning/tuning.hpp"

namespace hapticd {

namespace {

// Closes the device on every path out (close() leaves zero force).
struct DeviceCloser {
    Device* device = nullptr;
    ~DeviceCloser() {
        if (device != nullptr) device->close();
    }
};

// The force limiter's rate (scene/force_limiter.hpp): the default for the profile's max_force, or the given one
// checked.
void resolve_max_force_rate(Options& o, const DeviceProfile& profile) {
    // On the loop's period as it runs (whole ns).
    const double loop_period = static_cast<double>(std::llround(1e9 / o.rate)) * 1e-9;
    if (o.max_force_rate == 0.0) {
        o.max_force_rate = default_max_force_rate(profile.max_force, loop_period);
    } else if (const std::string e = max_force_rate_error(o.max_force_rate, profile.max_force, loop_period);
               !e.empty()) {
        throw StartupError(ErrorKind::InvalidParameter,
                           e + " (max_force from device profile '" + profile.path + "', T = 1 / --rate)");
    }
}

// The run's length in ticks (0: until stopped); a replay's is the recording's.
std::uint64_t run_ticks(const Options& o, const Recording* replay) {
    std::uint64_t max_ticks = 0;
    if (o.duration_set) {
        max_ticks = static_cast<std::uint64_t>(std::ceil(o.duration * o.rate - 1e-9));
        if (max_ticks == 0) max_ticks = 1;
    }
    if (replay != nullptr)
        max_ticks = replay->ticks.size();  // the recorded run's last tick wrote zero force, as this one's will
                                           // (after the same stop window, or at once after a fault)
    return max_ticks;
}

RunReport make_report(const Options& o, const DeviceProfile& profile, double period, double delay,
                      const std::vector<ResolvedWall>& walls) {
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
    return report;
}

// The config walls with their tuned gains (an invalid one: exit 4).
Scene make_scene(const std::vector<ResolvedWall>& walls, const DeviceProfile& profile, double period) {
    std::vector<VirtualWall> scene_walls;
    for (const auto& w : walls) {
        try {
            scene_walls.emplace_back(w.geometry, w.tuning.K, w.tuning.B, period);
        } catch (const std::invalid_argument& e) {
            throw StartupError(ErrorKind::InvalidParameter, e.what());
        }
    }
    return Scene(std::move(scene_walls), static_cast<std::size_t>(profile.axes), profile.max_force,
                 profile.velocity_estimator, period);
}

// The device opened (then `closer` closes it on every path out) and homed; exit 6 otherwise.
void open_and_home(Device& device, const DeviceProfile& profile, DeviceCloser& closer) {
    if (const DeviceStatus s = device.open(); s != DeviceStatus::Ok) {
        throw StartupError(ErrorKind::Device, "device '" + profile.name + "': open failed: " + device.last_error());
    }
    closer.device = &device;
    if (const DeviceStatus s = device.home(); s != DeviceStatus::Ok) {
        throw StartupError(ErrorKind::Device, "device '" + profile.name + "': homing failed: " + device.last_error());
    }
}

DaemonConfig daemon_config(const Options& o, const DeviceProfile& profile, std::int64_t period_ns,
                           std::uint64_t max_ticks, const Recording* replay, const std::vector<ResolvedWall>& walls) {
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
    return cfg;
}

// --passivity-control: the controller (a bad parameter: exit 4) and its line; nothing without it.
void make_passivity(std::optional<PassivityController>& passivity, const Options& o, const DeviceProfile& profile,
                    double period, std::ostream& out) {
    if (!o.passivity_control) return;
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
    if (!o.quiet) out << "hapticd: " << describe(pc) << "\n";
}

// --serve (not in a replay): the client objects, the state stream and the control socket, attached to the
// daemon, the recorder told of every batch, the server thread started. Null otherwise.
std::unique_ptr<ServeRuntime> start_serving(const Options& o, const DeviceProfile& profile, double period, double delay,
                                            const std::vector<ResolvedWall>& walls, Daemon& daemon, Recorder* recorder,
                                            const Recording* replay) {
    std::unique_ptr<ServeRuntime> serving;  // --serve: client objects, state stream, control socket
    if (o.serve && replay == nullptr) {
        std::vector<ConfigWallInfo> config_walls;
        for (const auto& w : walls) {
            config_walls.push_back({w.geometry.axis, w.geometry.position, w.geometry.direction,
                                    w.geometry.mode == WallMode::Bilateral, w.tuning.K, w.tuning.B});
        }
        serving = std::make_unique<ServeRuntime>(o, profile, period, delay, config_walls);
        daemon.attach(serving->hooks());
        if (recorder) {
            serving->hooks().objects->set_observer(recorder);
            serving->set_mesh_observer(recorder);
        }
        serving->start();
    }
    return serving;
}

}  // namespace

int run_main(int argc, const char* const* argv, const Recording* replay) {
    Options o = parse_options(argc, argv, kExitCodeHelp);
    apply_replay_overrides(o, replay);
    validate_options(o);
    if (o.list_devices) return list_devices(std::cout, o);
    const DeviceProfile profile = load_device_profile(o);
    if (replay != nullptr) check_replayable(*replay, o, profile);
    std::ostream& out = std::cout;

    const double period = 1.0 / o.rate;
    resolve_max_force_rate(o, profile);
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
    // --retune: the table of the held and released optima, each certified over the set, and the dwell.
    const std::optional<RetuneTable> retune_table =
        retune_requested(o, profile)
            ? std::optional<RetuneTable>(make_retune_table(o, profile, plant, walls, ident.has_value()))
            : std::nullopt;

    const std::int64_t period_ns = std::llround(1e9 / o.rate);
    const std::uint64_t max_ticks = run_ticks(o, replay);

    RunReport report = make_report(o, profile, period, delay, walls);

    if (!o.quiet) {
        print_startup(out, o, profile, period, delay, period_ns, walls, report, ident, configured_tuning, ident_tuning);
        if (retune_table) out << retune_text(*retune_table, walls, period);
    }

    SimScenario scenario = make_scenario(o, profile, walls, report, period, delay);

    std::ofstream summary = open_summary(o);
    const std::vector<HandEventRecord>* hand_events = nullptr;  // the simulated hand's schedule, once run
    std::optional<WallRetuner> retuner;                         // --retune: the tick's part
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
            if (retune_table) {
                j["retune"] = retune_json(*retune_table, walls, retuner && report.ran ? &*retuner : nullptr, period);
            }
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

    Scene scene = make_scene(walls, profile, period);

    install_stop_signal_handlers();
    std::unique_ptr<TraceWriter> trace = open_trace(o);
    std::unique_ptr<Recorder> recorder = open_recorder(argc, argv, o, profile);

    DeviceCloser closer;
    open_and_home(*device, profile, closer);

    DaemonConfig cfg = daemon_config(o, profile, period_ns, max_ticks, replay, walls);
    std::optional<PassivityController> passivity;
    make_passivity(passivity, o, profile, period, out);
    if (passivity) cfg.passivity = &*passivity;
    if (retune_table) {
        try {
            retuner.emplace(make_wall_retuner(*retune_table, walls));
        } catch (const std::invalid_argument& e) {
            throw StartupError(ErrorKind::InvalidParameter, std::string("--retune: ") + e.what());
        }
        cfg.retune = &*retuner;
    }
    cfg.recorder = recorder.get();
    ReplayObjects replay_objects = make_replay_objects(replay, o, profile, period, cfg);
    auto daemon = std::make_unique<Daemon>(*device, scene, trace.get(), cfg);
    if (replay_objects.objects) daemon->attach(ServerHooks{replay_objects.objects.get(), nullptr});
    // --serve: the socket's lock (daemon/socket_lock.hpp), held until the end, then client objects, state stream,
    // control socket
    const SocketLock socket_lock =
        o.serve && replay == nullptr
            ? SocketLock::acquire(o.serve_socket.empty() ? default_server_socket_path() : o.serve_socket)
            : SocketLock{};
    std::unique_ptr<ServeRuntime> serving =
        start_serving(o, profile, period, delay, walls, *daemon, recorder.get(), replay);
    // From here a fatal signal or std::terminate zeroes the device where the driver can and marks the state
    // (daemon/fatal_signal.hpp); the targets are cleared before the state and the device go away.
    install_fatal_signal_handlers(device.get(), serving ? serving->hooks().state : nullptr);
    struct FatalTargetsCleared {
        ~FatalTargetsCleared() { clear_fatal_signal_targets(); }
    } fatal_targets_cleared;

    if (!o.lockstep) apply_realtime_step(report, o, out);
    if (!o.quiet) print_running(out, o, max_ticks, scenario, profile);

    // Under systemd (Type=notify): READY=1 now that tuning, device open and homing are done; WATCHDOG=1 while
    // the loop's heartbeat advances; STOPPING=1 after the loop (daemon/systemd_notify.hpp).
    SystemdNotifier notifier;
    notifier.ready(ready_status_text(profile, walls, o), daemon->loop().heartbeat());
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
    finish_trace(trace.get(), report, o);
    finish_recording(recorder.get(), o, out);
    if (replay != nullptr) return replay_verdict(*replay, report.run, *playback, replay_objects.feeder.get());
    report.saturated_ticks = report.run.limiter.saturated_ticks;
    if (const auto* sim = dynamic_cast<const SimDevice*>(device.get()); sim != nullptr && !sim->hand_events().empty()) {
        hand_events = &sim->hand_events();
        if (!o.quiet) out << hand_events_text(*hand_events, period);
    }
    if (passivity) {
        report.passivity_control = true;
        report.passivity = passivity->stats();
    }
    warn_device_counters(*device, profile, o);
    if (retuner && !o.quiet) out << retune_switches_text(*retuner, period);

    const int code = fault_exit_code(report, o, profile);
    if (!o.quiet) {
        if (report.run.stopped_by_signal) out << "hapticd: stopped by signal " << report.run.signal << "\n";
        out << statistics_text(report);
    }
    write_summary(code);
    return code;
}

}  // namespace hapticd
