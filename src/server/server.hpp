// SPDX-License-Identifier: Apache-2.0
// hapticd's control server (docs/protocol.md): a Unix-domain SOCK_SEQPACKET socket served by one thread
// of its own. It decodes requests (server/message_decoder.hpp), checks every object against the exact
// stability region (tuning/object_checks.hpp) and hands whole batches to the loop through the lock-free
// SPSC ring of scene/scene_objects.hpp. It never blocks the loop and is never blocked by a client: all
// socket I/O is non-blocking; a client whose replies do not fit is disconnected.
//
// Slots: the server owns the assignment of the loop's 64 object slots. A removed object's slot is reused
// only after the loop has published (state shared memory) that the batch removing it was applied and the
// slot is empty, so a ramp-out is never cut short.
#pragma once

#include <sys/socket.h>

#include <atomic>
#include <cstdint>
#include <memory>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include "common/axis_vector.hpp"
#include "scene/scene_objects.hpp"
#include "server/contact_events.hpp"

namespace hapticd {

class GainChecker;
class StatePublisher;

// A config-file wall, as the server lists it and counts it in the summed gains.
struct ConfigWallInfo {
    std::size_t axis = 0;
    double position = 0.0;
    double direction = 1.0;
    bool bilateral = false;
    double K = 0.0, B = 0.0;
};

struct ServerConfig {
    std::string socket_path;  // empty: default_server_socket_path()
    unsigned socket_mode = 0660;
    int socket_gid = -1;  // -1: the process's group
    // The stream socket (SOCK_STREAM, '\n'-framed; what an OpenSSH Unix-socket forward reaches): "" is
    // stream_socket_path_for(socket_path), "none" is no stream socket. Same mode, group and sessions.
    std::string stream_socket_path;
    std::string device_name = "sim";
    std::size_t axes = 1;
    double period = 1e-3;         // s
    double mass = 0.3;            // kg, every axis
    double delay = 0.0;           // s, device + buffer
    double max_force = 10.0;      // N
    double ramp_time = 0.03;      // s
    double max_force_rate = 1e4;  // N/s
    AxisVector workspace_min{-1e9, -1e9, -1e9};
    AxisVector workspace_max{1e9, 1e9, 1e9};
    std::vector<ConfigWallInfo> config_walls;
    bool log_connections = true;            // SO_PEERCRED lines on stderr
    std::size_t session_max_objects = 32;   // objects one session may hold (used, not ramping out)
    std::size_t session_max_in_flight = 8;  // one session's batches pushed to the loop and not yet applied
    double mesh_upload_timeout = 10.0;      // s: a mesh upload without a chunk for this long is dropped
};

[[nodiscard]] std::string default_server_socket_path();

// The socket path holds something that is not a stale hapticd socket (a file, a live socket): left alone.
class SocketPathError : public std::runtime_error {
  public:
    using std::runtime_error::runtime_error;
};

// Removes what is at `path` only when it is a stale hapticd socket: a Unix socket nobody listens on (connect
// gives ECONNREFUSED); nothing there is fine. Anything else (a regular file, a directory, a socket of another
// type or one that accepts) is left alone: SocketPathError naming the path. `type`: the socket type probed
// with (SOCK_SEQPACKET for the control socket, SOCK_STREAM for the stream socket).
void remove_stale_socket(const std::string& path, int type = SOCK_SEQPACKET);

// The stream socket beside a control socket (docs/protocol.md section 1): the same path + ".stream".
[[nodiscard]] std::string stream_socket_path_for(const std::string& socket_path);

struct ServerCounters {
    std::uint64_t sessions_opened = 0;
    std::uint64_t sessions_closed = 0;
    std::uint64_t commits_pushed = 0;
    std::uint64_t commits_refused = 0;
    std::uint64_t states_dropped = 0;
    std::uint64_t contacts_lost = 0;           // contact records the loop's ring could not take
    std::uint64_t contacts_dropped = 0;        // contact messages not queued for a session (its queue was full)
    std::uint64_t scene_checks_restarted = 0;  // commits' scene checks cancelled by a departure and run again
};

// Every engagement pattern of the config walls alone (a unilateral wall acts only beyond its position;
// tuning/engagement_patterns.hpp): the scene the loop renders with no client object, and the one a departure
// that cuts every client object jumps to. Empty when every pattern is stable, else why not (for the start-up
// error).
std::string config_walls_unstable(const GainChecker& checker, const std::vector<ConfigWallInfo>& walls);

class Server {
  public:
    // Creates and binds the socket (mode, group), throws std::runtime_error naming the path on failure.
    // checker, the rings (producer side) and state must outlive the server. `departures`: the ring the
    // departure batches of clients that left go through, which the loop takes ahead of every other batch
    // (SceneObjects, take_departures); without it they go through `ring` and queue behind earlier batches.
    // `contacts`: the consumer side of the loop's contact events (server/contact_events.hpp), sent to the
    // sessions that subscribe_contacts; without it those sessions get none.
    Server(const ServerConfig& config, GainChecker& checker, CommitRing& ring, const StatePublisher& state,
           CommitRing* departures = nullptr, ContactRing* contacts = nullptr);
    ~Server();  // stop() + remove the socket file
    Server(const Server&) = delete;
    Server& operator=(const Server&) = delete;

    void start();  // spawns the server thread
    // Told (on the server thread) of each mesh hierarchy before the first batch that renders it is pushed
    // (--record); set before start().
    void set_mesh_observer(MeshObserver* observer) noexcept;
    void stop();  // ends it (sessions closed) and joins

    [[nodiscard]] const std::string& socket_path() const noexcept;
    // The stream socket's path; empty when there is none.
    [[nodiscard]] const std::string& stream_socket_path() const noexcept;
    // Batches handed to the loop so far (any thread).
    [[nodiscard]] std::uint64_t commits_pushed() const noexcept {
        return commits_pushed_.load(std::memory_order_acquire);
    }
    [[nodiscard]] ServerCounters counters() const;

  private:
    struct Impl;
    std::unique_ptr<Impl> impl_;
    std::atomic<std::uint64_t> commits_pushed_{0};
    std::thread thread_;
};

}  // namespace hapticd
