// SPDX-License-Identifier: Apache-2.0
// hapticd's options: command line (CLI11) over the config file (TOML read with toml++, applied to the same
// CLI11 options: config/apply_config_file.hpp) over built-in defaults; and the device profile (a TOML file
// of its own).
#pragma once

#include <cstdint>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include <hapticopt/criterion.hpp>

#include "common/axis_vector.hpp"
#include "common/startup_error.hpp"
#include "common/velocity_estimator_spec.hpp"
#include "config/key_locations.hpp"
#include "config/profile_keys.hpp"

namespace hapticd {

struct Options {
    hapticopt::Criterion criterion = hapticopt::Criterion::CE2;  // --criterion, parsed by its option
    std::string config_path;                                     // the config file actually used ("" when none)
    std::string device = "sim";
    double rate = 1000.0;        // Hz
    long long delay_buffer = 0;  // samples
    bool duration_set = false;
    double duration = 0.0;     // s; unset: run until stopped
    std::string trace;         // CSV path ("" : no trace)
    std::string summary_json;  // JSON path ("" : none)
    bool lockstep = false;
    std::string scenario = "auto";  // the simulated hand's intent; auto: rest with --serve, else step
    double hand_mass = 0.0;         // kg added to the profile's mass (which includes the arm's, Table II)
    double hand_damping = -1.0;     // b_H, N s/m; < 0: kHandDampingPerMass times the profile's mass
    double hand_stiffness = -1.0;   // k_H, N/m; < 0: kHandStiffnessPerMass times the profile's mass
    double path_amplitude = 0.01;   // m
    double path_frequency = 0.5;    // Hz
    // The simulated hand's grips, releases and arm changes (config/hand_schedule.hpp; "": none), and the kg of the
    // profile's mass that leaves the handle at a release (< 0: the profile's mass minus the lightest of mass_range).
    std::string hand_schedule;
    double hand_release_mass = -1.0;
    bool bilateral = false;
    bool simulate = false;  // simulate the profile's physics even when its driver is a real device
    bool gains_set = false;
    double stiffness = 0.0;  // explicit K, N/m
    double damping = 0.0;    // explicit B, N s/m
    std::vector<std::string> walls{"axis=0 position=0.0 direction=+1"};
    bool walls_from_command_line = false;
    bool no_walls = false;  // start with no config walls (--no-walls, or wall = [] in the file)
    bool dry_run = false;   // tune, print and exit without running the loop
    int rt_priority = 80;
    double spin_us = 0.0;  // busy-wait this long before each deadline (0: sleep until it)
    int cpu = -1;
    bool mlock = true;
    long long watchdog_overruns = 50;
    long long watchdog_stall_periods = 100;
    long long trace_capacity = 65536;
    std::string record;                 // --record FILE: every tick and client batch (docs/recording.md; "" : none)
    long long record_capacity = 65536;  // the recorder's tick ring, records
    std::string replay;                 // --replay FILE (handled by replay_main before the options are parsed)
    double step_force = 1.0;
    double push_speed = 0.1;
    double push_distance = 0.002;
    double push_force = 0.0;
    double hold_force = 2.0;
    double hold_distance = 0.001;
    bool quiet = false;
    std::string falcon_firmware;  // Novint Falcon firmware image (overrides the profile's `firmware`)
    bool list_devices = false;    // list the USB/HID devices hapticd can drive and exit
    bool identify = false;        // identify mass, damping, stiffness and delay at start-up (identification_run.hpp)
    std::string identification_file;  // JSON: written after --identify, reused without it ("" : none)
    double identify_force = 0.0;      // excitation force limit, N (0: 25 % of the profile's max_force)
    double identify_distance = 0.0;   // excitation position limit, m (0: 5 mm, 0.05 rad for rotary devices)
    double identify_duration = 2.0;   // s of excitation (plus 0.3 s of zero force)
    std::string
        velocity_estimator;  // --velocity-estimator: overrides the profile's velocity_estimator ("": the profile's)
    std::optional<double> force_noise_budget;  // --force-noise-budget: overrides the profile's (0: none)
    bool robust = false;  // tune for the worst case over the profile's parameter ranges (tuning.hpp)
    // Re-tune the config walls online between the optimum for the held and the released mass (daemon/retune.hpp;
    // also the profile's `retune = true`).
    bool retune = false;
    bool passivity_control =
        false;  // Hannaford-Ryu observer + variable damper after the delay (scene/passivity_controller.hpp)
    double passivity_damping_cap = 0.0;      // N s/m; 0: 2 m / ((N + 1) T), N the delay buffer (beta <= 2 / (N + 1))
    double passivity_velocity_guard = 1e-4;  // m/s: no damper below this speed
    // The control socket for client applications (docs/protocol.md, server/server.hpp).
    bool serve = false;
    // --instance NAME: this daemon's socket hapticd-NAME.sock, state /hapticd-NAME-state and config NAME.toml
    // (include/hapticd/instance.hpp); "": the default instance (hapticd.sock, /hapticd-state, hapticd.toml).
    std::string instance;
    // "" : $RUNTIME_DIRECTORY or $XDG_RUNTIME_DIR /hapticd.sock, else /run/hapticd/ (hapticd-NAME.sock for an instance)
    std::string serve_socket;
    std::string serve_mode = "0660";           // octal file mode of the socket
    std::string serve_group;                   // group of the socket and the state ("" : the daemon's group)
    std::string serve_stream_socket;           // "" : serve_socket + ".stream"; "none": no stream socket
    std::string serve_shm = "/hapticd-state";  // POSIX shared-memory name of the state stream (/hapticd-NAME-state)
    double ramp_time = 0.03;                   // s, ramp in/out of client objects
    // N/s, limit on the change of the force written per tick (scene/force_limiter.hpp); 0: derived from the device
    // profile (default_max_force_rate), resolved by hapticd's main once the profile is read.
    double max_force_rate = 0.0;
    double move_interval_max = 0.05;    // s, longest first-order hold of a client's move (0: at once)
    double activation_speed = 0.01;     // m/s, a plane appearing around the handle moves out at this speed (0: at once)
    int session_max_objects = 32;       // --serve: objects one session may hold (of the scene's 64)
    double mesh_upload_timeout = 10.0;  // --serve: s without a chunk after which a mesh upload is dropped
    int session_max_in_flight = 8;      // --serve: one session's batches handed to the loop, not yet applied
    bool serve_wait_commit = false;     // start the loop only once a client batch was accepted (tests)
    long long trace_axis = -1;          // axis the trace records (-1: the first wall's)
    KeyLocations config_locations;      // where the config file wrote the values the command line did not override
};

// The simulated hand's default impedance per kg of the profile's mass: the limits of Hulin et al. 2008 that
// eq. 2 of the paper extends by about 50 % (k/m < 1000 s^-2, b/m < 20 s^-1), i.e. 2/3 of eq. 2's bounds
// (docs/simulated-hand.md).
inline constexpr double kHandStiffnessPerMass = 1000.0 * 2.0 / 3.0;  // s^-2
inline constexpr double kHandDampingPerMass = 20.0 * 2.0 / 3.0;      // s^-1

struct DeviceProfile {
    std::string path;
    std::string name;
    std::string driver = "sim";
    std::string description;
    // kg (kg m^2), device + expected arm: the one mass of every axis, or (anisotropic mass_model) the mass
    // along axis 0, 1 / (M^-1)_00 — what the features that model one mass use (they refuse an anisotropic one).
    double mass = 0.0;
    DeviceMass mass_model;                // M from `mass` (one value or one per axis) or `mass_matrix`
    std::optional<double> max_stiffness;  // N/m (N m/rad), `max_stiffness`; none: only the stability region limits K
    double damping = 0.0;                 // N s/m
    double stiffness = 0.0;               // N/m
    double inherent_delay = 0.0;          // s
    double max_force = 0.0;               // N (N m)
    long long axes = 1;
    std::vector<double> workspace_min;
    std::vector<double> workspace_max;
    bool rotary = false;
    double position_noise = 0.0;
    // The encoder step q of each axis, m (rad): `position_resolution`, one value for every axis or one per axis;
    // 0: none. The simulated device rounds its position to it; the tuning predicts the force noise it causes.
    AxisVector position_resolution{};
    // The Coulomb (dry) friction f_c of each axis, N (N m): `coulomb_friction`, one value for every axis or one per
    // axis; 0: none. The simulated device renders it (devices/sim_device.hpp); the tuning predicts with it whether
    // the wall comes to rest between encoder counts (tuning/tuning.hpp, EncoderChatter).
    AxisVector coulomb_friction{};
    // How the loop estimates the velocity its dampers act on (`velocity_estimator`: backward, lowpass:<F>Hz,
    // window:<N>); the tuning checks every wall and client scene with the same estimator.
    VelocityEstimatorSpec velocity_estimator{};
    // `force_noise_budget`, N (N m): the auto-tuned walls minimise their energy criterion subject to the force noise
    // the encoder step causes, sigma_F <= this (TuningPlant::force_noise_budget); needs position_resolution > 0 on
    // the wall's axis. None: no budget.
    std::optional<double> force_noise_budget;
    long long noise_seed = 1;
    long long fail_at_tick = -1;
    RealDeviceKeys real;  // keys of the falcon / hid drivers (config/profile_keys.hpp)
    // Uncertainty of the plant for --robust: [min, max] each, empty = the nominal value is exact.
    std::vector<double> mass_range;
    std::vector<double> damping_range;
    std::vector<double> stiffness_range;
    std::vector<double> inherent_delay_range;
    // Every scene is certified stable for the moving masses mass_range (or the mass alone) widened by this relative
    // margin: [min / (1 + margin), max (1 + margin)] (`mass_margin`, 0 .. 1; docs/robust-stability.md).
    double mass_margin = 0.1;
    // The arm in the set (docs/robust-stability.md, "The arm"): k_H / m in [0, arm_stiffness_per_mass] (s^-2) and
    // b_H / m in [0, arm_damping_per_mass] (s^-1) with every mass; 0 and 0: the device alone.
    double arm_stiffness_per_mass = 0.0;
    double arm_damping_per_mass = 0.0;
    // `retune = true`: re-tune the config walls online as --retune does (docs/robust-stability.md, "Online
    // re-tuning"); default false.
    bool retune = false;
};

// Parses argv (and the config file it selects); --help ends with `help_footer` (the daemon's exit codes). Throws
// StartupError (Usage, BadConfig, InvalidParameter). When --help or --version was requested, prints it to stdout and
// throws StartupError(ErrorKind::Ok, "").
Options parse_options(int argc, const char* const* argv, const std::string& help_footer = "");

// Loads and validates the device profile named by options.device. Throws StartupError (3, 4).
DeviceProfile load_device_profile(const Options& options);

// Range checks of the options (code 4, message naming parameter, value and accepted range).
void validate_options(const Options& options);

// Where a device profile given by name is looked for, first match wins: devices/ next to the config file in use,
// then devices/ in each of config_search_dirs() (config/config_locations.hpp).
[[nodiscard]] std::vector<std::string> device_profile_dirs(const Options& options);
[[nodiscard]] std::string resolve_device_profile_path(const Options& options);

}  // namespace hapticd
