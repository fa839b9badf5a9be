// SPDX-License-Identifier: Apache-2.0
#include "server/serve_runtime.hpp"

#include <grp.h>

#include <algorithm>
#include <chrono>
#include <cstdlib>
#include <stdexcept>
#include <thread>

#include "common/startup_error.hpp"
#include "common/stop_flag.hpp"

namespace hapticd {

namespace {

constexpr std::size_t kCommitRingCapacity = 64;

int group_id(const std::string& name) {
    if (name.empty()) return -1;
    const group* g = ::getgrnam(name.c_str());
    if (g == nullptr) {
        throw StartupError(ErrorKind::InvalidParameter,
                           "serve-group = " + name + " is invalid; accepted: an existing group name");
    }
    return static_cast<int>(g->gr_gid);
}

}  // namespace

SceneObjectsConfig scene_objects_config(const Options& o, const DeviceProfile& profile, double period) {
    SceneObjectsConfig oc;
    oc.period = period;
    oc.ramp_time = o.ramp_time;
    oc.axes = static_cast<std::size_t>(profile.axes);
    oc.move_interval_max = o.move_interval_max;
    oc.activation_speed = o.activation_speed;
    oc.velocity = profile.velocity_estimator;
    return oc;
}

ServeRuntime::ServeRuntime(const Options& o, const DeviceProfile& profile, double period, double delay,
                           const std::vector<ConfigWallInfo>& config_walls) {
    const int gid = group_id(o.serve_group);
    const unsigned mode = static_cast<unsigned>(std::strtoul(o.serve_mode.c_str(), nullptr, 8));
    if (mode > 0777U)
        throw StartupError(ErrorKind::InvalidParameter,
                           "serve-mode = " + o.serve_mode + " is invalid; accepted: 0 .. 0777");
    const std::size_t axes = static_cast<std::size_t>(profile.axes);

    ring_ = std::make_unique<CommitRing>(kCommitRingCapacity);
    // One departure per slot at most is in flight (a slot is reused only once its departure was applied).
    departure_ring_ = std::make_unique<CommitRing>(kSceneObjectCapacity);
    objects_ = std::make_unique<SceneObjects>(scene_objects_config(o, profile, period), *ring_, departure_ring_.get());
    // The socket path first: a second daemon started on a live one's names stops here, before it replaces
    // the live one's state segment.
    try {
        const std::string socket = o.serve_socket.empty() ? default_server_socket_path() : o.serve_socket;
        remove_stale_socket(socket);
        if (o.serve_stream_socket != "none") {
            remove_stale_socket(o.serve_stream_socket.empty() ? stream_socket_path_for(socket) : o.serve_stream_socket,
                                SOCK_STREAM);
        }
    } catch (const SocketPathError& e) {
        throw StartupError(ErrorKind::SocketPathInUse, e.what());
    }
    try {
        state_ = std::make_unique<StatePublisher>(o.serve_shm, axes, period, gid);
    } catch (const std::exception& e) {
        throw StartupError(ErrorKind::Server, e.what());
    }
    contact_ring_ = std::make_unique<ContactRing>(kContactRingCapacity);
    contacts_ = std::make_unique<ContactDetector>(*contact_ring_);
    GainCheckPlant plant;
    plant.mass = profile.mass;
    plant.damping = profile.damping;
    plant.stiffness = profile.stiffness;
    plant.period = period;
    plant.time_delay = delay;
    plant.velocity = profile.velocity_estimator;  // the loop's (scene_objects_config)
    plant.mass_matrix = profile.mass_model;       // one mass, per axis or a matrix (config/profile_keys.hpp)
    plant.max_stiffness = profile.max_stiffness;  // none: no limit
    if (profile.mass_range.size() == 2) plant.mass_range = std::make_pair(profile.mass_range[0], profile.mass_range[1]);
    plant.mass_margin = profile.mass_margin;  // every verdict holds over the set (docs/robust-stability.md)
    plant.arm_stiffness_per_mass = profile.arm_stiffness_per_mass;
    plant.arm_damping_per_mass = profile.arm_damping_per_mass;
    // Criterion gains keep the profile's force-noise budget, judged with the coarsest axis's encoder step: the step
    // along any object's direction, sqrt(sum n_a^2 q_a^2), is at most that (GainChecker::criterion_gains).
    if (profile.force_noise_budget) {
        plant.force_noise_budget = profile.force_noise_budget;
        for (std::size_t a = 0; a < axes && a < profile.position_resolution.size(); ++a)
            plant.position_resolution = std::max(plant.position_resolution, profile.position_resolution[a]);
    }
    // The set's total delays: inherent_delay_range plus the delay buffer (delay - inherent_delay), holding delay.
    if (profile.inherent_delay_range.size() == 2) {
        const double buffer = delay - profile.inherent_delay;
        plant.delay_range = std::make_pair(std::min(profile.inherent_delay_range[0] + buffer, delay),
                                           std::max(profile.inherent_delay_range[1] + buffer, delay));
    }
    try {
        checker_ = std::make_unique<GainChecker>(plant);
    } catch (const std::invalid_argument& e) {
        throw StartupError(ErrorKind::InvalidParameter, e.what());
    }

    if (const std::string why = config_walls_unstable(*checker_, config_walls); !why.empty()) {
        throw StartupError(ErrorKind::InvalidParameter,
                           "the config walls are not stable in every combination the handle can engage "
                           "(docs/protocol.md, section 5): " +
                               why);
    }

    ServerConfig sc;
    sc.socket_path = o.serve_socket;
    sc.stream_socket_path = o.serve_stream_socket;
    sc.socket_mode = mode;
    sc.socket_gid = gid;
    sc.device_name = profile.name;
    sc.axes = axes;
    sc.period = period;
    sc.mass = profile.mass;
    sc.delay = delay;
    sc.max_force = profile.max_force;
    sc.ramp_time = o.ramp_time;
    sc.max_force_rate = o.max_force_rate;
    for (std::size_t a = 0; a < axes && a < kMaxAxes; ++a) {
        if (a < profile.workspace_min.size()) sc.workspace_min[a] = profile.workspace_min[a];
        if (a < profile.workspace_max.size()) sc.workspace_max[a] = profile.workspace_max[a];
    }
    sc.config_walls = config_walls;
    sc.session_max_objects = static_cast<std::size_t>(o.session_max_objects);
    sc.session_max_in_flight = static_cast<std::size_t>(o.session_max_in_flight);
    sc.mesh_upload_timeout = o.mesh_upload_timeout;
    sc.log_connections = !o.quiet;
    try {
        server_ = std::make_unique<Server>(sc, *checker_, *ring_, *state_, departure_ring_.get(), contact_ring_.get());
    } catch (const SocketPathError& e) {
        throw StartupError(ErrorKind::SocketPathInUse, e.what());
    } catch (const std::exception& e) {
        throw StartupError(ErrorKind::Server, e.what());
    }
}

ServeRuntime::~ServeRuntime() { stop(); }

void ServeRuntime::start() { server_->start(); }

void ServeRuntime::wait_for_first_commit() const {
    while (server_->commits_pushed() == 0 && !stop_requested()) {
        state_->beat();  // alive before the loop's first tick
        std::this_thread::sleep_for(std::chrono::milliseconds(1));
    }
}

void ServeRuntime::stop() {
    if (server_) server_->stop();
}

}  // namespace hapticd
