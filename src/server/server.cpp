// SPDX-License-Identifier: Apache-2.0
#include "server/server.hpp"

#include <fcntl.h>
#include <poll.h>
#include <sys/eventfd.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/un.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <algorithm>
#include <deque>
#include <iostream>
#include <map>
#include <mutex>
#include <optional>
#include <sstream>
#include <stdexcept>

#include <hapticopt/criterion.hpp>
#include <nlohmann/json.hpp>

#include "client/object_json.hpp"
#include "client/text_limits.hpp"
#include "server/departure_plan.hpp"
#include "tuning/engagement_patterns.hpp"
#include "server/message_decoder.hpp"
#include "server/object_limits.hpp"
#include "server/reply_text.hpp"
#include "server/state_publisher.hpp"
#include "tuning/object_checks.hpp"
#include "tuning/tuning.hpp"

namespace hapticd {

namespace {

using nlohmann::json;
using Clock = std::chrono::steady_clock;
namespace cl = hapticd::client;

constexpr std::size_t kMaxSessions = 256;
constexpr int kMessagesPerRound = 16;
constexpr int kHelloTimeoutS = 5;  // a connection that never says hello is closed (it would hold a session)
constexpr std::uint64_t kNotPushed = ~std::uint64_t{0};
// Contact messages a session may have waiting for room in its socket: 256 of ~250 bytes.
constexpr std::size_t kContactQueueCapacity = 256;

std::string g(double v) { return server::short_number(v); }


Matrix3 outer(const AxisVector& u, double scale) {
    Matrix3 m{};
    for (std::size_t i = 0; i < 3; ++i) {
        for (std::size_t j = 0; j < 3; ++j) m[i][j] = scale * u[i] * u[j];
    }
    return m;
}

AxisVector to_axis(const cl::Vec3& v) { return AxisVector{v[0], v[1], v[2]}; }

// The config walls as terms of the checks (ids 1 .. n, as in `list`): unilateral ones engage conditionally,
// and two facing each other on one axis with disjoint solids are never engaged together.
std::vector<SceneTerm> terms_of_config_walls(const std::vector<ConfigWallInfo>& config_walls) {
    std::vector<AxisWall> walls;
    for (const auto& w : config_walls) walls.push_back(AxisWall{w.axis, w.position, w.direction, w.bilateral});
    const std::vector<int> pairs = exclusive_wall_pairs(walls);
    std::vector<SceneTerm> terms;
    for (std::size_t i = 0; i < config_walls.size(); ++i) {
        const auto& w = config_walls[i];
        std::array<double, 3> e{};
        e[w.axis] = 1.0;
        SceneTerm t = plane_term(e, w.K, w.B);
        t.conditional = !w.bilateral;
        t.exclusive_pair = pairs[i];
        t.object_id = static_cast<std::uint32_t>(i + 1);
        terms.push_back(t);
    }
    return terms;
}

// A checked object: what the loop renders and what the summed-gain check adds.
struct Resolved {
    ObjectParams params;
    Matrix3 K_matrix{};
    Matrix3 B_matrix{};
};

struct Refusal {
    cl::ErrorCode code = cl::ErrorCode::BadMessage;
    std::string message;
    std::optional<double> largest_stable_K;
    std::optional<std::pair<double, double>> damping_needed = std::nullopt;  // unstable_gains: the B (N s/m) interval for K
};

struct ServerSlot {
    enum class State { Free, Used, Draining } state = State::Free;
    std::uint32_t id = 0;
    std::uint64_t owner = 0;
    std::optional<cl::ObjectDescription> description;
    Resolved resolved;
    std::uint64_t drain_seq = kNotPushed;
};

struct Session {
    int fd = -1;
    std::uint64_t id = 0;
    long pid = 0;
    long uid = -1;
    long gid = -1;
    std::string name;
    bool welcomed = false;
    double lease_s = 0.0;
    Clock::time_point last_rx;
    bool subscribed = false;
    double rate_hz = 0.0;
    Clock::time_point next_state;
    std::uint64_t dropped = 0;
    bool closed = false;
    std::deque<std::uint64_t> in_flight;  // commit_seq of this session's batches the loop has not applied yet
    bool contacts = false;                // subscribe_contacts
    std::optional<std::vector<std::uint32_t>> contact_filter;  // none: every object
    std::deque<std::string> contact_queue;  // contact messages waiting for room in the socket, oldest first
    std::uint64_t contact_dropped = 0;      // contact events lost for this subscription so far
};

}  // namespace

std::string default_server_socket_path() {
    if (const char* s = std::getenv("RUNTIME_DIRECTORY"); s != nullptr && *s != '\0') return std::string(s) + "/hapticd.sock";
    if (const char* s = std::getenv("XDG_RUNTIME_DIR"); s != nullptr && *s != '\0') return std::string(s) + "/hapticd.sock";
    return "/run/hapticd/hapticd.sock";
}

void remove_stale_socket(const std::string& path) {
    sockaddr_un addr{};
    if (path.size() >= sizeof(addr.sun_path)) return;  // refused by the bind with the accepted length
    struct stat st {};
    if (::lstat(path.c_str(), &st) != 0) {
        if (errno == ENOENT) return;
        throw SocketPathError("Server: socket path '" + path + "': lstat: " + std::strerror(errno));
    }
    if (!S_ISSOCK(st.st_mode)) {
        throw SocketPathError("Server: socket path '" + path + "' exists and is not a socket; hapticd replaces only a stale socket "
                              "of its own: remove the file or choose another --serve-socket");
    }
    const int probe = ::socket(AF_UNIX, SOCK_SEQPACKET | SOCK_CLOEXEC, 0);
    if (probe < 0) throw SocketPathError(std::string("Server: socket: ") + std::strerror(errno));
    addr.sun_family = AF_UNIX;
    std::memcpy(addr.sun_path, path.c_str(), path.size() + 1);
    const int c = ::connect(probe, reinterpret_cast<const sockaddr*>(&addr), sizeof(addr));
    const int connect_errno = errno;
    ::close(probe);
    if (c == 0) {
        throw SocketPathError("Server: socket path '" + path + "' is in use: a process is listening on it (another hapticd?); "
                              "stop it or choose another --serve-socket");
    }
    if (connect_errno != ECONNREFUSED) {
        throw SocketPathError("Server: socket path '" + path + "' is a socket hapticd cannot tell is stale (connect: " +
                              std::strerror(connect_errno) + "); remove it or choose another --serve-socket");
    }
    if (::unlink(path.c_str()) != 0 && errno != ENOENT) {
        throw SocketPathError("Server: cannot remove the stale socket '" + path + "': " + std::strerror(errno));
    }
}

struct Server::Impl {
    Impl(const ServerConfig& c, GainChecker& k, CommitRing& r, CommitRing* d, const StatePublisher& s,
         std::atomic<std::uint64_t>& pushed, ContactRing* contacts)
        : config(c), checker(k), ring(r), departure_ring(d != nullptr ? *d : r), state(s), commits_pushed(pushed),
          contact_ring(contacts) {}

    ServerConfig config;
    GainChecker& checker;
    CommitRing& ring;
    CommitRing& departure_ring;  // `ring` itself when the loop has no departure ring
    const StatePublisher& state;
    std::atomic<std::uint64_t>& commits_pushed;
    ContactRing* contact_ring;              // may be null: no contact events
    std::uint64_t contact_lost_seen = 0;    // the lost_before of the last record taken
    std::vector<std::uint32_t> in_contact;  // ascending: the objects in contact after the last record taken
    int listen_fd = -1;
    int wake_fd = -1;
    std::atomic<bool> stop{false};
    std::map<std::uint64_t, Session> sessions;
    std::array<ServerSlot, kSceneObjectCapacity> slots{};
    std::deque<ObjectCommit> pending;  // departure batches that did not fit in the departure ring yet
    std::vector<pollfd> departed_fds;      // close_departed_sessions' poll set, kept to reuse its storage
    std::vector<std::uint64_t> departed_ids;
    std::uint32_t next_object_id = 1;
    std::uint64_t next_session_id = 1;
    std::uint64_t next_commit_seq = 1;
    mutable std::mutex counters_mutex;
    ServerCounters counters;
    std::vector<char> buffer = std::vector<char>(cl::kMaxMessageBytes + 1);
    StateLayout snapshot{};

    void log(const std::string& line) const {
        if (config.log_connections) std::cerr << "hapticd: server: " << line << "\n";
    }

    // ---- socket set-up -------------------------------------------------------------------------
    void open_socket() {
        if (config.socket_path.empty()) config.socket_path = default_server_socket_path();
        const std::string& path = config.socket_path;
        sockaddr_un addr{};
        addr.sun_family = AF_UNIX;
        if (path.size() >= sizeof(addr.sun_path)) {
            throw std::runtime_error("Server: socket path '" + path + "' is too long; accepted: at most " +
                                     std::to_string(sizeof(addr.sun_path) - 1) + " bytes");
        }
        const auto slash = path.rfind('/');
        if (slash != std::string::npos && slash > 0) {
            const std::string dir = path.substr(0, slash);
            struct stat st {};
            if (::stat(dir.c_str(), &st) != 0 && ::mkdir(dir.c_str(), 0755) != 0) {
                throw std::runtime_error("Server: cannot create the socket directory '" + dir + "': " + std::strerror(errno));
            }
        }
        std::memcpy(addr.sun_path, path.c_str(), path.size() + 1);
        listen_fd = ::socket(AF_UNIX, SOCK_SEQPACKET | SOCK_NONBLOCK | SOCK_CLOEXEC, 0);
        if (listen_fd < 0) throw std::runtime_error(std::string("Server: socket: ") + std::strerror(errno));
        remove_stale_socket(path);
        // Bind with a restrictive umask so the file never exists with a wider mode than asked for.
        const mode_t old = ::umask(0177);
        const int b = ::bind(listen_fd, reinterpret_cast<const sockaddr*>(&addr), sizeof(addr));
        const int bind_errno = errno;
        ::umask(old);
        if (b != 0) throw std::runtime_error("Server: bind('" + path + "'): " + std::strerror(bind_errno));
        if (config.socket_gid >= 0 && ::chown(path.c_str(), static_cast<uid_t>(-1), static_cast<gid_t>(config.socket_gid)) != 0) {
            throw std::runtime_error("Server: chown('" + path + "', group " + std::to_string(config.socket_gid) + "): " + std::strerror(errno));
        }
        if (::chmod(path.c_str(), static_cast<mode_t>(config.socket_mode)) != 0) {
            throw std::runtime_error("Server: chmod('" + path + "'): " + std::strerror(errno));
        }
        if (::listen(listen_fd, 64) != 0) throw std::runtime_error(std::string("Server: listen: ") + std::strerror(errno));
        wake_fd = ::eventfd(0, EFD_NONBLOCK | EFD_CLOEXEC);
        if (wake_fd < 0) throw std::runtime_error(std::string("Server: eventfd: ") + std::strerror(errno));
    }

    // ---- sending -------------------------------------------------------------------------------
    // Replies: a full socket means the client does not read -> disconnect (never block).
    void send_reply(Session& s, json message) {
        if (s.closed) return;
        const std::string text = server::reply_text(std::move(message));
        const ssize_t n = ::send(s.fd, text.data(), text.size(), MSG_DONTWAIT | MSG_NOSIGNAL);
        if (n < 0) {
            if (errno == EAGAIN || errno == EWOULDBLOCK) {
                close_session(s, std::string(cl::to_string(cl::ErrorCode::SlowConsumer)) + " (a reply did not fit: the client does not read)");
            } else {
                close_session(s, std::string("send failed: ") + std::strerror(errno));
            }
        }
    }

    void send_error(Session& s, std::optional<std::uint64_t> id, cl::ErrorCode code, const std::string& message,
                    int op_index = -1, std::optional<double> largest = std::nullopt,
                    std::optional<std::pair<double, double>> damping = std::nullopt) {
        json e{{"type", "error"}, {"code", cl::to_string(code)}, {"message", message}};
        e["id"] = id ? json(*id) : json(nullptr);
        if (op_index >= -1 && code != cl::ErrorCode::BadJson) e["op_index"] = op_index;
        if (largest) e["largest_stable_K"] = *largest;
        if (damping) e["damping_needed"] = json::array({damping->first, damping->second});
        send_reply(s, e);
    }

    // ---- sessions ------------------------------------------------------------------------------
    void accept_all() {
        for (;;) {
            const int fd = ::accept4(listen_fd, nullptr, nullptr, SOCK_NONBLOCK | SOCK_CLOEXEC);
            if (fd < 0) return;  // EAGAIN or a transient error: try again next round
            ucred cred{};
            socklen_t len = sizeof(cred);
            const bool have = ::getsockopt(fd, SOL_SOCKET, SO_PEERCRED, &cred, &len) == 0;
            if (sessions.size() >= kMaxSessions) {
                const std::string text = json{{"type", "refused"}, {"code", cl::to_string(cl::ErrorCode::Capacity)},
                                              {"message", "Server: " + std::to_string(kMaxSessions) + " sessions already open"}}
                                             .dump();
                (void)::send(fd, text.data(), text.size(), MSG_DONTWAIT | MSG_NOSIGNAL);
                ::close(fd);
                continue;
            }
            Session s;
            s.fd = fd;
            s.id = next_session_id++;
            s.pid = have ? static_cast<long>(cred.pid) : 0;
            s.uid = have ? static_cast<long>(cred.uid) : -1;
            s.gid = have ? static_cast<long>(cred.gid) : -1;
            s.last_rx = Clock::now();
            log("session " + std::to_string(s.id) + " connected: pid " + std::to_string(s.pid) + ", uid " +
                std::to_string(s.uid) + ", gid " + std::to_string(s.gid));
            sessions.emplace(s.id, s);
            std::lock_guard<std::mutex> lock(counters_mutex);
            ++counters.sessions_opened;
        }
    }

    void close_session(Session& s, const std::string& why) {
        if (s.closed) return;
        s.closed = true;
        ::close(s.fd);
        s.fd = -1;
        ramp_out_objects_of(s.id);
        log("session " + std::to_string(s.id) + " (" + (s.name.empty() ? "unnamed" : s.name) + ", pid " + std::to_string(s.pid) +
            ", uid " + std::to_string(s.uid) + ") closed: " + why);
        std::lock_guard<std::mutex> lock(counters_mutex);
        ++counters.sessions_closed;
    }

    // The config walls' gains (the daemon's, along their axes) added to K and B.
    void add_config_walls(Matrix3& K, Matrix3& B) const {
        for (const auto& w : config.config_walls) {
            AxisVector e{};
            e[w.axis] = 1.0;
            add_to(K, outer(e, w.K));
            add_to(B, outer(e, w.B));
        }
    }

    std::vector<SceneTerm> config_wall_terms() const { return terms_of_config_walls(config.config_walls); }

    static SceneTerm slot_term(const ServerSlot& slot, SceneTerm::Role role) {
        SceneTerm t;
        t.K = slot.resolved.K_matrix;
        t.B = slot.resolved.B_matrix;
        t.conditional = engages_conditionally(slot.resolved.params);
        t.role = role;
        t.object_id = slot.id;
        return t;
    }

    // A session's objects ramp out by the departure rule (departure_plan.hpp, docs/protocol.md section 5):
    // with them, if the scene they leave or a ramp scene would be unstable, the fewest further client
    // objects (or all of them, or all cut at once); the owners of those get an event with the reason.
    void ramp_out_objects_of(std::uint64_t session) {
        std::vector<DepartureObject> leaving, staying;
        for (std::size_t i = 0; i < kSceneObjectCapacity; ++i) {
            const ServerSlot& slot = slots[i];
            if (slot.state != ServerSlot::State::Used) continue;
            (slot.owner == session ? leaving : staying)
                .push_back(DepartureObject{i, slot.owner, slot_term(slot, SceneTerm::Role::Base)});
        }
        if (leaving.empty()) return;
        const double step = config.ramp_time > 0.0 ? config.period / config.ramp_time : 1.0;
        const DeparturePlan plan = plan_departure(checker, config_wall_terms(), leaving, staying, step);
        ObjectCommit c;
        std::map<std::uint64_t, std::vector<std::uint32_t>> further_by_owner;
        for (const std::size_t i : plan.out) {
            ServerSlot& slot = slots[i];
            if (slot.owner != session) further_by_owner[slot.owner].push_back(slot.id);
            slot.state = ServerSlot::State::Draining;
            slot.drain_seq = kNotPushed;
            SlotUpdate& u = c.updates[c.count++];
            u.slot = static_cast<std::uint8_t>(i);
            u.action = plan.cut ? SlotUpdate::Action::Cut : SlotUpdate::Action::Remove;
            u.params = slot.resolved.params;
        }
        pending.push_back(c);  // before the events: a send may close another session, whose batch must follow
        push_pending();
        if (!plan.further.empty()) {
            const std::string how = plan.cut ? "removed at once (no ramp-out of them all is stable either)" : "ramped out with them";
            log("session " + std::to_string(session) + " left; " + std::to_string(plan.further.size()) + " objects of other sessions " +
                how + ": " + plan.reason);
            for (const auto& [owner, ids] : further_by_owner) {
                const auto it = sessions.find(owner);
                if (it == sessions.end() || it->second.closed) continue;
                send_reply(it->second, json{{"type", "event"}, {"code", "objects_removed"}, {"object_ids", ids},
                                            {"message", "objects " + json(ids).dump() + " are " + how + " because session " +
                                                            std::to_string(session) + " left and, without them, " + plan.reason +
                                                            " (docs/protocol.md, section 5)"}});
            }
        }
    }

    // Pushes waiting departure batches in order; assigns their sequence numbers when they enter the ring.
    // The loop applies every batch with a smaller seq (sent before) at once when it takes a departure, and
    // none with a larger one before it: the departure was planned on exactly that scene (`slots` now).
    void push_pending() {
        while (!pending.empty()) {
            ObjectCommit& c = pending.front();
            c.seq = next_commit_seq;
            if (!departure_ring.try_push(c)) return;
            ++next_commit_seq;
            for (std::uint32_t i = 0; i < c.count; ++i) slots[c.updates[i].slot].drain_seq = c.seq;
            commits_pushed.fetch_add(1, std::memory_order_release);
            {
                std::lock_guard<std::mutex> lock(counters_mutex);
                ++counters.commits_pushed;
            }
            pending.pop_front();
        }
    }

    // ---- object checks -------------------------------------------------------------------------
    std::optional<Refusal> check_vector(const cl::Vec3& v, const std::string& field, bool unit) const {
        for (std::size_t a = config.axes; a < 3; ++a) {
            if (v[a] != 0.0) {
                return Refusal{cl::ErrorCode::BadMessage, field + "[" + std::to_string(a) + "] = " + g(v[a]) + " is invalid: the device has " +
                                                  std::to_string(config.axes) + " axes; accepted: 0 beyond axis " +
                                                  std::to_string(config.axes - 1), std::nullopt};
            }
        }
        if (unit) {
            const double n = std::sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
            if (!(std::fabs(n - 1.0) <= 1e-6)) {
                return Refusal{cl::ErrorCode::BadMessage, field + ": length " + g(n) + " is invalid; accepted range: a unit vector, | |n| - 1 | <= 1e-6",
                               std::nullopt};
            }
        }
        return std::nullopt;
    }

    server::WorkspaceBox workspace() const {
        server::WorkspaceBox box;
        box.axes = config.axes;
        for (std::size_t a = 0; a < 3; ++a) {
            box.min[a] = config.workspace_min[a];
            box.max[a] = config.workspace_max[a];
        }
        return box;
    }

    std::optional<Refusal> check_in_workspace(const cl::Vec3& v, const std::string& field) const {
        if (auto r = server::check_in_workspace(v, field, workspace())) return Refusal{r->code, r->message, std::nullopt};
        return std::nullopt;
    }

    // A plane outside the workspace is refused (docs/protocol.md, section 5).
    std::optional<Refusal> check_plane_in_workspace(const cl::Vec3& n, double offset) const {
        if (auto r = server::check_plane_in_workspace(n, offset, workspace())) return Refusal{r->code, r->message, std::nullopt};
        return std::nullopt;
    }

    // The profile's stiffness limit (beyond_device_limits); `what` names the stiffness ("plane: K").
    std::optional<Refusal> check_stiffness_limit(double K, const std::string& what) const {
        const std::optional<double> limit = checker.max_stiffness();
        if (!limit || !(K > *limit)) return std::nullopt;
        return Refusal{cl::ErrorCode::BeyondDeviceLimits, what + " = " + g(K) + " N/m exceeds the device's stiffness limit (device profile key "
                                                      "max_stiffness = " + g(*limit) + " N/m); accepted range: <= " + g(*limit) + " N/m",
                       std::nullopt};
    }

    // Gains of an object acting with gains (K P, B P) and the masses `masses` (GainChecker::masses_of):
    // explicit or the cached optimum of the criterion for the lightest of them; then the stiffness limit
    // and the exact verdict for every mass.
    std::optional<Refusal> resolve_gains(const cl::Gains& gains, const std::string& kind, const std::vector<double>& masses,
                                         double& K, double& B) {
        const double lightest = masses.empty() ? checker.mass().smallest() : *std::min_element(masses.begin(), masses.end());
        if (!gains.criterion.empty()) {
            std::optional<CriterionGains> c;
            try {
                c = checker.criterion_gains(gains.criterion, lightest);
            } catch (const std::exception& e) {
                return Refusal{cl::ErrorCode::BadMessage, kind + ".gains.criterion = " + cl::truncate_utf8(gains.criterion, 40) + ": " + e.what(), std::nullopt};
            }
            if (!c) {
                return Refusal{cl::ErrorCode::UnknownCriterion, kind + ".gains.criterion = \"" + cl::truncate_utf8(gains.criterion, 40) +
                                                        "\" is invalid; accepted: " + accepted_criteria_text(),
                               std::nullopt};
            }
            K = c->K;
            B = c->B;
            if (auto r = check_stiffness_limit(K, kind + ": the optimal K of criterion " + gains.criterion)) return r;
        } else {
            K = gains.K.value_or(0.0);
            B = gains.B.value_or(0.0);
            if (auto r = server::check_explicit_gains(K, B, kind)) return Refusal{r->code, r->message, std::nullopt};
            if (auto r = check_stiffness_limit(K, kind + ": K")) return r;
        }
        // The verdict per mass (one Schur-Cohn test each); the largest stable K only for the refusal.
        const PairVerdict v = checker.check_object(K, B, masses);
        if (!v.stable) {
            const std::string along = masses.size() == 1 ? "the mass along the object's direction" : "one of the object's directional masses";
            return Refusal{cl::ErrorCode::UnstableGains,
                           kind + ": K = " + g(K) + " N/m, B = " + g(B) + " N s/m (alpha = " + g(v.alpha) + ", beta = " + g(v.beta) +
                               ") are outside the stability region for " + along + ", " + g(v.mass) + " kg (device mass " +
                               checker.mass().describe() + "), period " + g(config.period) + " s, delay " + g(config.delay) +
                               " s; the largest stable K at B = " + g(B) + " N s/m is " + g(v.largest_stable_K) +
                               " N/m (alpha_max = " + g(v.alpha_max) + "); " +
                               (v.damping_stable ? "K = " + g(K) + " N/m is stable for " + g(v.damping_stable->first) + " < B < " +
                                                       g(v.damping_stable->second) + " N s/m" +
                                                       (v.damping_needed ? ", accepted for " + g(v.damping_needed->first) + " < B < " +
                                                                               g(v.damping_needed->second) + " N s/m (damping_needed; the spectral radius "
                                                                               "below 1 - 1e-6)"
                                                                         : " but never 1e-6 below a spectral radius of 1, which the daemon requires")
                                                 : "no B makes K = " + g(K) + " N/m stable with " + along),
                           v.largest_stable_K, v.damping_needed};
        }
        return std::nullopt;
    }

    std::optional<Refusal> resolve(const cl::ObjectDescription& d, Resolved& out) {
        out = Resolved{};
        ObjectParams& p = out.params;
        if (const auto* plane = std::get_if<cl::Plane>(&d)) {
            if (auto r = check_vector(plane->normal, "plane.normal", true)) return r;
            if (auto r = check_plane_in_workspace(plane->normal, plane->offset)) return r;
            p.kind = ObjectKind::Plane;
            p.direction = to_axis(plane->normal);
            p.offset = plane->offset;
            p.bilateral = plane->bilateral;
            if (auto r = resolve_gains(plane->gains, "plane", {checker.mass_along(p.direction)}, p.K, p.B)) return r;
            out.K_matrix = outer(p.direction, p.K);
            out.B_matrix = outer(p.direction, p.B);
            return std::nullopt;
        }
        if (const auto* spring = std::get_if<cl::Spring>(&d)) {
            if (auto r = check_vector(spring->point, "spring.point", false)) return r;
            if (auto r = check_in_workspace(spring->point, "spring.point")) return r;
            p.kind = ObjectKind::Spring;
            p.constraint = spring->constraint == cl::Constraint::Point  ? SpringConstraint::Point
                           : spring->constraint == cl::Constraint::Line ? SpringConstraint::Line
                                                                        : SpringConstraint::Plane;
            if (p.constraint != SpringConstraint::Point) {
                if (auto r = check_vector(spring->direction, "spring.direction", true)) return r;
                p.direction = to_axis(spring->direction);
            }
            p.point = to_axis(spring->point);
            Matrix3 P{};
            if (p.constraint == SpringConstraint::Plane) {
                P = outer(p.direction, 1.0);
            } else {
                for (std::size_t i = 0; i < config.axes; ++i) P[i][i] = 1.0;  // only the device's axes
                if (p.constraint == SpringConstraint::Line) {
                    const Matrix3 dd = outer(p.direction, -1.0);
                    add_to(P, dd);
                }
            }
            const std::vector<double> masses = p.constraint == SpringConstraint::Plane ? std::vector<double>{checker.mass_along(p.direction)}
                                                                                       : checker.masses_of(P);
            if (auto r = resolve_gains(spring->gains, "spring", masses, p.K, p.B)) return r;
            for (std::size_t i = 0; i < 3; ++i) {
                for (std::size_t j = 0; j < 3; ++j) {
                    out.K_matrix[i][j] = p.K * P[i][j];
                    out.B_matrix[i][j] = p.B * P[i][j];
                }
            }
            return std::nullopt;
        }
        const auto& field = std::get<cl::Field>(d);
        if (auto r = check_vector(field.center, "field.center", false)) return r;
        if (auto r = check_vector(field.force, "field.force", false)) return r;
        if (auto r = check_in_workspace(field.center, "field.center")) return r;
        if (auto r = server::check_field_damping(field.damping)) return Refusal{r->code, r->message, std::nullopt};
        if (!(field.radius > 0.0) || !std::isfinite(field.radius)) {
            return Refusal{cl::ErrorCode::BadMessage, "field.radius = " + g(field.radius) + " is invalid; accepted range: finite, > 0 m", std::nullopt};
        }
        Matrix3 J{};
        for (std::size_t i = 0; i < 3; ++i) {
            for (std::size_t j = 0; j < 3; ++j) {
                J[i][j] = field.jacobian[i][j];
                if ((i >= config.axes || j >= config.axes) && J[i][j] != 0.0) {
                    return Refusal{cl::ErrorCode::BadMessage, "field.jacobian[" + std::to_string(i) + "][" + std::to_string(j) +
                                                      "] is invalid: the device has " + std::to_string(config.axes) +
                                                      " axes; accepted: 0 outside them", std::nullopt};
                }
            }
        }
        const GainChecker::FieldStiffness fs = GainChecker::field_stiffness(J);
        const double scale = 1e-12 * (1.0 + fs.jacobian_norm);
        if (fs.min_stiffness < -scale) {
            return Refusal{cl::ErrorCode::UnstableGains, "field.jacobian: its symmetric part has the eigenvalue " + g(-fs.min_stiffness) +
                                                 " N/m > 0 (a negative stiffness, unstable); accepted: sym(J) negative semi-definite",
                           std::nullopt};
        }
        const double f0 = std::sqrt(field.force[0] * field.force[0] + field.force[1] * field.force[1] + field.force[2] * field.force[2]);
        const double largest = f0 + fs.jacobian_norm * field.radius;
        if (largest > config.max_force) {
            return Refusal{cl::ErrorCode::BeyondDeviceLimits, "field: the largest force |F0| + ||J|| radius = " + g(largest) +
                                                       " N exceeds the device's max_force; accepted range: <= " + g(config.max_force) + " N",
                           std::nullopt};
        }
        if (!(field.damping >= 0.0)) {
            return Refusal{cl::ErrorCode::BadMessage, "field.damping = " + g(field.damping) + " is invalid; accepted range: finite, >= 0 N s/m",
                           std::nullopt};
        }
        if (auto r = check_stiffness_limit(fs.max_stiffness, "field: the stiffness of its Jacobian (largest eigenvalue of -sym(J))")) return r;
        Matrix3 B_field{};
        for (std::size_t i = 0; i < config.axes; ++i) B_field[i][i] = field.damping;
        std::string why;
        std::optional<double> largest_stable_K;
        if (!checker.field_is_stable(J, B_field, why, largest_stable_K)) return Refusal{cl::ErrorCode::UnstableGains, why, largest_stable_K};
        p.kind = ObjectKind::Field;
        p.point = to_axis(field.center);
        p.radius = field.radius;
        p.force = to_axis(field.force);
        p.B = field.damping;
        for (std::size_t i = 0; i < 3; ++i) p.jacobian[i] = AxisVector{J[i][0], J[i][1], J[i][2]};
        out.K_matrix = GainChecker::field_stiffness_matrix(J);
        out.B_matrix = B_field;
        return std::nullopt;
    }

    // Per-session limits (docs/protocol.md, section 7): one session may not hold every slot nor fill the
    // hand-over ring. Objects ramping out do not count: they are no longer the session's.
    static std::size_t objects_held(const std::array<ServerSlot, kSceneObjectCapacity>& slots_of, std::uint64_t session) {
        std::size_t n = 0;
        for (const auto& slot : slots_of) n += slot.state == ServerSlot::State::Used && slot.owner == session ? 1U : 0U;
        return n;
    }

    bool refuse_over_in_flight_limit(Session& s, std::uint64_t id) {
        state.read(snapshot);
        while (!s.in_flight.empty() && s.in_flight.front() <= snapshot.last_commit_seq) s.in_flight.pop_front();
        if (s.in_flight.size() < config.session_max_in_flight) return false;
        {
            std::lock_guard<std::mutex> lock(counters_mutex);
            ++counters.commits_refused;
        }
        send_error(s, id, cl::ErrorCode::SessionLimit,
                   "commit: this session has " + std::to_string(s.in_flight.size()) +
                       " batches handed to the loop and not yet applied (the loop has applied up to commit_seq " +
                       std::to_string(snapshot.last_commit_seq) + "); accepted: at most " + std::to_string(config.session_max_in_flight) +
                       " in flight per session (option session-max-in-flight); retry when commit_seq " + std::to_string(s.in_flight.front()) +
                       " is applied",
                   -1);
        return true;
    }

    // ---- commit --------------------------------------------------------------------------------
    void handle_commit(Session& s, std::uint64_t id, const server::CommitRequest& req) {
        if (refuse_over_in_flight_limit(s, id)) return;
        std::array<ServerSlot, kSceneObjectCapacity> proposal = slots;
        std::array<std::optional<SlotUpdate>, kSceneObjectCapacity> updates{};
        std::vector<std::uint32_t> new_ids;
        std::uint32_t next_id = next_object_id;
        auto refuse = [&](cl::ErrorCode code, const std::string& message, int op, std::optional<double> largest = std::nullopt,
                          std::optional<std::pair<double, double>> damping = std::nullopt) {
            {
                std::lock_guard<std::mutex> lock(counters_mutex);
                ++counters.commits_refused;
            }
            send_error(s, id, code, "commit: ops[" + std::to_string(op) + "]: " + message, op, largest, damping);
        };
        auto find_slot = [&](std::uint32_t object_id) -> int {
            for (std::size_t i = 0; i < kSceneObjectCapacity; ++i) {
                if (proposal[i].state == ServerSlot::State::Used && proposal[i].id == object_id) return static_cast<int>(i);
            }
            return -1;
        };
        auto owned_slot = [&](std::uint32_t object_id, int op, int& slot_out) -> bool {
            const int slot = find_slot(object_id);
            if (slot < 0) {
                if (object_id >= 1 && object_id <= config.config_walls.size()) {
                    refuse(cl::ErrorCode::NotOwner, "object " + std::to_string(object_id) + " is a config-file wall, owned by the daemon", op);
                } else {
                    refuse(cl::ErrorCode::UnknownObject, "object_id = " + std::to_string(object_id) + ": no such object in the scene", op);
                }
                return false;
            }
            if (proposal[static_cast<std::size_t>(slot)].owner != s.id) {
                refuse(cl::ErrorCode::NotOwner, "object " + std::to_string(object_id) + " belongs to session " +
                                        std::to_string(proposal[static_cast<std::size_t>(slot)].owner) + ", not to this one (" +
                                        std::to_string(s.id) + ")", op);
                return false;
            }
            slot_out = slot;
            return true;
        };
        auto merge = [&](std::size_t slot, SlotUpdate::Action action, const ObjectParams& params) {
            auto& u = updates[slot];
            if (!u) {
                u = SlotUpdate{static_cast<std::uint8_t>(slot), action, params};
                return;
            }
            if (action == SlotUpdate::Action::Remove) {
                u->action = SlotUpdate::Action::Remove;
            } else if (action == SlotUpdate::Action::Set || u->action == SlotUpdate::Action::Set) {
                u->action = SlotUpdate::Action::Set;
            }
            u->params = params;
        };

        int op_index = 0;
        for (const auto& op : req.ops) {
            switch (op.kind) {
                case server::CommitOperation::Kind::Add: {
                    Resolved r;
                    if (auto refusal = resolve(*op.object, r)) {
                        refuse(refusal->code, refusal->message, op_index, refusal->largest_stable_K, refusal->damping_needed);
                        return;
                    }
                    int free_slot = -1;
                    for (std::size_t i = 0; i < kSceneObjectCapacity; ++i) {
                        if (proposal[i].state == ServerSlot::State::Free && !updates[i]) {
                            free_slot = static_cast<int>(i);
                            break;
                        }
                    }
                    if (const std::size_t held = objects_held(proposal, s.id); held >= config.session_max_objects) {
                        refuse(cl::ErrorCode::SessionLimit, "this session holds " + std::to_string(held) + " objects; accepted: at most " +
                                                    std::to_string(config.session_max_objects) +
                                                    " per session (option session-max-objects; the scene holds " +
                                                    std::to_string(kSceneObjectCapacity) + ")", op_index);
                        return;
                    }
                    if (free_slot < 0) {
                        refuse(cl::ErrorCode::Capacity, "the scene holds " + std::to_string(kSceneObjectCapacity) +
                                               " client objects (removed ones count until their ramp-out ends); remove some first", op_index);
                        return;
                    }
                    if (next_id < 1 + config.config_walls.size()) next_id = static_cast<std::uint32_t>(1 + config.config_walls.size());
                    r.params.id = next_id++;
                    ServerSlot& slot = proposal[static_cast<std::size_t>(free_slot)];
                    slot.state = ServerSlot::State::Used;
                    slot.id = r.params.id;
                    slot.owner = s.id;
                    slot.description = *op.object;
                    slot.resolved = r;
                    merge(static_cast<std::size_t>(free_slot), SlotUpdate::Action::Set, r.params);
                    new_ids.push_back(r.params.id);
                    break;
                }
                case server::CommitOperation::Kind::Modify: {
                    int slot = -1;
                    if (!owned_slot(op.object_id, op_index, slot)) return;
                    Resolved r;
                    if (auto refusal = resolve(*op.object, r)) {
                        refuse(refusal->code, refusal->message, op_index, refusal->largest_stable_K, refusal->damping_needed);
                        return;
                    }
                    ServerSlot& ss = proposal[static_cast<std::size_t>(slot)];
                    r.params.id = ss.id;
                    const bool move = is_move(ss.resolved.params, r.params);
                    ss.description = *op.object;
                    ss.resolved = r;
                    merge(static_cast<std::size_t>(slot), move ? SlotUpdate::Action::Move : SlotUpdate::Action::Set, r.params);
                    break;
                }
                case server::CommitOperation::Kind::Remove: {
                    int slot = -1;
                    if (!owned_slot(op.object_id, op_index, slot)) return;
                    ServerSlot& ss = proposal[static_cast<std::size_t>(slot)];
                    ss.state = ServerSlot::State::Draining;
                    ss.drain_seq = kNotPushed;
                    merge(static_cast<std::size_t>(slot), SlotUpdate::Action::Remove, ss.resolved.params);
                    break;
                }
                case server::CommitOperation::Kind::Clear:
                    for (std::size_t i = 0; i < kSceneObjectCapacity; ++i) {
                        ServerSlot& ss = proposal[i];
                        if (ss.state != ServerSlot::State::Used || ss.owner != s.id) continue;
                        ss.state = ServerSlot::State::Draining;
                        ss.drain_seq = kNotPushed;
                        merge(i, SlotUpdate::Action::Remove, ss.resolved.params);
                    }
                    break;
            }
            ++op_index;
        }

        // The summed stiffness of the scene that would result (every session's objects and the config walls).
        Matrix3 K_sum{}, B_unused{};
        add_config_walls(K_sum, B_unused);
        for (const auto& slot : proposal) {
            if (slot.state == ServerSlot::State::Used) add_to(K_sum, slot.resolved.K_matrix);
        }
        // The stiffness limit holds for the sum as well: the device renders it when all are in contact. Every
        // term's symmetric stiffness is positive semi-definite, so no engagement pattern's sum is stiffer.
        if (const std::optional<double> limit = checker.max_stiffness()) {
            const double largest = GainChecker::largest_stiffness(K_sum);
            if (largest > *limit) {
                {
                    std::lock_guard<std::mutex> lock(counters_mutex);
                    ++counters.commits_refused;
                }
                send_error(s, id, cl::ErrorCode::BeyondDeviceLimits,
                           "commit: the summed stiffness of the scene along its stiffest direction, " + g(largest) +
                               " N/m, exceeds the device's stiffness limit (device profile key max_stiffness = " + g(*limit) +
                               " N/m); accepted range: <= " + g(*limit) + " N/m (all objects are counted as in contact at once)",
                           -1);
                return;
            }
        }
        // Every scene the loop can render from this batch (tuning/engagement_patterns.hpp): the final scene and
        // every ramp scene, each with every engagement pattern of the conditional objects. The batch's new and
        // changed objects ramp in, the ones they replace or remove ramp out, everything else sits at its final
        // weight — exactly what the loop renders, since it starts this batch's ramps only once every earlier
        // batch's have ended (SceneObjects::apply_commits). Moves have no ramp.
        std::vector<SceneTerm> terms = config_wall_terms();
        for (std::size_t i = 0; i < kSceneObjectCapacity; ++i) {
            if (updates[i] && updates[i]->action != SlotUpdate::Action::Move) {
                if (updates[i]->action == SlotUpdate::Action::Set) terms.push_back(slot_term(proposal[i], SceneTerm::Role::In));
                if (slots[i].state == ServerSlot::State::Used) terms.push_back(slot_term(slots[i], SceneTerm::Role::Out));
            } else if (proposal[i].state == ServerSlot::State::Used) {
                terms.push_back(slot_term(proposal[i], SceneTerm::Role::Base));
            }
        }
        const double step = config.ramp_time > 0.0 ? config.period / config.ramp_time : 1.0;
        const EngagementCheck verdict = check_engagement_patterns(checker, terms, step);
        if (!verdict.stable) {
            {
                std::lock_guard<std::mutex> lock(counters_mutex);
                ++counters.commits_refused;
            }
            send_error(s, id, verdict.over_limit ? cl::ErrorCode::Capacity : cl::ErrorCode::UnstableSum, "commit: " + verdict.why + " (docs/protocol.md, section 5)", -1);
            return;
        }

        ObjectCommit c;
        for (const auto& u : updates) {
            if (u) c.updates[c.count++] = *u;
        }
        push_pending();  // older ramp-outs first, so batches reach the loop in order
        if (!pending.empty()) {
            send_error(s, id, cl::ErrorCode::Busy, "commit: the hand-over queue to the loop is full; retry", -1);
            return;
        }
        c.seq = next_commit_seq;
        if (c.count > 0 && !ring.try_push(c)) {
            send_error(s, id, cl::ErrorCode::Busy, "commit: the hand-over queue to the loop is full; retry", -1);
            return;
        }
        std::uint64_t seq = 0;
        if (c.count > 0) {
            seq = next_commit_seq++;
            commits_pushed.fetch_add(1, std::memory_order_release);
            std::lock_guard<std::mutex> lock(counters_mutex);
            ++counters.commits_pushed;
        }
        for (std::size_t i = 0; i < kSceneObjectCapacity; ++i) {
            if (proposal[i].state == ServerSlot::State::Draining && proposal[i].drain_seq == kNotPushed) proposal[i].drain_seq = seq;
        }
        slots = proposal;
        next_object_id = next_id;
        if (c.count > 0) s.in_flight.push_back(seq);
        send_reply(s, json{{"type", "ok"}, {"id", id}, {"commit_seq", seq}, {"object_ids", new_ids}});
    }

    // ---- other requests ------------------------------------------------------------------------
    json device_json() const {
        // mass: per axis a, the mass along that axis 1 / (M^-1)_aa (axes beyond the device's: axis 0's);
        // mass_matrix: M on the device's axes, row by row.
        const DeviceMass& M = checker.mass();
        json mass = json::array(), matrix = json::array();
        for (std::size_t a = 0; a < 3; ++a) mass.push_back(M.of_axis(a < config.axes ? a : 0));
        for (std::size_t i = 0; i < config.axes; ++i) {
            json row = json::array();
            for (std::size_t j = 0; j < config.axes; ++j) row.push_back(M.isotropic ? (i == j ? M.matrix[0][0] : 0.0) : M.matrix[i][j]);
            matrix.push_back(row);
        }
        const std::optional<double> limit = checker.max_stiffness();
        return json{{"name", config.device_name}, {"axes", config.axes}, {"period_s", config.period},
                    {"mass", mass}, {"mass_matrix", matrix}, {"delay_s", config.delay},
                    {"max_force", config.max_force}, {"max_stiffness", limit ? json(*limit) : json(nullptr)}};
    }

    json list_json() const {
        json objects = json::array();
        std::uint32_t wall_id = 1;
        for (const auto& w : config.config_walls) {
            cl::Plane p;
            p.normal = {0.0, 0.0, 0.0};
            p.normal[w.axis] = -w.direction;
            p.offset = -w.direction * w.position;
            p.bilateral = w.bilateral;
            p.gains = cl::Gains::explicit_gains(w.K, w.B);
            objects.push_back({{"id", wall_id++}, {"owner", 0}, {"kind", "plane"}, {"K", w.K}, {"B", w.B},
                               {"object", cl::object_to_json(p)}, {"ramping_out", false}});
        }
        for (const auto& slot : slots) {
            if (slot.state == ServerSlot::State::Free || !slot.description) continue;
            objects.push_back({{"id", slot.id}, {"owner", slot.owner}, {"kind", cl::kind_name(*slot.description)},
                               {"K", slot.resolved.params.K}, {"B", slot.resolved.params.B},
                               {"object", cl::object_to_json(*slot.description)},
                               {"ramping_out", slot.state == ServerSlot::State::Draining}});
        }
        return objects;
    }

    static const char* fault_name(std::uint32_t f) { return to_string(static_cast<StateFault>(f)); }

    void handle_message(Session& s, std::string_view bytes) {
        s.last_rx = Clock::now();
        const server::DecodeResult result = server::decode_message(bytes, !s.welcomed);
        if (const auto* e = std::get_if<server::DecodeError>(&result)) {
            if (e->code == cl::ErrorCode::ProtocolVersion) {
                send_reply(s, json{{"type", "refused"}, {"code", cl::to_string(e->code)}, {"server_protocol", server::kServerProtocol},
                                   {"client_protocol", e->client_protocol}, {"message", e->message}});
                close_session(s, "refused: " + cl::escape_for_log(e->message, 256));
            } else if (e->code == cl::ErrorCode::BadHello) {
                send_reply(s, json{{"type", "refused"}, {"code", cl::to_string(e->code)}, {"server_protocol", server::kServerProtocol}, {"message", e->message}});
                close_session(s, "refused: " + cl::escape_for_log(e->message, 256));
            } else {
                send_error(s, e->id, e->code, e->message, e->op_index);
                if (e->code == cl::ErrorCode::Oversized) close_session(s, "oversized message");
            }
            return;
        }
        const auto& req = std::get<server::Request>(result);
        if (const auto* hello = std::get_if<server::HelloRequest>(&req.body)) {
            s.welcomed = true;
            s.name = cl::escape_for_log(hello->client, 64);  // only ever logged: one line, no control bytes
            s.lease_s = hello->lease_s;
            log("session " + std::to_string(s.id) + " is '" + s.name + "', lease " + g(s.lease_s) + " s");
            send_reply(s, json{{"type", "welcome"}, {"protocol", server::kServerProtocol}, {"session", s.id}, {"lease_s", s.lease_s},
                               {"max_message_bytes", cl::kMaxMessageBytes}, {"capacity", kSceneObjectCapacity},
                               {"state_shm", state.name()}, {"ramp_s", config.ramp_time}, {"max_force_rate", config.max_force_rate},
                               {"device", device_json()}});
            return;
        }
        const std::uint64_t id = *req.id;
        std::visit(
            [&](const auto& body) {
                using T = std::decay_t<decltype(body)>;
                if constexpr (std::is_same_v<T, server::HeartbeatRequest>) {
                    state.read(snapshot);
                    send_reply(s, json{{"type", "ok"}, {"id", id}, {"tick", snapshot.tick}});
                } else if constexpr (std::is_same_v<T, server::CommitRequest>) {
                    handle_commit(s, id, body);
                } else if constexpr (std::is_same_v<T, server::ListRequest>) {
                    send_reply(s, json{{"type", "ok"}, {"id", id}, {"objects", list_json()}});
                } else if constexpr (std::is_same_v<T, server::StatusRequest>) {
                    state.read(snapshot);
                    std::size_t n = config.config_walls.size();
                    for (const auto& slot : slots) n += slot.state != ServerSlot::State::Free ? 1U : 0U;
                    send_reply(s, json{{"type", "ok"}, {"id", id}, {"tick", snapshot.tick}, {"sessions", sessions.size()},
                                       {"objects", n}, {"overruns", snapshot.overruns}, {"fault", fault_name(snapshot.fault)},
                                       {"commits_applied", snapshot.last_commit_seq}});
                } else if constexpr (std::is_same_v<T, server::SubscribeRequest>) {
                    s.subscribed = true;
                    s.rate_hz = body.rate_hz;
                    s.next_state = Clock::now();
                    send_reply(s, json{{"type", "ok"}, {"id", id}});
                } else if constexpr (std::is_same_v<T, server::UnsubscribeRequest>) {
                    s.subscribed = false;
                    send_reply(s, json{{"type", "ok"}, {"id", id}});
                } else if constexpr (std::is_same_v<T, server::SubscribeContactsRequest>) {
                    subscribe_contacts(s, id, body);
                } else if constexpr (std::is_same_v<T, server::UnsubscribeContactsRequest>) {
                    s.contacts = false;
                    s.contact_queue.clear();
                    send_reply(s, json{{"type", "ok"}, {"id", id}});
                } else if constexpr (std::is_same_v<T, server::ByeRequest>) {
                    send_reply(s, json{{"type", "ok"}, {"id", id}});
                    close_session(s, "bye");
                } else {
                    send_error(s, id, cl::ErrorCode::BadMessage, "hello: already welcomed");
                }
            },
            req.body);
    }

    static bool peer_hung_up(int fd) {
        pollfd p{fd, POLLRDHUP, 0};
        const int r = ::poll(&p, 1, 0);
        return r < 0 || (r > 0 && (p.revents & (POLLRDHUP | POLLHUP | POLLERR)) != 0);
    }

    // The last resort: whatever escapes a request's handling is answered `internal` and logged; the session
    // and the daemon go on.
    void handle_guarded(Session& s, std::string_view bytes) {
        try {
            handle_message(s, bytes);
        } catch (const std::exception& e) {
            internal_error(s, e.what());
        } catch (...) {
            internal_error(s, "an unknown exception");
        }
    }

    void internal_error(Session& s, const char* what) noexcept {
        try {
            log("session " + std::to_string(s.id) + ": internal error while handling a request: " + cl::escape_for_log(what, 256));
            send_error(s, std::nullopt, cl::ErrorCode::Internal, std::string("Server: internal error while handling the request (") +
                                                         cl::truncate_utf8(what, 256) + "); the session goes on");
        } catch (...) {
        }
    }

    void read_session(Session& s) {
        for (int i = 0; i < kMessagesPerRound && !s.closed; ++i) {
            const ssize_t n = ::recv(s.fd, buffer.data(), buffer.size(), MSG_DONTWAIT);
            if (n < 0) {
                if (errno == EAGAIN || errno == EWOULDBLOCK || errno == EINTR) return;
                close_session(s, std::string("recv failed: ") + std::strerror(errno));
                return;
            }
            // SOCK_SEQPACKET: 0 is both an empty message and the end of the stream; the peer has hung up
            // only in the second case.
            if (n == 0 && peer_hung_up(s.fd)) {
                close_session(s, "disconnected (EOF)");
                return;
            }
            handle_guarded(s, std::string_view(buffer.data(), static_cast<std::size_t>(n)));
            close_departed_sessions();
        }
    }

    // Closes every session whose peer has gone, ahead of the messages still waiting on the others: a
    // request's checks take milliseconds (tens on a loaded machine), so a departure noticed only at the next
    // poll would wait behind every message of the round. One zero-timeout poll over the open sessions.
    void close_departed_sessions() {
        departed_fds.clear();
        departed_ids.clear();
        for (auto& [sid, other] : sessions) {
            if (other.closed) continue;
            departed_fds.push_back({other.fd, POLLRDHUP, 0});
            departed_ids.push_back(sid);
        }
        if (departed_fds.empty() || ::poll(departed_fds.data(), departed_fds.size(), 0) <= 0) return;
        for (std::size_t i = 0; i < departed_fds.size(); ++i) {
            if ((departed_fds[i].revents & (POLLRDHUP | POLLHUP | POLLERR)) == 0) continue;
            Session& other = sessions.at(departed_ids[i]);
            close_session(other, "disconnected (EOF)");
        }
    }

    void send_states(Clock::time_point now) {
        bool have = false;
        for (auto& [sid, s] : sessions) {
            // A state never overtakes a contact event: while contact messages wait for room, states wait too.
            if (s.closed || !s.subscribed || now < s.next_state || !s.contact_queue.empty()) continue;
            if (!have) {
                state.read(snapshot);
                have = true;
            }
            s.next_state += std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(1.0 / s.rate_hz));
            if (s.next_state < now) s.next_state = now;  // never send bursts to catch up
            json contact = json::array();
            for (std::uint32_t i = 0; i < 64; ++i) {
                if ((snapshot.config_contact_mask >> i) & 1U) contact.push_back(i + 1);  // config wall ids 1 .. n
            }
            for (std::size_t i = 0; i < kSceneObjectCapacity; ++i) {
                if (((snapshot.contact_mask >> i) & 1U) != 0U && snapshot.slot_object_id[i] != 0) contact.push_back(snapshot.slot_object_id[i]);
            }
            const std::string text =
                json{{"type", "state"}, {"tick", snapshot.tick}, {"time_s", snapshot.time_s},
                     {"position", json::array({snapshot.position[0], snapshot.position[1], snapshot.position[2]})},
                     {"velocity", json::array({snapshot.velocity[0], snapshot.velocity[1], snapshot.velocity[2]})},
                     {"force", json::array({snapshot.force[0], snapshot.force[1], snapshot.force[2]})},
                     {"contact", contact}, {"contact_mask", snapshot.contact_mask},
                     {"config_contact_mask", snapshot.config_contact_mask}, {"overruns", snapshot.overruns},
                     {"wake_latency_ns", snapshot.wake_latency_ns}, {"last_commit_seq", snapshot.last_commit_seq},
                     {"objects", snapshot.objects}, {"fault", fault_name(snapshot.fault)}, {"dropped", s.dropped}}
                    .dump();
            const ssize_t n = ::send(s.fd, text.data(), text.size(), MSG_DONTWAIT | MSG_NOSIGNAL);
            if (n < 0) {
                if (errno == EAGAIN || errno == EWOULDBLOCK) {
                    ++s.dropped;
                    std::lock_guard<std::mutex> lock(counters_mutex);
                    ++counters.states_dropped;
                } else {
                    close_session(s, std::string("send failed: ") + std::strerror(errno));
                }
            }
        }
    }

    // ---- contact events ------------------------------------------------------------------------
    // Takes every record the loop has handed over (at most a ring's worth), in tick order, and queues one
    // message per record for each contact subscriber whose filter admits the object; then sends what fits.
    // Records the loop could not hand over (lost_before rose) count as dropped for every subscriber.
    void drain_contacts() {
        if (contact_ring == nullptr) return;
        ContactRecord r;
        std::uint64_t lost_total = 0, dropped_total = 0;
        for (std::size_t n = 0; n < contact_ring->capacity() && contact_ring->try_pop(r); ++n) {
            const std::uint64_t lost = r.lost_before - contact_lost_seen;
            contact_lost_seen = r.lost_before;
            lost_total += lost;
            const auto it = std::lower_bound(in_contact.begin(), in_contact.end(), r.object_id);
            const bool present = it != in_contact.end() && *it == r.object_id;
            if (r.begin && !present) in_contact.insert(it, r.object_id);
            if (!r.begin && present) in_contact.erase(it);
            std::optional<json> message;
            for (auto& [sid, s] : sessions) {
                if (s.closed || !s.contacts) continue;
                s.contact_dropped += lost;
                if (s.contact_filter && std::find(s.contact_filter->begin(), s.contact_filter->end(), r.object_id) == s.contact_filter->end()) {
                    continue;
                }
                if (s.contact_queue.size() >= kContactQueueCapacity) {
                    ++s.contact_dropped;
                    ++dropped_total;
                    continue;
                }
                if (!message) {
                    message = json{{"type", "contact"}, {"event", r.begin ? "begin" : "end"}, {"object_id", r.object_id},
                                   {"tick", r.tick}, {"time_s", r.time_s},
                                   {"position", json::array({r.position[0], r.position[1], r.position[2]})},
                                   {"force", json::array({r.force[0], r.force[1], r.force[2]})}};
                }
                (*message)["dropped"] = s.contact_dropped;
                s.contact_queue.push_back(message->dump());
            }
        }
        if (lost_total != 0 || dropped_total != 0) {
            std::lock_guard<std::mutex> lock(counters_mutex);
            counters.contacts_lost += lost_total;
            counters.contacts_dropped += dropped_total;
        }
        for (auto& [sid, s] : sessions) flush_contacts(s);
    }

    // Sends a session's waiting contact messages in order until its socket is full (the rest wait for the
    // next round); never blocks.
    void flush_contacts(Session& s) {
        while (!s.closed && !s.contact_queue.empty()) {
            const std::string& text = s.contact_queue.front();
            const ssize_t n = ::send(s.fd, text.data(), text.size(), MSG_DONTWAIT | MSG_NOSIGNAL);
            if (n < 0) {
                if (errno == EAGAIN || errno == EWOULDBLOCK) return;
                close_session(s, std::string("send failed: ") + std::strerror(errno));
                return;
            }
            s.contact_queue.pop_front();
        }
    }

    void subscribe_contacts(Session& s, std::uint64_t id, const server::SubscribeContactsRequest& req) {
        drain_contacts();  // what happened before this reply goes to the earlier subscribers only
        s.contacts = true;
        s.contact_filter = req.object_ids;
        s.contact_queue.clear();
        s.contact_dropped = 0;
        json ids = json::array();
        for (const std::uint32_t oid : in_contact) {
            if (!s.contact_filter || std::find(s.contact_filter->begin(), s.contact_filter->end(), oid) != s.contact_filter->end()) {
                ids.push_back(oid);
            }
        }
        send_reply(s, json{{"type", "ok"}, {"id", id}, {"contacts", ids}});
    }

    void reclaim_slots() {
        state.read(snapshot);
        for (std::size_t i = 0; i < kSceneObjectCapacity; ++i) {
            ServerSlot& slot = slots[i];
            if (slot.state != ServerSlot::State::Draining || slot.drain_seq == kNotPushed) continue;
            if (snapshot.last_commit_seq >= slot.drain_seq && snapshot.slot_object_id[i] == 0) slot = ServerSlot{};
        }
    }

    // run() again after anything that escaped a round outside a request (logged): the server thread never
    // ends by an exception while the daemon runs.
    void run_guarded() noexcept {
        while (!stop.load(std::memory_order_acquire)) {
            try {
                run();
                return;
            } catch (const std::exception& e) {
                try {
                    log(std::string("internal error in the server loop (it goes on): ") + cl::escape_for_log(e.what(), 256));
                } catch (...) {
                }
            } catch (...) {
            }
        }
    }

    void run() {
        std::vector<pollfd> fds;
        std::vector<std::uint64_t> ids;
        while (!stop.load(std::memory_order_acquire)) {
            fds.clear();
            ids.clear();
            fds.push_back({listen_fd, POLLIN, 0});
            fds.push_back({wake_fd, POLLIN, 0});
            for (auto& [sid, s] : sessions) {
                fds.push_back({s.fd, POLLIN, 0});
                ids.push_back(sid);
            }
            const int r = ::poll(fds.data(), fds.size(), 1);  // 1 ms: leases, subscriptions, slot reclaim
            if (r < 0 && errno != EINTR) {
                log(std::string("poll failed: ") + std::strerror(errno));
                return;
            }
            if (stop.load(std::memory_order_acquire)) break;
            if (r > 0) {
                if ((fds[0].revents & POLLIN) != 0) accept_all();
                close_departed_sessions();
                for (std::size_t i = 0; i < ids.size(); ++i) {
                    const short ev = fds[i + 2].revents;
                    if (ev == 0) continue;
                    Session& s = sessions.at(ids[i]);
                    if ((ev & POLLIN) != 0) read_session(s);
                    if (!s.closed && (ev & (POLLHUP | POLLERR)) != 0 && (ev & POLLIN) == 0) close_session(s, "hung up");
                }
            }
            const auto now = Clock::now();
            for (auto& [sid, s] : sessions) {
                if (!s.closed && !s.welcomed && now - s.last_rx > std::chrono::seconds(kHelloTimeoutS)) {
                    const std::string text = json{{"type", "refused"}, {"code", cl::to_string(cl::ErrorCode::BadHello)}, {"server_protocol", server::kServerProtocol},
                                                  {"message", "Server: no hello within " + std::to_string(kHelloTimeoutS) + " s"}}
                                                 .dump();
                    (void)::send(s.fd, text.data(), text.size(), MSG_DONTWAIT | MSG_NOSIGNAL);
                    close_session(s, "no hello within " + std::to_string(kHelloTimeoutS) + " s");
                }
                if (s.closed || s.lease_s <= 0.0) continue;
                if (now - s.last_rx > std::chrono::duration<double>(s.lease_s)) {
                    const std::string text = json{{"type", "expired"}, {"code", cl::to_string(cl::ErrorCode::LeaseLost)},
                                                  {"message", "lease: no message for " + g(s.lease_s) + " s; the session's objects ramp out"}}
                                                 .dump();
                    (void)::send(s.fd, text.data(), text.size(), MSG_DONTWAIT | MSG_NOSIGNAL);
                    close_session(s, "lease lost (no message for " + g(s.lease_s) + " s)");
                }
            }
            drain_contacts();
            send_states(now);
            push_pending();
            reclaim_slots();
            for (auto it = sessions.begin(); it != sessions.end();) {
                it = it->second.closed ? sessions.erase(it) : std::next(it);
            }
        }
        for (auto& [sid, s] : sessions) close_session(s, "server stopping");
        sessions.clear();
    }
};

std::string config_walls_unstable(const GainChecker& checker, const std::vector<ConfigWallInfo>& walls) {
    const EngagementCheck verdict = check_engagement_patterns(checker, terms_of_config_walls(walls), 1.0, PatternLimit::None);
    return verdict.stable ? std::string() : verdict.why;
}

Server::Server(const ServerConfig& config, GainChecker& checker, CommitRing& ring, const StatePublisher& state, CommitRing* departures,
               ContactRing* contacts)
    : impl_(std::make_unique<Impl>(config, checker, ring, departures, state, commits_pushed_, contacts)) {
    impl_->open_socket();
    impl_->log("listening on " + impl_->config.socket_path + " (mode 0" +
               [&] {
                   std::ostringstream o;
                   o << std::oct << impl_->config.socket_mode;
                   return o.str();
               }() +
               "), state in shared memory " + state.name());
}

Server::~Server() {
    stop();
    if (impl_->listen_fd >= 0) ::close(impl_->listen_fd);
    if (impl_->wake_fd >= 0) ::close(impl_->wake_fd);
    ::unlink(impl_->config.socket_path.c_str());
}

void Server::start() {
    if (thread_.joinable()) return;
    impl_->stop.store(false, std::memory_order_release);
    thread_ = std::thread([this] { impl_->run_guarded(); });
}

void Server::stop() {
    if (!thread_.joinable()) return;
    impl_->stop.store(true, std::memory_order_release);
    const std::uint64_t one = 1;
    (void)::write(impl_->wake_fd, &one, sizeof(one));
    thread_.join();
}

const std::string& Server::socket_path() const noexcept { return impl_->config.socket_path; }

ServerCounters Server::counters() const {
    std::lock_guard<std::mutex> lock(impl_->counters_mutex);
    return impl_->counters;
}

}  // namespace hapticd
