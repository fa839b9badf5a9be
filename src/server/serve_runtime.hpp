// SPDX-License-Identifier: Apache-2.0
// What `hapticd --serve` adds to a run, built from the options and the profile before the loop starts:
// the hand-over ring, the loop's object slots, the shared-memory state, the gain checker and the server
// thread. hapticd_main attaches hooks() to the daemon, start()s the server, runs the loop, then stop()s.
#pragma once

#include <memory>
#include <vector>

#include "config/options.hpp"
#include "scene/scene_objects.hpp"
#include "server/contact_events.hpp"
#include "server/server.hpp"
#include "server/server_hooks.hpp"
#include "server/state_publisher.hpp"
#include "tuning/object_checks.hpp"

namespace hapticd {

// The loop's object slots' configuration for these options and this profile (also what --replay rebuilds).
[[nodiscard]] SceneObjectsConfig scene_objects_config(const Options& options, const DeviceProfile& profile,
                                                      double period);

class ServeRuntime {
  public:
    // Throws StartupError: ErrorKind::InvalidParameter for a bad --serve-group / --serve-mode, ErrorKind::Server
    // when the socket or the shared memory cannot be created, ErrorKind::SocketPathInUse when the socket path holds
    // anything but a stale hapticd socket (server.hpp, remove_stale_socket).
    ServeRuntime(const Options& options, const DeviceProfile& profile, double period, double delay,
                 const std::vector<ConfigWallInfo>& config_walls);
    ~ServeRuntime();

    [[nodiscard]] ServerHooks hooks() noexcept { return ServerHooks{objects_.get(), state_.get(), contacts_.get()}; }
    void start();
    void set_mesh_observer(MeshObserver* observer) noexcept { server_->set_mesh_observer(observer); }
    // --serve-wait-commit: returns once a client batch was handed to the loop, or on SIGINT/SIGTERM.
    void wait_for_first_commit() const;
    void stop();
    [[nodiscard]] const Server& server() const noexcept { return *server_; }

  private:
    std::unique_ptr<CommitRing> ring_;
    std::unique_ptr<CommitRing> departure_ring_;  // clients that left: taken by the loop ahead of ring_
    std::unique_ptr<SceneObjects> objects_;
    std::unique_ptr<StatePublisher> state_;
    std::unique_ptr<ContactRing> contact_ring_;  // loop -> server: contact begins and ends
    std::unique_ptr<ContactDetector> contacts_;
    std::unique_ptr<GainChecker> checker_;
    std::unique_ptr<Server> server_;
};

}  // namespace hapticd
