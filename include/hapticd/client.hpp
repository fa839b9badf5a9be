// SPDX-License-Identifier: Apache-2.0
// The C++ client library of hapticd (protocol version 1, docs/protocol.md): connect and handshake, keep a
// lease, commit batches of typed scene objects (all-or-nothing, applied at one tick boundary), read the
// state from shared memory without a system call, or subscribe to it over the socket.
//
//     hapticd::client::Client c = hapticd::client::Client::connect({.client_name = "demo", .lease_s = 0.5});
//     hapticd::client::Batch batch;
//     batch.add(hapticd::client::Plane{.normal = {0, 0, 1}, .offset = 0.0, .gains =
//     hapticd::client::Gains::by_criterion("CE2")}); const auto result = c.commit(batch);           // throws
//     hapticd::client::Error (code(), message naming K, B, ...) hapticd::client::StateReader state =
//     hapticd::client::StateReader::open(c.welcome().state_shm); hapticd::client::StateSample s; state.read(s); //
//     latest tick, no system call
//
// CMake: find_package(hapticd) and target_link_libraries(app PRIVATE hapticd::client). Not thread-safe:
// one Client per thread (a StateReader may be used from any one thread).
#pragma once

#include <array>
#include <cstdint>
#include <deque>
#include <optional>
#include <stdexcept>
#include <string>
#include <utility>
#include <variant>
#include <vector>

#include "hapticd/state_layout.hpp"

namespace hapticd::client {

inline constexpr int kProtocolVersion = 1;
inline constexpr std::size_t kMaxMessageBytes = 65536;

using Vec3 = std::array<double, 3>;

// The error codes of docs/protocol.md, section 8, plus Transport (the socket failed) and Unknown.
enum class ErrorCode {
    ProtocolVersion,
    BadHello,
    Oversized,
    BadJson,
    BadMessage,
    UnstableGains,
    UnstableSum,
    BeyondDeviceLimits,
    UnknownCriterion,
    UnknownObject,
    NotOwner,
    Capacity,
    Busy,
    LeaseLost,
    SlowConsumer,
    SessionLimit,  // this session's object or in-flight limit (docs/protocol.md, section 7)
    Internal,      // the server failed while handling the request; the session goes on
    Transport,
    Unknown,
};
[[nodiscard]] const char* to_string(ErrorCode code) noexcept;
[[nodiscard]] ErrorCode error_code_from_string(const std::string& code) noexcept;

// An error reply or refusal of the server, or a transport failure. what() is the server's message
// (naming the field and the accepted range), prefixed with the client function's name.
class Error : public std::runtime_error {
  public:
    Error(ErrorCode code, const std::string& message, int op_index = -1,
          std::optional<double> largest_stable_K = std::nullopt,
          std::optional<std::pair<double, double>> damping_needed = std::nullopt)
        : std::runtime_error(message),
          code_(code),
          op_index_(op_index),
          largest_stable_K_(largest_stable_K),
          damping_needed_(damping_needed) {}
    [[nodiscard]] ErrorCode code() const noexcept { return code_; }
    // The failing operation of a commit (-1: the summed-gain check or not a commit).
    [[nodiscard]] int op_index() const noexcept { return op_index_; }
    // unstable_gains: the largest stable stiffness at the object's damping, N/m.
    [[nodiscard]] std::optional<double> largest_stable_K() const noexcept { return largest_stable_K_; }
    // unstable_gains: the open interval (B_min, B_max) of damping, N s/m, that makes the object's K stable
    // (the reply's damping_needed); none when no B does.
    [[nodiscard]] std::optional<std::pair<double, double>> damping_needed() const noexcept { return damping_needed_; }

  private:
    ErrorCode code_;
    int op_index_;
    std::optional<double> largest_stable_K_;
    std::optional<std::pair<double, double>> damping_needed_;
};

// Gains of an object: explicit (K in N/m, B in N s/m; checked) or by criterion (the daemon's optimum).
struct Gains {
    std::optional<double> K;
    std::optional<double> B;
    std::string criterion;  // hapticopt's: "amax", "OV", "CE0" .. "CE2+OV"; empty with K, B
    static Gains explicit_gains(double stiffness, double damping) { return Gains{stiffness, damping, {}}; }
    static Gains by_criterion(std::string name) { return Gains{std::nullopt, std::nullopt, std::move(name)}; }
};

// Plane wall: penetration p = offset - n.x; f = n (K p + B dp/dt), unilateral: only while p > 0.
struct Plane {
    Vec3 normal{1.0, 0.0, 0.0};  // unit
    double offset = 0.0;         // m
    bool bilateral = false;
    Gains gains = Gains::by_criterion("CE2");
};

enum class Constraint { Point, Line, Plane };

// Spring to a point, a line (through `point` along `direction`) or a plane (through `point`, normal
// `direction`); `point` may be moved every tick by modify().
struct Spring {
    Constraint constraint = Constraint::Point;
    Vec3 point{};
    Vec3 direction{1.0, 0.0, 0.0};  // unit; unused for Point
    Gains gains = Gains::explicit_gains(100.0, 0.0);
};

// Force field F0 + J (x - x0) - B v inside the radius, zero outside. The stiffness -sym(J) and the
// damping B (isotropic, on the device's velocity) are checked together like a wall's (K, B).
struct Field {
    Vec3 center{};
    double radius = 0.01;            // m
    Vec3 force{};                    // F0, N
    std::array<Vec3, 3> jacobian{};  // J, N/m, rows
    double damping = 0.0;            // B, N s/m
};

// A triangle mesh this session uploaded (Client::upload_mesh; docs/protocol.md, section 4a), rendered through a
// god-object proxy with the wall law (K, B) along its contact normals at the pose (position, orientation).
struct Mesh {
    std::uint32_t mesh = 0;                                 // the id upload_mesh returned
    Vec3 position{};                                        // m: where the mesh's origin is, device frame
    std::array<double, 4> orientation{1.0, 0.0, 0.0, 0.0};  // unit quaternion w, x, y, z: mesh frame -> device frame
    Gains gains = Gains::by_criterion("CE2");
    double static_friction = 0.0;  // 0 <= dynamic <= static <= 10
    double dynamic_friction = 0.0;
    // Force shading (docs/mesh-rendering.md, "Force shading"): the crease angle in degrees, 0 .. 80; faces meeting
    // at more than it keep their edge sharp. Empty: off (the faces' own normals).
    std::optional<double> shading_crease_angle_deg{};
};

using ObjectDescription = std::variant<Plane, Spring, Field, Mesh>;

// One batch of operations, committed all-or-nothing at one tick boundary.
class Batch {
  public:
    struct Operation {
        enum class Kind { Add, Modify, Remove, Clear } kind = Kind::Add;
        std::uint32_t object_id = 0;              // Modify, Remove
        std::optional<ObjectDescription> object;  // Add, Modify
    };
    Batch& add(const ObjectDescription& object);
    Batch& modify(std::uint32_t object_id, const ObjectDescription& object);
    Batch& remove(std::uint32_t object_id);
    Batch& clear();
    [[nodiscard]] const std::vector<Operation>& operations() const noexcept { return operations_; }
    [[nodiscard]] bool empty() const noexcept { return operations_.empty(); }

  private:
    std::vector<Operation> operations_;
};

struct CommitResult {
    std::uint64_t commit_seq = 0;           // appears as StateSample::last_commit_seq once applied
    std::vector<std::uint32_t> object_ids;  // one per add, in order
    std::size_t scenes_checked = 0;         // scene verdicts of the stability check (docs/protocol.md, section 5) ...
    std::size_t scenes_sampled = 0;         // ... of them accepted on the sampled verdict, not proven over the set
};

// The welcome's `device` (docs/protocol.md, section 2).
struct DeviceInfo {
    std::string name;
    std::size_t axes = 0;
    double period_s = 0.0;
    // kg, per axis a the mass a plane along that axis acts with, 1 / (M^-1)_aa (= M_aa for a diagonal M;
    // axes beyond the device's: axis 0's).
    Vec3 mass{};
    // kg, the profile's mass matrix M on the device's axes (row i, column j; m I for one mass), 0 beyond
    // them. A plane with unit normal n acts with the mass 1 / (n^T M^-1 n).
    std::array<Vec3, 3> mass_matrix{};
    double delay_s = 0.0;  // total loop delay the gains are checked for
    double max_force = 0.0;
    std::optional<double> max_stiffness;  // N/m, the profile's limit; none: only the stability region bounds K
    // The velocity estimate every damper acts on and every check analyses: "backward", "lowpass:<F>Hz" or
    // "window:<N>" (docs/velocity-estimation.md).
    std::string velocity_estimator = "backward";
    // The plant set every check holds for (docs/robust-stability.md): the mass matrix scaled by mass_scale[0] ..
    // mass_scale[1]; plant_set_exact false when the checks sample the set (a profile with b or k > 0).
    std::array<double, 2> mass_scale{1.0, 1.0};
    // With every mass, an arm of k_H / m up to arm_stiffness_per_mass (s^-2) and b_H / m up to arm_damping_per_mass
    // (s^-1); 0 and 0: the device alone.
    double arm_stiffness_per_mass = 0.0;
    double arm_damping_per_mass = 0.0;
    bool plant_set_exact = true;
};

struct Welcome {
    int protocol = 0;
    std::uint64_t session = 0;
    double lease_s = 0.0;
    std::size_t max_message_bytes = 0;
    std::size_t capacity = 0;
    std::string state_shm;
    double ramp_s = 0.0;
    double max_force_rate = 0.0;
    DeviceInfo device;
};

struct ObjectInfo {
    std::uint32_t id = 0;
    std::uint64_t owner = 0;  // session; 0: the daemon's config walls
    std::string kind;         // "plane", "spring", "field", "mesh"
    double K = 0.0;           // gains used, N/m
    double B = 0.0;           // N s/m
    std::string description_json;
};

struct Status {
    std::uint64_t tick = 0;
    std::uint64_t sessions = 0;
    std::uint64_t objects = 0;
    std::uint64_t overruns = 0;
    std::uint64_t commits_applied = 0;
    std::string fault;
    std::uint64_t meshes = 0;      // meshes held by every session (uploading, building or built)
    std::uint64_t mesh_bytes = 0;  // what they count against the limits (docs/protocol.md, section 4a)
    // The commit whose scenes are being checked (docs/protocol.md, section 3): its session and for how long so far;
    // none when no check runs. Commits of other sessions waiting for it: commits_waiting.
    std::optional<std::uint64_t> commit_check_session;
    double commit_check_running_s = 0.0;
    std::uint64_t commits_waiting = 0;
    // Sessions gone whose objects still render while their departure is planned (docs/protocol.md, section 5).
    std::uint64_t departures_waiting = 0;
};

// A mesh object's god-object proxy as the loop rendered it at the sample's tick (docs/protocol.md, section 6;
// StateMeshProxy), in the device frame: the object pushes the handle towards the proxy, K (proxy - position).
struct MeshProxySample {
    std::uint32_t object_id = 0;
    std::uint32_t slot = 0;                // the scene slot, 0 .. 63
    Vec3 proxy{};                          // m: on or outside the surface (1 um in front of its faces)
    std::array<Vec3, 3> normals{};         // unit outward normals of the active constraints (the first `constraints`)
    int constraints = 0;                   // active faces, 0 .. 3; 0: free (the proxy is at the handle)
    std::uint32_t triangle = 0xFFFFFFFFU;  // one active face (index in the uploaded mesh); 0xFFFFFFFF when free
    bool sliding = false;                  // friction: the proxy slid at this tick
    bool converged = true;                 // false: the proxy's step ran out of sweeps and goes on at the next tick
};

// One consistent copy of the shared-memory state (or of a subscribed `state` message).
struct StateSample {
    std::uint64_t tick = 0;
    double time_s = 0.0;
    Vec3 position{};
    Vec3 velocity{};
    Vec3 force{};
    std::uint64_t contact_mask = 0;         // bit s: the client object in slot s is in contact
    std::uint64_t config_contact_mask = 0;  // bit i: the config wall with object id i + 1 is in contact
    std::uint64_t overruns = 0;
    std::int64_t wake_latency_ns = 0;
    std::uint64_t last_commit_seq = 0;  // every batch up to this commit_seq is applied
    std::uint32_t fault = 0;            // 0 none, 1 device, 2 non-finite, 3 watchdog, 4 fatal signal, 5 std::terminate
    std::uint32_t objects = 0;
    std::array<std::uint32_t, kStateObjectCapacity> slot_object_id{};
    // The mesh objects' proxies: bit s of mesh_slot_mask set when slot s renders a mesh; mesh_proxy[0 ..
    // mesh_proxies - 1] the proxies of the first kStateMeshProxyCapacity (7) of those slots, in slot order (a
    // daemon that publishes none: 0 and 0, StateReader::mesh_proxy_capacity() 0).
    std::uint64_t mesh_slot_mask = 0;
    std::uint32_t mesh_proxies = 0;
    std::array<MeshProxySample, kStateMeshProxyCapacity> mesh_proxy{};
    std::uint64_t dropped = 0;  // subscribed messages dropped before this one (socket only)
    // Shared memory only (docs/protocol.md, section 6): the writer's liveness. stale: the heartbeat is older
    // than state_stale_after_s(period) (10 periods, at least 50 ms) or was never written; the daemon is dead
    // or stalled and the sample is not the device's present state. fatal_signal: with fault 4 or 5.
    bool stale = false;
    double heartbeat_age_s = 0.0;  // s; -1: never written
    std::uint32_t fatal_signal = 0;

    // The ids of the objects in contact: the config walls' (ascending), then the client objects' in slot order.
    [[nodiscard]] std::vector<std::uint32_t> contacts() const {
        std::vector<std::uint32_t> ids;
        for (std::uint32_t i = 0; i < 64; ++i) {
            if ((config_contact_mask >> i & 1U) != 0U) ids.push_back(i + 1);
        }
        for (std::size_t slot = 0; slot < slot_object_id.size(); ++slot) {
            if ((contact_mask >> slot & 1U) != 0U && slot_object_id[slot] != 0) ids.push_back(slot_object_id[slot]);
        }
        return ids;
    }
};

// An unsolicited message of the server (docs/protocol.md, section 3, "Events"): {"type":"event","code":...}
// without an id. `code` says what happened — "objects_removed": another session left and these objects of
// this session had to ramp out with its own (section 5). `object_ids`: the objects it concerns (empty when
// the event names none); `message`: the server's explanation; `json`: the whole message as received, for
// the fields a later event carries that this struct does not name.
struct Event {
    std::string code;
    std::string message;
    std::vector<std::uint32_t> object_ids;
    std::string json;
};

// Events a Client keeps until the application takes them (ConnectOptions::event_queue_capacity).
inline constexpr std::size_t kDefaultEventQueueCapacity = 256;

// One begin or end of contact, as the loop rendered it (a `contact` message, docs/protocol.md, section 6,
// "Contact events"): of a client object (its id) or a config wall (ids 1 .. n). A subscription receives
// every transition in tick order, begin and end alternating per object, unless `dropped` rose.
struct ContactEvent {
    enum class Kind { Begin, End } kind = Kind::Begin;
    std::uint32_t object_id = 0;
    std::uint64_t tick = 0;  // the loop's tick whose published state first (begin) or no longer (end) has it in contact
    double time_s = 0.0;     // that tick's state time_s
    Vec3 position{};         // the handle at that tick, m
    Vec3 force{};            // the force commanded to the device at that tick, N
    std::uint64_t dropped =
        0;  // events of this subscription lost before this one (the daemon's or this session's queue full)
};

// Contact events a Client keeps until the application takes them (ConnectOptions::contact_queue_capacity).
inline constexpr std::size_t kDefaultContactQueueCapacity = 4096;

// How commit() retries a `busy` reply (the hand-over queue to the loop is full; docs/protocol.md, section
// 8): up to `tries` attempts in all, sleeping initial_delay_s before the second and doubling up to
// max_delay_s (defaults: 8 tries, 1, 2, 4, 8, 16, 32, 50 ms: 113 ms of waiting at most). tries = 1: no
// retry. After the last try commit() throws Error(Busy) saying how many tries and how long they took.
struct BusyRetry {
    int tries = 8;                  // 1 .. 1000
    double initial_delay_s = 1e-3;  // 0 .. 10 s
    double max_delay_s = 0.05;      // initial_delay_s .. 10 s
};

// The socket a Client talks over (docs/protocol.md, section 1): SeqPacket, the control socket (one message per
// packet); Stream, the daemon's `.stream` socket or a forward of it (`ssh -L`), one JSON message per line;
// Auto, the one the socket at the path is (SOCK_SEQPACKET, then SOCK_STREAM when connect says EPROTOTYPE).
enum class Transport { Auto, SeqPacket, Stream };

struct ConnectOptions {
    std::string socket_path;  // empty: default_socket_path(instance)
    // The daemon instance (hapticd --instance NAME, include/hapticd/instance.hpp) when socket_path is empty: its
    // socket hapticd-NAME.sock; empty: default_socket_path(). Both set: std::invalid_argument from connect().
    std::string instance{};
    Transport transport = Transport::Auto;
    std::string client_name = "hapticd-client";
    double lease_s = 0.0;             // 0: no lease; else 0.01 .. 60 s, send heartbeat() (or anything) faster
    int protocol = kProtocolVersion;  // for tests of the refusal
    double timeout_s = 5.0;           // for each reply
    // Events kept until poll_event() / next_event() takes them; more are dropped (counted: events_dropped()).
    std::size_t event_queue_capacity = kDefaultEventQueueCapacity;
    // Contact events kept until poll_contact() / next_contact() takes them; more are dropped (counted:
    // contacts_dropped()).
    std::size_t contact_queue_capacity = kDefaultContactQueueCapacity;
    BusyRetry busy_retry{};  // commit()'s retries of `busy`; checked by connect() (std::invalid_argument)
};

// $HAPTICD_SOCKET, else the socket of the instance $HAPTICD_INSTANCE names, else $RUNTIME_DIRECTORY/hapticd.sock,
// $XDG_RUNTIME_DIR/hapticd.sock, /run/hapticd/hapticd.sock. An invalid $HAPTICD_INSTANCE: std::invalid_argument
// naming it and the accepted form.
[[nodiscard]] std::string default_socket_path();
// The socket of instance NAME: hapticd-NAME.sock in $RUNTIME_DIRECTORY, $XDG_RUNTIME_DIR or /run/hapticd (the
// daemon's order); "" : default_socket_path(). An invalid name: std::invalid_argument naming the accepted form.
[[nodiscard]] std::string default_socket_path(const std::string& instance);

class Client {
  public:
    // Connects and performs the handshake. Throws Error (Transport, ProtocolVersion, BadHello, ...).
    static Client connect(const ConnectOptions& options);

    Client(Client&& other) noexcept;
    Client& operator=(Client&& other) noexcept;
    Client(const Client&) = delete;
    Client& operator=(const Client&) = delete;
    ~Client();  // closes the socket: the server ramps this session's objects out

    [[nodiscard]] const Welcome& welcome() const noexcept { return welcome_; }

    std::uint64_t heartbeat();                // returns the loop's tick
    CommitResult commit(const Batch& batch);  // throws Error on refusal (nothing changed); retries busy (BusyRetry)
    // Throws std::invalid_argument naming the field and its range.
    void set_busy_retry(const BusyRetry& retry);
    [[nodiscard]] const BusyRetry& busy_retry() const noexcept { return busy_retry_; }
    std::vector<ObjectInfo> list();
    Status status();
    // Uploads a triangle mesh (docs/protocol.md, section 4a: mesh_begin, chunks of at most 500 vertices or 1000
    // triangles, mesh_end) and waits up to build_timeout_s for its hierarchy (mesh_status every 5 ms). Returns
    // the mesh's id, for Mesh::mesh. The server's refusals (bad_message naming the vertex or triangle, open in
    // solid mode, the session's limits) are thrown as Error; a mesh that fails to build too.
    std::uint32_t upload_mesh(const std::vector<Vec3>& vertices,
                              const std::vector<std::array<std::uint32_t, 3>>& triangles, bool solid,
                              double build_timeout_s = 10.0);
    void delete_mesh(std::uint32_t mesh);  // freed once no object renders it
    void subscribe(double rate_hz);
    void unsubscribe();
    // The next subscribed `state` message; std::nullopt after timeout_s without one.
    std::optional<StateSample> next_state(double timeout_s);

    // Contact events (docs/protocol.md, section 6, "Contact events"): object_ids empty: every object's, else
    // only those (1 .. 64 ids). Returns the objects in contact when the subscription took effect (the
    // events that follow continue from there); subscribing again replaces the filter and starts afresh
    // (contact events queued here are discarded). Events arrive alongside state samples and events: every
    // call that reads the socket queues them, in order. poll_contact(): the oldest queued, first reading
    // what has arrived without waiting; next_contact(): waits up to timeout_s for one.
    std::vector<std::uint32_t> subscribe_contacts(const std::vector<std::uint32_t>& object_ids = {});
    void unsubscribe_contacts();
    std::optional<ContactEvent> poll_contact();
    std::optional<ContactEvent> next_contact(double timeout_s);
    [[nodiscard]] std::size_t contacts_queued() const noexcept { return contacts_.size(); }
    // Contact events dropped here because the queue (ConnectOptions::contact_queue_capacity) was full; the
    // server's own losses are in ContactEvent::dropped.
    [[nodiscard]] std::uint64_t contacts_dropped() const noexcept { return contacts_dropped_; }
    void bye();  // orderly end of the session

    // Events (the server's unsolicited `event` messages), in the order they arrived. Every call that reads
    // the socket (a request waiting for its reply, next_state) queues the events it reads, so none is lost
    // while a request waits. poll_event(): the oldest queued event; with none queued, it first reads what
    // has arrived, without waiting (std::nullopt: no event). next_event(): waits up to timeout_s for one. Polled, not
    // called back: a callback run inside commit() could call commit() again. The queue holds
    // ConnectOptions::event_queue_capacity events; further ones are dropped and counted — after a drop,
    // list() tells the scene as it is.
    std::optional<Event> poll_event();
    std::optional<Event> next_event(double timeout_s);
    [[nodiscard]] std::size_t events_queued() const noexcept { return events_.size(); }
    [[nodiscard]] std::uint64_t events_dropped() const noexcept { return events_dropped_; }

    // Low level, for tests and other encodings: send one raw message, receive one raw message.
    void send_raw(const std::string& message);
    std::optional<std::string> receive_raw(double timeout_s);
    [[nodiscard]] int fd() const noexcept { return fd_; }
    // True over the stream transport (the daemon may be on another machine: StateSource subscribes).
    [[nodiscard]] bool stream() const noexcept { return stream_; }
    // The newest subscribed `state` message arrived (older ones queued are discarded); with none arrived, the
    // next one within timeout_s, else std::nullopt.
    std::optional<StateSample> latest_state(double timeout_s);

  private:
    Client(int fd, double timeout_s) : fd_(fd), timeout_s_(timeout_s) {}
    bool stream_ = false;
    std::string rx_;  // stream: received bytes not yet returned as messages
    std::string request(const std::string& type, const std::string& body_json);  // returns the ok reply
    int fd_ = -1;
    double timeout_s_ = 5.0;
    std::uint64_t next_id_ = 1;
    Welcome welcome_;
    std::vector<std::string> pending_states_;  // state messages received while waiting for a reply
    // A message that is not the reply awaited: a state (kept for next_state), an event or a contact event
    // (queued), `expired` (thrown as Error from `function`); others (a late reply) are ignored. Returns true
    // for an event.
    bool keep_unsolicited(const std::string& raw, const std::string& function);
    std::deque<Event> events_;
    std::size_t event_capacity_ = kDefaultEventQueueCapacity;
    std::uint64_t events_dropped_ = 0;
    std::deque<ContactEvent> contacts_;
    std::size_t contact_capacity_ = kDefaultContactQueueCapacity;
    std::uint64_t contacts_dropped_ = 0;
    BusyRetry busy_retry_{};
};

// Read-only view of the daemon's shared-memory state.
class StateReader {
  public:
    // Throws Error(Transport) when the segment does not exist or has another magic/layout version.
    static StateReader open(const std::string& shm_name);
    StateReader(StateReader&& other) noexcept;
    StateReader& operator=(StateReader&& other) noexcept;
    StateReader(const StateReader&) = delete;
    StateReader& operator=(const StateReader&) = delete;
    ~StateReader();

    // Copies one consistent tick (seqlock). No allocation, no system call but the vDSO's clock_gettime. While
    // the writer is inside a publication (the sequence odd; a preempted loop can hold it for milliseconds) it
    // waits, up to stale_after_s(). Returns false if the sequence stayed odd that long (a stalled or dead
    // writer) or `max_attempts` completed copies in a row overlapped a write.
    bool read(StateSample& out, int max_attempts = 1000) const noexcept;
    [[nodiscard]] std::size_t axes() const noexcept;
    [[nodiscard]] double period_s() const noexcept;
    // The age after which read() flags a sample stale: state_stale_after_s(period_s()).
    [[nodiscard]] double stale_after_s() const noexcept;
    // The daemon's process id as it wrote it at start-up.
    [[nodiscard]] long writer_pid() const noexcept;
    // Mesh proxies the daemon publishes per tick (StateLayout::mesh_proxy_capacity): 7, or 0 for a daemon that
    // publishes none (its segment has zeros there).
    [[nodiscard]] std::size_t mesh_proxy_capacity() const noexcept;

  private:
    explicit StateReader(const StateLayout* layout) : layout_(layout) {}
    const StateLayout* layout_ = nullptr;
};

// The device state from wherever this client can read it (docs/clients.md, "Remote use"): the shared memory
// (StateReader) or `subscribe` over the session's socket. Auto: over the stream transport subscribe (the daemon
// may run on another machine, and a segment of the same name here would be another daemon's); over the
// SOCK_SEQPACKET socket the shared memory, subscribing only when the segment cannot be opened.
class StateSource {
  public:
    enum class Mode { Auto, SharedMemory, Subscribe };
    // Throws Error(Transport) for SharedMemory when the segment cannot be opened, std::invalid_argument for a
    // rate outside 0.1 .. 1000 Hz. The client must outlive the source.
    StateSource(Client& client, double rate_hz = 1000.0, Mode mode = Mode::Auto);
    [[nodiscard]] bool shared_memory() const noexcept { return reader_.has_value(); }
    // Why the subscription was chosen in Auto mode (empty: the shared memory).
    [[nodiscard]] const std::string& why() const noexcept { return why_; }
    // The latest tick: from the shared memory, or the newest state message (waiting up to timeout_s for one;
    // std::nullopt when none came).
    std::optional<StateSample> read(double timeout_s = 1.0);

  private:
    Client* client_;
    std::optional<StateReader> reader_;
    std::string why_;
};

}  // namespace hapticd::client
