// SPDX-License-Identifier: Apache-2.0
// hapticd's options: the command line over the config file over the defaults, and their range checks
// (options.hpp); the device profile in device_profile.cpp.
#include "config/options.hpp"

#include <filesystem>
#include <iostream>

#include <CLI/CLI.hpp>

#include "common/criterion_names.hpp"
#include "config/apply_config_file.hpp"
#include "config/config_locations.hpp"
#include "config/hand_schedule.hpp"
#include "config/option_ranges.hpp"
#include "hapticd/instance.hpp"
#include "tuning/tuning.hpp"

namespace hapticd {

namespace fs = std::filesystem;

namespace {

constexpr const char* kVersion = "hapticd 0.1.0";

const std::vector<std::string> kScenarios{"auto", "rest", "step", "push", "hold", "path"};

struct Handles {
    CLI::Option* duration = nullptr;
    CLI::Option* stiffness = nullptr;
    CLI::Option* damping = nullptr;
    CLI::Option* wall = nullptr;
    CLI::Option* serve_shm = nullptr;
};

// Which of the options that need it were given (the CLI::App owning the handles is gone by then).
struct Given {
    bool duration = false;
    bool stiffness = false;
    bool damping = false;
    bool wall = false;
    bool serve_shm = false;
    static Given of(const Handles& h) {
        return {h.duration->count() > 0, h.stiffness->count() > 0, h.damping->count() > 0, h.wall->count() > 0,
                h.serve_shm->count() > 0};
    }
};

// --criterion (and the config file's criterion key): the name parsed into hapticopt::Criterion here, where it enters,
// and stored in Options::criterion; a name that is not a criterion is "--criterion: <name> not in {amax,OV,...}"
// (CLI11's wording for a set of choices). Help shows "TEXT:{amax,OV,...}": the config file reads the key as a string
// (takes_of in config/apply_config_file.cpp), and the names it accepts.
void add_criterion_option(CLI::App& app, Options& o) {
    std::string choices;
    for (const std::string& name : accepted_criteria()) choices += (choices.empty() ? "{" : ",") + name;
    choices += "}";
    app.add_option_function<std::string>(
           "--criterion",
           [&o, choices](const std::string& name) {
               const std::optional<hapticopt::Criterion> c = hapticopt::parse_criterion(name);
               if (!c) throw CLI::ValidationError("--criterion", name + " not in " + choices);
               o.criterion = *c;
           },
           "Tuning criterion of the wall (default CE2)")
        ->type_name("TEXT:" + choices);
}

// The options that may appear both on the command line and in the config file (key = long name).
void define_common(CLI::App& app, Options& o, Handles& h) {
    add_criterion_option(app, o);
    app.add_option(
        "--device", o.device,
        "Device profile: a name in <config dir>/devices/<name>.toml, or a path to a .toml file (default sim)");
    app.add_option("--rate", o.rate, "Loop rate in Hz (default 1000)");
    app.add_option("--delay-buffer", o.delay_buffer,
                   "Extra delay of the wall force in samples, N >= 0 (total delay = device delay + N/rate)");
    h.duration = app.add_option("--duration", o.duration, "Run time in s (default: until SIGINT/SIGTERM)");
    app.add_option("--trace", o.trace, "Write a per-tick CSV trace to FILE");
    app.add_option("--summary-json", o.summary_json, "Write the tuning and loop statistics as JSON to FILE at exit");
    app.add_flag("--lockstep", o.lockstep, "No sleeping: run ticks back to back (simulated device, tests)");
    app.add_option("--scenario", o.scenario,
                   "Simulated hand's intent: rest, step, push, hold, path (default auto: rest with --serve, else step)")
        ->check(CLI::IsMember(kScenarios));
    app.add_option("--hand-mass", o.hand_mass,
                   "Simulated hand: mass added to the profile's (which includes the arm), kg (default 0)");
    app.add_option("--hand-damping", o.hand_damping,
                   "Simulated hand: damping b_H, N s/m (default -1: 13.3 s^-1 times the profile's mass; 0: no hand)");
    app.add_option("--hand-stiffness", o.hand_stiffness,
                   "Simulated hand: stiffness k_H around its rest position, N/m (default -1: 667 s^-2 times the "
                   "profile's mass; 0: no hand)");
    app.add_option("--hand-schedule", o.hand_schedule,
                   "Simulated hand: 'release@T,grip@T,arm@T:k=K:b=B', T in s from the start: the hand lets go "
                   "(its mass, k_H, b_H and force leave), grips again, or changes k_H, b_H (docs/simulated-hand.md)");
    app.add_option("--hand-release-mass", o.hand_release_mass,
                   "Simulated hand: the part of the profile's mass that leaves the handle at a release, kg "
                   "(default -1: the profile's mass minus the lightest of its mass_range)");
    app.add_option("--path-amplitude", o.path_amplitude,
                   "path intent: amplitude of the hand's rest position, m (default 0.01)");
    app.add_option("--path-frequency", o.path_frequency, "path intent: frequency, Hz (default 0.5)");
    app.add_flag("--bilateral", o.bilateral, "Walls without a mode render bilaterally (as analysed in the paper)");
    app.add_flag("--simulate", o.simulate, "Simulate the profile's physics even if its driver is a real device");
    h.stiffness = app.add_option("--stiffness", o.stiffness, "Explicit wall stiffness K in N/m (needs --damping)");
    h.damping = app.add_option("--damping", o.damping, "Explicit wall damping B in N s/m (needs --stiffness)");
    h.wall = app.add_option("--wall", o.walls,
                            "Wall 'axis=0 position=0.0 direction=+1 [mode=unilateral|bilateral] [criterion=..]' "
                            "(repeatable; replaces the configured walls)");
    app.add_flag("--no-walls", o.no_walls,
                 "Start with no walls: a scene that only clients fill (--serve); in the config file: wall = []");
    app.add_option("--rt-priority", o.rt_priority, "SCHED_FIFO priority 1..99, 0: do not ask (default 80)");
    app.add_option(
        "--spin-us", o.spin_us,
        "Sleep until this long before each tick's deadline, then busy-wait for it: the tick starts on time "
        "whatever the kernel's wake-up latency, for this much CPU per period (default 0: sleep until the deadline)");
    app.add_option("--cpu", o.cpu, "Pin the loop thread to this CPU (default -1: no pinning)");
    app.add_option("--mlock", o.mlock, "Lock memory with mlockall (default true)");
    app.add_option("--watchdog-overruns", o.watchdog_overruns,
                   "Fault after more than this many consecutive overruns (default 50)");
    app.add_option("--watchdog-stall-periods", o.watchdog_stall_periods,
                   "Fault when one late tick skips more than this many periods (default 100)");
    app.add_option("--trace-capacity", o.trace_capacity, "Trace ring capacity in records (default 65536)");
    app.add_option(
        "--record", o.record,
        "Record every tick's state and every client batch the loop applies to FILE, for --replay and the scope "
        "(docs/recording.md)");
    app.add_option("--record-capacity", o.record_capacity, "Recorder's tick ring capacity in records (default 65536)");
    app.add_option("--step-force", o.step_force, "step scenario: external force step, N (default 1)");
    app.add_option("--push-speed", o.push_speed, "push scenario: approach speed, m/s (default 0.1)");
    app.add_option("--push-distance", o.push_distance,
                   "push scenario: start distance from the wall, m (default 0.002)");
    app.add_option("--push-force", o.push_force, "push scenario: external force while pushing, N (default 0)");
    app.add_option("--hold-force", o.hold_force, "hold scenario: constant human force, N (default 2)");
    app.add_option("--hold-distance", o.hold_distance,
                   "hold scenario: start distance from the wall, m (default 0.001)");
    app.add_flag("--quiet", o.quiet, "Print only warnings and errors");
    app.add_flag("--identify", o.identify,
                 "Identify mass, damping, stiffness and delay by a short excitation before rendering; tune from them");
    app.add_option("--identification-file", o.identification_file,
                   "Identification results (JSON): written after --identify, reused without it");
    app.add_option("--identify-force", o.identify_force, "Excitation force limit in N (default 0: 25 % of max_force)");
    app.add_option("--identify-distance", o.identify_distance,
                   "Excitation position limit in m from the start (default 0: 5 mm, 0.05 rad rotary)");
    app.add_option("--identify-duration", o.identify_duration, "Excitation time in s (default 2)");
    app.add_flag(
        "--passivity-control", o.passivity_control,
        "Time-domain passivity control (Hannaford-Ryu observer + variable damper) on the force after the delay "
        "buffer; explicit gains outside the stability region are then accepted (docs/passivity.md)");
    app.add_option(
        "--passivity-damping-cap", o.passivity_damping_cap,
        "Largest damping the passivity controller adds, N s/m (default 0: 2 m / ((N + 1) T), N the delay buffer)");
    app.add_option("--passivity-velocity-guard", o.passivity_velocity_guard,
                   "Speed below which the passivity controller adds no damping, m/s (default 1e-4)");
    app.add_option("--velocity-estimator", o.velocity_estimator,
                   "Velocity estimate the dampers act on, overriding the profile's velocity_estimator: backward, "
                   "lowpass:<F>Hz or window:<N> (docs/velocity-estimation.md); the tuning and every check use it");
    app.add_option("--force-noise-budget", o.force_noise_budget,
                   "Encoder-step force noise the auto-tuned walls keep below, N, overriding the profile's "
                   "force_noise_budget (0: none)");
    app.add_flag("--robust", o.robust,
                 "Tune CE0/CE1/CE2 for the worst case over the profile's mass_range, damping_range, stiffness_range "
                 "and inherent_delay_range (with --identify: the identified values +- 3 standard errors)");
    app.add_flag("--retune", o.retune,
                 "Re-tune the config walls online: identify grip and release from the position and the force, switch "
                 "between the criterion's optimum for the held mass and for the released one (the lower end of the "
                 "profile's mass_range), both certified over the plant set, switches at least twice the certified "
                 "dwell apart (docs/robust-stability.md, \"Online re-tuning\"); config walls only, not with --serve");
    app.add_flag("--serve", o.serve, "Serve client applications on a control socket (docs/protocol.md)");
    app.add_option("--instance", o.instance,
                   "Instance name, one per device on the machine: socket hapticd-NAME.sock, state /hapticd-NAME-state, "
                   "config NAME.toml (default: none, hapticd.sock, /hapticd-state, hapticd.toml; docs/hapticd.md)");
    app.add_option("--serve-socket", o.serve_socket,
                   "Control socket path (default $RUNTIME_DIRECTORY/hapticd.sock, $XDG_RUNTIME_DIR/hapticd.sock or "
                   "/run/hapticd/hapticd.sock; hapticd-NAME.sock with --instance NAME)");
    app.add_option("--serve-stream-socket", o.serve_stream_socket,
                   "Stream control socket (SOCK_STREAM, one JSON message per line; what an ssh -L Unix-socket "
                   "forward reaches), same mode, group and sessions (default: the control socket's path + "
                   "\".stream\"; none: no stream socket)");
    app.add_option("--serve-mode", o.serve_mode, "Octal file mode of the control socket (default 0660)");
    app.add_option("--serve-group", o.serve_group, "Group of the control socket and the state (default: the daemon's)");
    h.serve_shm = app.add_option(
        "--serve-shm", o.serve_shm,
        "POSIX shared-memory name of the state stream (default /hapticd-state; /hapticd-NAME-state with --instance)");
    app.add_option("--ramp-time", o.ramp_time, "Ramp in/out time of client objects in s (default 0.03; 0: none)");
    app.add_option("--max-force-rate", o.max_force_rate,
                   "Limit on the change of the total force in N/s (default 10000)");
    app.add_option("--move-interval-max", o.move_interval_max,
                   "Client moves are interpolated over their measured update interval, at most this long, s "
                   "(default 0.05; 0: applied at once; docs/protocol.md, section 4)");
    app.add_option(
        "--activation-speed", o.activation_speed,
        "A unilateral plane added with the handle behind its surface starts at the handle and moves out at this "
        "speed, m/s (default 0.01; 0: at once; docs/protocol.md, section 4)");
    app.add_option(
        "--session-max-objects", o.session_max_objects,
        "Objects one client session may hold, 1 .. 64 (default 32; the scene holds 64; docs/protocol.md, section 7)");
    app.add_option("--session-max-in-flight", o.session_max_in_flight,
                   "Batches of one client session handed to the loop and not yet applied, 1 .. 64 (default 8; "
                   "docs/protocol.md, section 7)");
    app.add_option("--mesh-upload-timeout", o.mesh_upload_timeout,
                   "A mesh upload with no chunk for this long is dropped, s, 0.1 .. 600 (default 10; "
                   "docs/protocol.md, section 4a)");
    app.add_flag("--serve-wait-commit", o.serve_wait_commit,
                 "Start the loop only once a client batch was accepted (tests)");
    app.add_option("--trace-axis", o.trace_axis, "Axis the trace records (default -1: the first wall's)");
    app.add_option("--falcon-firmware", o.falcon_firmware,
                   "Novint Falcon firmware image to upload at start (user-supplied; overrides the profile's firmware)");
}

// The config file's keys are the options of define_common (its types and checks included).
Given load_config_file(const std::string& path, Options& o) {
    Handles h;
    CLI::App file_app{"hapticd config file"};
    file_app.set_help_flag();
    define_common(file_app, o, h);
    o.config_locations = apply_config_file(file_app, "config file '" + path + "'", path, false);
    return Given::of(h);
}

}  // namespace

Options parse_options(int argc, const char* const* argv, const std::string& help_footer) {
    // Pass 1: the command line alone (usage errors, --help, where the config file is).
    std::string config_arg;
    bool config_given = false;
    std::string instance_arg;  // --instance on the command line
    {
        Options scratch;
        Handles h;
        CLI::App app{
            "hapticd: a virtual wall at a fixed rate, with K and B tuned optimally for the device's mass, "
            "period and delay (Hulin et al., IROS 2011)",
            "hapticd"};
        app.footer(config_search_help() + " Keys are the long option names.\n" + help_footer);
        app.set_version_flag("--version", kVersion);
        define_common(app, scratch, h);
        auto* cfg = app.add_option("--config", config_arg, "Config file (TOML; default: the search below)");
        app.add_flag("--dry-run", scratch.dry_run, "Tune, print and exit without running the loop");
        app.add_flag("--list-devices", scratch.list_devices, "List the USB/HID devices hapticd can drive and exit");
        app.add_option(
            "--replay", scratch.replay,
            "Re-render a recording (--record) with the options it was made with, in lockstep, and compare the "
            "forces bit for bit (alone, or with --quiet; exit 11 on a difference, 10 on a bad recording)");
        try {
            app.parse(argc, argv);
        } catch (const CLI::CallForHelp&) {
            std::cout << app.help();
            throw StartupError(ErrorKind::Ok, "");
        } catch (const CLI::CallForAllHelp&) {
            std::cout << app.help("", CLI::AppFormatMode::All);
            throw StartupError(ErrorKind::Ok, "");
        } catch (const CLI::CallForVersion&) {
            std::cout << kVersion << "\n";
            throw StartupError(ErrorKind::Ok, "");
        } catch (const CLI::ParseError& e) {
            throw StartupError(ErrorKind::Usage, std::string(e.what()) + " (see hapticd --help)");
        }
        config_given = cfg->count() > 0;
        instance_arg = scratch.instance;
    }
    // The instance names files: checked before it chooses one.
    if (!instance_arg.empty() && !valid_instance_name(instance_arg)) {
        invalid(KeyLocations{}, "instance", instance_arg, kInstanceNameForm);
    }

    Options o;
    Given from_file;
    Given from_cli;
    bool from_environment = false;
    const std::string config_path = config_given ? config_arg : default_config_file(from_environment, instance_arg);
    if (!config_path.empty()) {  // "": --config "" or nothing found, built-in defaults only
        if (!fs::is_regular_file(config_path)) {
            throw StartupError(ErrorKind::BadConfig, "config file '" + config_path + "'" +
                                                         (from_environment ? " (from $HAPTICD_CONFIG)" : "") +
                                                         " does not exist or is not a file");
        }
        from_file = load_config_file(config_path, o);
        o.config_path = config_path;
    }

    // Pass 2: the command line over the config file's values.
    {
        CLI::App app{"hapticd", "hapticd"};
        app.set_version_flag("--version", kVersion);
        Handles cli_h;
        define_common(app, o, cli_h);
        std::string ignored;
        app.add_option("--config", ignored);
        app.add_flag("--dry-run", o.dry_run);
        app.add_flag("--list-devices", o.list_devices);
        app.add_option("--replay", o.replay);
        try {
            app.parse(argc, argv);
        } catch (const CLI::ParseError& e) {
            throw StartupError(ErrorKind::Usage, std::string(e.what()) + " (see hapticd --help)");
        }
        from_cli = Given::of(cli_h);
        std::vector<std::string> overridden;  // a range error of these names the command line, not the file
        for (const auto& entry : o.config_locations.positions()) {
            const CLI::Option* option = app.get_option_no_throw("--" + entry.first);
            if (option != nullptr && option->count() > 0) overridden.push_back(entry.first);
        }
        for (const auto& key : overridden) o.config_locations.forget(key);
    }
    o.duration_set = from_file.duration || from_cli.duration;
    const bool k_set = from_file.stiffness || from_cli.stiffness;
    const bool b_set = from_file.damping || from_cli.damping;
    if (k_set != b_set) {
        throw StartupError(ErrorKind::Usage, std::string("explicit gains need both --stiffness and --damping; only ") +
                                                 (k_set ? "--stiffness" : "--damping") + " was given");
    }
    o.gains_set = k_set;
    o.walls_from_command_line = from_cli.wall;
    if (o.no_walls && !from_cli.wall) o.walls.clear();  // --wall on the command line wins over wall = [] in a file
    // An instance's names, unless --serve-socket / --serve-shm name others (a bad name from the file:
    // validate_options).
    if (!o.instance.empty() && valid_instance_name(o.instance)) {
        if (o.serve_socket.empty()) o.serve_socket = instance_socket_path(o.instance);
        if (!from_file.serve_shm && !from_cli.serve_shm) o.serve_shm = instance_state_shm(o.instance);
    }
    return o;
}

void validate_options(const Options& o) {
    const KeyLocations& w = o.config_locations;
    check_range(w, "rate", o.rate, 1.0, 100000.0, false, "1 .. 100000 Hz");
    if (o.delay_buffer < 0 || o.delay_buffer > 100000) {
        invalid(w, "delay-buffer", std::to_string(o.delay_buffer), "0 .. 100000 samples");
    }
    if (o.duration_set) {
        check_range(w, "duration", o.duration, 0.0, 1e7, true, "> 0 s and <= 1e7 s (omit it to run until stopped)");
    }
    if (o.gains_set) {
        check_range(w, "stiffness", o.stiffness, 0.0, 1e12, false, "finite, >= 0 N/m");
        check_range(w, "damping", o.damping, 0.0, 1e12, false, "finite, >= 0 N s/m");
    }
    if (o.rt_priority < 0 || o.rt_priority > 99) invalid(w, "rt-priority", std::to_string(o.rt_priority), "0 .. 99");
    if (o.cpu < -1 || o.cpu >= 1024) invalid(w, "cpu", std::to_string(o.cpu), "-1 (no pinning) .. 1023");
    check_range(w, "spin-us", o.spin_us, 0.0, 1e6, false, "0 .. 1e6 us, and less than one period");
    if (o.spin_us * o.rate >= 1e6) {
        invalid(w, "spin-us", shortest_text(o.spin_us),
                "0 .. less than one period (" + shortest_text(1e6 / o.rate) + " us at rate " + shortest_text(o.rate) +
                    " Hz)");
    }
    if (o.watchdog_overruns < 0 || o.watchdog_overruns > 1000000000) {
        invalid(w, "watchdog-overruns", std::to_string(o.watchdog_overruns), "0 .. 1e9");
    }
    if (o.watchdog_stall_periods < 0 || o.watchdog_stall_periods > 1000000000) {
        invalid(w, "watchdog-stall-periods", std::to_string(o.watchdog_stall_periods), "0 .. 1e9");
    }
    if (o.trace_capacity < 2 || o.trace_capacity > (1LL << 24)) {
        invalid(w, "trace-capacity", std::to_string(o.trace_capacity), "2 .. 16777216 records");
    }
    if (o.record_capacity < 2 || o.record_capacity > (1LL << 24)) {
        invalid(w, "record-capacity", std::to_string(o.record_capacity), "2 .. 16777216 records");
    }
    check_range(w, "step-force", o.step_force, -1e6, 1e6, false, "finite, |F| <= 1e6 N");
    check_range(w, "push-speed", o.push_speed, 0.0, 1e3, false, "0 .. 1000 m/s");
    check_range(w, "push-distance", o.push_distance, 0.0, 1e3, false, "0 .. 1000 m");
    check_range(w, "push-force", o.push_force, -1e6, 1e6, false, "finite, |F| <= 1e6 N");
    check_range(w, "hold-force", o.hold_force, -1e6, 1e6, false, "finite, |F| <= 1e6 N");
    check_range(w, "hold-distance", o.hold_distance, 0.0, 1e3, false, "0 .. 1000 m");
    check_range(w, "hand-mass", o.hand_mass, 0.0, 1e3, false, "0 .. 1000 kg");
    if (o.hand_damping != -1.0)
        check_range(w, "hand-damping", o.hand_damping, 0.0, 1e6, false, "0 .. 1e6 N s/m, or -1 (default)");
    if (o.hand_stiffness != -1.0)
        check_range(w, "hand-stiffness", o.hand_stiffness, 0.0, 1e9, false, "0 .. 1e9 N/m, or -1 (default)");
    if (o.hand_release_mass != -1.0)
        check_range(w, "hand-release-mass", o.hand_release_mass, 0.0, 1e3, false, "0 .. 1000 kg, or -1 (default)");
    try {
        (void)parse_hand_schedule(o.hand_schedule);
    } catch (const std::invalid_argument& e) {
        throw StartupError(ErrorKind::InvalidParameter, w.prefix("hand-schedule") + e.what());
    }
    check_range(w, "path-amplitude", o.path_amplitude, 0.0, 1e3, false, "0 .. 1000 m");
    check_range(w, "path-frequency", o.path_frequency, 0.0, 1e3, false, "0 .. 1000 Hz");
    check_range(w, "passivity-damping-cap", o.passivity_damping_cap, 0.0, 1e9, false, "0 (auto) .. 1e9 N s/m");
    check_range(w, "passivity-velocity-guard", o.passivity_velocity_guard, 0.0, 1e3, true, "> 0 and <= 1000 m/s");
    check_range(w, "identify-force", o.identify_force, 0.0, 1e6, false, "0 (auto) .. 1e6 N");
    check_range(w, "identify-distance", o.identify_distance, 0.0, 1e3, false, "0 (auto) .. 1000 m");
    check_range(w, "identify-duration", o.identify_duration, 0.1, 600.0, false, "0.1 .. 600 s");
    check_range(w, "ramp-time", o.ramp_time, 0.0, 10.0, false, "0 .. 10 s");
    check_range(w, "max-force-rate", o.max_force_rate, 0.0, 1e9, false,
                "0 (the default: max_force per 4 ms) or > 0 N/s with a step per tick below the device's max_force");
    check_range(w, "move-interval-max", o.move_interval_max, 0.0, 10.0, false, "0 .. 10 s");
    check_range(w, "activation-speed", o.activation_speed, 0.0, 1e3, false, "0 .. 1000 m/s");
    if (o.serve_mode.empty() || o.serve_mode.size() > 4 ||
        o.serve_mode.find_first_not_of("01234567") != std::string::npos) {
        invalid(w, "serve-mode", o.serve_mode, "an octal file mode 0 .. 0777, e.g. 0660");
    }
    if (!o.instance.empty() && !valid_instance_name(o.instance)) invalid(w, "instance", o.instance, kInstanceNameForm);
    if (!o.serve_stream_socket.empty() && o.serve_stream_socket == o.serve_socket) {
        invalid(w, "serve-stream-socket", o.serve_stream_socket,
                "a path other than --serve-socket's (default: that path + \".stream\"), or none");
    }
    if (o.serve_shm.size() < 2 || o.serve_shm[0] != '/' || o.serve_shm.find('/', 1) != std::string::npos) {
        invalid(w, "serve-shm", o.serve_shm, "'/' followed by a name without '/', e.g. /hapticd-state");
    }
    if (o.session_max_objects < 1 || o.session_max_objects > 64) {
        invalid(w, "session-max-objects", std::to_string(o.session_max_objects), "1 .. 64 objects");
    }
    if (o.session_max_in_flight < 1 || o.session_max_in_flight > 64) {
        invalid(w, "session-max-in-flight", std::to_string(o.session_max_in_flight), "1 .. 64 batches");
    }
    if (!(o.mesh_upload_timeout >= 0.1 && o.mesh_upload_timeout <= 600.0)) {
        invalid(w, "mesh-upload-timeout", std::to_string(o.mesh_upload_timeout), "0.1 .. 600 s");
    }
    if (o.trace_axis < -1 || o.trace_axis > 2)
        invalid(w, "trace-axis", std::to_string(o.trace_axis), "-1 (the first wall's), 0, 1, 2");
}

}  // namespace hapticd
