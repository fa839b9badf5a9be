// SPDX-License-Identifier: Apache-2.0
// The server thread: one poll loop over the listening socket and the sessions (server/sessions.hpp), each
// request decoded (server/message_decoder.hpp) and answered (server/replies.hpp); commits planned by the
// commit transaction (server/commit_transaction.hpp) and handed whole to the loop's ring; a departed
// session's objects ramped out by the departure rule (server/departure_plan.hpp); state and contact messages
// sent to the sessions that subscribe.
#include "server/server.hpp"

#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cstring>
#include <deque>
#include <iostream>
#include <map>
#include <mutex>
#include <optional>
#include <sstream>
#include <stdexcept>
#include <string_view>
#include <variant>

#include <nlohmann/json.hpp>

#include "client/text_limits.hpp"
#include "server/commit_transaction.hpp"
#include "server/departure_plan.hpp"
#include "server/mesh_store.hpp"
#include "server/message_decoder.hpp"
#include "server/object_limits.hpp"
#include "server/object_resolution.hpp"
#include "server/replies.hpp"
#include "server/reply_text.hpp"
#include "server/sessions.hpp"
#include "server/state_publisher.hpp"
#include "tuning/engagement_patterns.hpp"
#include "tuning/object_checks.hpp"

namespace hapticd {

namespace {

using nlohmann::json;
using server::Clock;
using server::ServerSlot;
using server::Session;
namespace cl = hapticd::client;

constexpr int kMessagesPerRound = 16;

std::string g(double v) { return server::short_number(v); }

}  // namespace

struct Server::Impl {
    Impl(const ServerConfig& c, GainChecker& k, CommitRing& r, CommitRing* d, const StatePublisher& s,
         std::atomic<std::uint64_t>& pushed, ContactRing* contacts)
        : config(c),
          checker(k),
          resolver(config, k),
          ring(r),
          departure_ring(d != nullptr ? *d : r),
          state(s),
          commits_pushed(pushed),
          contact_ring(contacts),
          meshes(server::MeshStoreLimits{.upload_timeout = std::chrono::milliseconds(
                                             static_cast<long>(config.mesh_upload_timeout * 1000.0 + 0.5))}) {}

    ServerConfig config;
    GainChecker& checker;
    server::ObjectResolver resolver;  // reads `config` and `checker`
    CommitRing& ring;
    CommitRing& departure_ring;  // `ring` itself when the loop has no departure ring
    const StatePublisher& state;
    std::atomic<std::uint64_t>& commits_pushed;
    ContactRing* contact_ring;              // may be null: no contact events
    std::uint64_t contact_lost_seen = 0;    // the lost_before of the last record taken
    std::vector<std::uint32_t> in_contact;  // ascending: the objects in contact after the last record taken
    server::ListeningSocket socket;
    server::ListeningSocket stream_socket;  // listen_fd -1: no stream socket
    std::atomic<bool> stop{false};
    std::map<std::uint64_t, Session> sessions;
    server::SlotTable slots{};
    std::deque<ObjectCommit> pending;  // departure batches that did not fit in the departure ring yet
    server::DepartureDetector departures;
    std::uint32_t next_object_id = 1;
    std::uint64_t next_session_id = 1;
    std::uint64_t next_commit_seq = 1;
    mutable std::mutex counters_mutex;
    ServerCounters counters;
    std::vector<char> buffer = std::vector<char>(cl::kMaxMessageBytes + 1);
    StateLayout snapshot{};
    server::MeshStore meshes;  // the sessions' meshes (docs/protocol.md, section 4a); its worker builds hierarchies
    // Hierarchies a modify replaced while the loop may still fade the old object out: freed once the batch is
    // applied (last_commit_seq) and a ramp's ticks more have passed (the fade ends within ramp_s of it).
    struct Retired {
        std::shared_ptr<const mesh::MeshHierarchy> mesh;
        std::uint64_t seq = 0;
        std::uint64_t applied_tick = 0;  // 0: not yet seen applied
    };
    std::vector<Retired> retired;

    void log(const std::string& line) const {
        if (config.log_connections) std::cerr << "hapticd: server: " << line << "\n";
    }

    void count(std::uint64_t ServerCounters::*counter, std::uint64_t n = 1) {
        std::lock_guard<std::mutex> lock(counters_mutex);
        counters.*counter += n;
    }

    void open_socket() {
        if (config.socket_path.empty()) config.socket_path = default_server_socket_path();
        if (config.stream_socket_path.empty()) config.stream_socket_path = stream_socket_path_for(config.socket_path);
        if (config.stream_socket_path == "none") config.stream_socket_path.clear();
        socket = server::open_listening_socket(config.socket_path, config.socket_mode, config.socket_gid,
                                               SOCK_SEQPACKET, true);
        if (config.stream_socket_path.empty()) return;
        try {
            stream_socket = server::open_listening_socket(config.stream_socket_path, config.socket_mode,
                                                          config.socket_gid, SOCK_STREAM, false);
        } catch (...) {
            ::close(socket.listen_fd);
            ::close(socket.wake_fd);
            ::unlink(config.socket_path.c_str());
            throw;
        }
    }

    // ---- sending -------------------------------------------------------------------------------
    // Replies: a full socket means the client does not read -> disconnect (never block).
    void send_reply(Session& s, json message) {
        if (s.closed) return;
        switch (server::send_to(s, server::reply_text(std::move(message)))) {
            case server::SendResult::Sent:
                return;
            case server::SendResult::Full:
                close_session(s, std::string(cl::to_string(cl::ErrorCode::SlowConsumer)) +
                                     " (a reply did not fit: the client does not read)");
                return;
            case server::SendResult::Failed:
                close_session(s, std::string("send failed: ") + std::strerror(errno));
                return;
        }
    }

    void send_error(Session& s, std::optional<std::uint64_t> id, cl::ErrorCode code, const std::string& message,
                    int op_index = -1, std::optional<double> largest = std::nullopt,
                    std::optional<std::pair<double, double>> damping = std::nullopt) {
        send_reply(s, server::error_reply(id, code, message, op_index, largest, damping));
    }

    // ---- sessions ------------------------------------------------------------------------------
    void accept_all(int listen_fd, bool stream) {
        while (const std::optional<server::Peer> peer = server::accept_peer(listen_fd)) {
            if (sessions.size() >= server::kMaxSessions) {
                (void)server::send_message(
                    peer->fd,
                    server::refused_reply(cl::ErrorCode::Capacity,
                                          "Server: " + std::to_string(server::kMaxSessions) + " sessions already open")
                            .dump() +
                        (stream ? "\n" : ""));
                ::close(peer->fd);
                continue;
            }
            Session s;
            s.fd = peer->fd;
            s.id = next_session_id++;
            s.pid = peer->pid;
            s.uid = peer->uid;
            s.gid = peer->gid;
            s.last_rx = Clock::now();
            s.stream = stream;
            log("session " + std::to_string(s.id) + " connected" + (stream ? " (stream socket)" : "") + ": pid " +
                std::to_string(s.pid) + ", uid " + std::to_string(s.uid) + ", gid " + std::to_string(s.gid));
            sessions.emplace(s.id, s);
            count(&ServerCounters::sessions_opened);
        }
    }

    void close_session(Session& s, const std::string& why) {
        if (s.closed) return;
        s.closed = true;
        ::close(s.fd);
        s.fd = -1;
        ramp_out_objects_of(s.id);
        meshes.drop_session(s.id);
        log("session " + std::to_string(s.id) + " (" + (s.name.empty() ? "unnamed" : s.name) + ", pid " +
            std::to_string(s.pid) + ", uid " + std::to_string(s.uid) + ") closed: " + why);
        count(&ServerCounters::sessions_closed);
    }

    // Closes every session whose peer has gone, ahead of the messages still waiting on the others: a
    // request's checks take milliseconds (tens on a loaded machine), so a departure noticed only at the next
    // poll would wait behind every message of the round.
    void close_departed_sessions() {
        departures.clear();
        for (auto& [sid, other] : sessions) {
            if (!other.closed) departures.watch(other.fd, sid, other.stream);
        }
        for (const std::uint64_t sid : departures.departed()) close_session(sessions.at(sid), "disconnected (EOF)");
    }

    // The hello timeout and the leases: a silent session is told why and closed.
    void close_silent_sessions(Clock::time_point now) {
        for (auto& [sid, s] : sessions) {
            switch (server::silence_of(s, now)) {
                case server::Silence::None:
                    break;
                case server::Silence::NoHello:
                    (void)server::send_to(
                        s, server::refused_hello_reply(
                               cl::ErrorCode::BadHello,
                               "Server: no hello within " + std::to_string(server::kHelloTimeoutS) + " s")
                               .dump());
                    close_session(s, "no hello within " + std::to_string(server::kHelloTimeoutS) + " s");
                    break;
                case server::Silence::LeaseLost:
                    (void)server::send_to(s, server::lease_expired_message("lease: no message for " + g(s.lease_s) +
                                                                           " s; the session's objects ramp out")
                                                 .dump());
                    close_session(s, "lease lost (no message for " + g(s.lease_s) + " s)");
                    break;
            }
        }
    }

    // ---- departures ----------------------------------------------------------------------------
    // A session's objects ramp out by the departure rule (departure_plan.hpp, docs/protocol.md section 5):
    // with them, if the scene they leave or a ramp scene would be unstable, the fewest further client
    // objects (or all of them, or all cut at once); the owners of those get an event with the reason.
    void ramp_out_objects_of(std::uint64_t session) {
        std::vector<DepartureObject> leaving, staying;
        for (std::size_t i = 0; i < kSceneObjectCapacity; ++i) {
            const ServerSlot& slot = slots[i];
            if (slot.state != ServerSlot::State::Used) continue;
            (slot.owner == session ? leaving : staying)
                .push_back(DepartureObject{i, slot.owner, server::slot_term(slot, SceneTerm::Role::Base)});
        }
        if (leaving.empty()) return;
        const double step = config.ramp_time > 0.0 ? config.period / config.ramp_time : 1.0;
        const DeparturePlan plan =
            plan_departure(checker, server::terms_of_config_walls(config.config_walls), leaving, staying, step);
        ObjectCommit c;
        std::map<std::uint64_t, std::vector<std::uint32_t>> further_by_owner;
        for (const std::size_t i : plan.out) {
            ServerSlot& slot = slots[i];
            if (slot.owner != session) further_by_owner[slot.owner].push_back(slot.id);
            slot.state = ServerSlot::State::Draining;
            slot.drain_seq = server::kNotPushed;
            SlotUpdate& u = c.updates[c.count++];
            u.slot = static_cast<std::uint8_t>(i);
            u.action = plan.cut ? SlotUpdate::Action::Cut : SlotUpdate::Action::Remove;
            u.params = slot.resolved.params;
        }
        pending.push_back(c);  // before the events: a send may close another session, whose batch must follow
        push_pending();
        if (!plan.further.empty()) {
            const std::string how =
                plan.cut ? "removed at once (no ramp-out of them all is stable either)" : "ramped out with them";
            log("session " + std::to_string(session) + " left; " + std::to_string(plan.further.size()) +
                " objects of other sessions " + how + ": " + plan.reason);
            for (const auto& [owner, ids] : further_by_owner) {
                const auto it = sessions.find(owner);
                if (it == sessions.end() || it->second.closed) continue;
                send_reply(it->second, server::objects_removed_event(
                                           ids, "objects " + json(ids).dump() + " are " + how + " because session " +
                                                    std::to_string(session) + " left and, without them, " +
                                                    plan.reason + " (docs/protocol.md, section 5)"));
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
            count(&ServerCounters::commits_pushed);
            pending.pop_front();
        }
    }

    void reclaim_slots() {
        state.read(snapshot);
        for (std::size_t i = 0; i < kSceneObjectCapacity; ++i) {
            ServerSlot& slot = slots[i];
            if (slot.state != ServerSlot::State::Draining || slot.drain_seq == server::kNotPushed) continue;
            if (snapshot.last_commit_seq >= slot.drain_seq && snapshot.slot_object_id[i] == 0) slot = ServerSlot{};
        }
        const auto ramp_ticks = static_cast<std::uint64_t>(std::ceil(config.ramp_time / config.period)) + 2;
        for (Retired& r : retired) {
            if (r.applied_tick == 0 && snapshot.last_commit_seq >= r.seq) r.applied_tick = snapshot.tick + 1;
        }
        std::erase_if(retired, [&](const Retired& r) {
            return r.applied_tick != 0 && snapshot.tick >= r.applied_tick + ramp_ticks;
        });
    }

    // ---- commit --------------------------------------------------------------------------------
    // Per-session limit (docs/protocol.md, section 7): one session may not fill the hand-over ring.
    bool refuse_over_in_flight_limit(Session& s, std::uint64_t id) {
        state.read(snapshot);
        while (!s.in_flight.empty() && s.in_flight.front() <= snapshot.last_commit_seq) s.in_flight.pop_front();
        if (s.in_flight.size() < config.session_max_in_flight) return false;
        count(&ServerCounters::commits_refused);
        send_error(s, id, cl::ErrorCode::SessionLimit,
                   "commit: this session has " + std::to_string(s.in_flight.size()) +
                       " batches handed to the loop and not yet applied (the loop has applied up to commit_seq " +
                       std::to_string(snapshot.last_commit_seq) + "); accepted: at most " +
                       std::to_string(config.session_max_in_flight) +
                       " in flight per session (option session-max-in-flight); retry when commit_seq " +
                       std::to_string(s.in_flight.front()) + " is applied",
                   -1);
        return true;
    }

    // The batch planned (all-or-nothing), handed to the loop behind the waiting departures, and adopted once
    // it is in the ring; busy when the ring has no room (nothing changes). A ring already full, or departures
    // still waiting for it, answer busy before the batch is planned: a busy server does not spend the checks.
    void handle_commit(Session& s, std::uint64_t id, const server::CommitRequest& req) {
        if (refuse_over_in_flight_limit(s, id)) return;
        push_pending();
        if (!pending.empty() || (!req.ops.empty() && ring.full())) {
            send_error(s, id, cl::ErrorCode::Busy, "commit: the hand-over queue to the loop is full; retry", -1);
            return;
        }
        const server::MeshLookup lookup = [&](std::uint32_t mesh) {
            server::MeshLookupResult out;
            auto found = meshes.built(s.id, mesh);
            if (auto* r = std::get_if<server::Refusal>(&found)) {
                out.refusal = std::move(*r);
            } else {
                out.hierarchy = std::get<server::MeshStore::Built>(found).hierarchy;
            }
            return out;
        };
        server::CommitOutcome outcome = server::plan_commit(server::CommitContext{config, checker, resolver, &lookup},
                                                            slots, s.id, next_object_id, req);
        if (const auto* r = std::get_if<server::CommitRefusal>(&outcome)) {
            count(&ServerCounters::commits_refused);
            send_error(s, id, r->refusal.code, r->refusal.message, r->op_index, r->refusal.largest_stable_K,
                       r->refusal.damping_needed);
            return;
        }
        server::CommitPlan& plan = std::get<server::CommitPlan>(outcome);
        ObjectCommit& c = plan.batch;
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
            count(&ServerCounters::commits_pushed);
        }
        for (ServerSlot& slot : plan.slots) {
            if (slot.state == ServerSlot::State::Draining && slot.drain_seq == server::kNotPushed) slot.drain_seq = seq;
        }
        for (std::size_t i = 0; i < kSceneObjectCapacity; ++i) {  // a modify that replaced a mesh object's hierarchy
            if (slots[i].resolved.mesh && slots[i].resolved.mesh != plan.slots[i].resolved.mesh) {
                retired.push_back(Retired{slots[i].resolved.mesh, seq, 0});
            }
        }
        slots = plan.slots;
        next_object_id = plan.next_object_id;
        if (c.count > 0) s.in_flight.push_back(seq);
        json ok = server::ok_reply(id);
        ok["commit_seq"] = seq;
        ok["object_ids"] = plan.new_ids;
        send_reply(s, ok);
    }

    // ---- meshes (docs/protocol.md, section 4a) ---------------------------------------------------
    void send_refusal(Session& s, std::uint64_t id, const server::Refusal& r) { send_error(s, id, r.code, r.message); }

    json mesh_info_reply(std::uint64_t id, std::uint32_t mesh, const server::MeshInfo& info) {
        json ok = server::ok_reply(id);
        ok["mesh"] = mesh;
        ok["state"] = server::to_string(info.state);
        ok["vertices"] = info.received_vertices;
        ok["triangles"] = info.received_triangles;
        ok["bytes"] = info.bytes;
        if (!info.message.empty()) ok["message"] = cl::truncate_utf8(info.message, 1024);
        return ok;
    }

    template <class Request>
    void handle_mesh(Session& s, std::uint64_t id, const Request& body) {
        const auto now = Clock::now();
        meshes.collect();
        meshes.expire(now);
        if constexpr (std::is_same_v<Request, server::MeshBeginRequest>) {
            auto r = meshes.begin(s.id, body, now);
            if (const auto* refusal = std::get_if<server::Refusal>(&r)) return send_refusal(s, id, *refusal);
            json ok = server::ok_reply(id);
            ok["mesh"] = std::get<std::uint32_t>(r);
            send_reply(s, ok);
        } else if constexpr (std::is_same_v<Request, server::MeshChunkRequest>) {
            if (auto refusal = meshes.chunk(s.id, body, now)) return send_refusal(s, id, *refusal);
            auto info = meshes.status(s.id, body.mesh);
            send_reply(s, mesh_info_reply(id, body.mesh, std::get<server::MeshInfo>(info)));
        } else if constexpr (std::is_same_v<Request, server::MeshEndRequest>) {
            if (auto refusal = meshes.end(s.id, body.mesh)) return send_refusal(s, id, *refusal);
            auto info = meshes.status(s.id, body.mesh);
            send_reply(s, mesh_info_reply(id, body.mesh, std::get<server::MeshInfo>(info)));
        } else if constexpr (std::is_same_v<Request, server::MeshStatusRequest>) {
            auto info = meshes.status(s.id, body.mesh);
            if (const auto* refusal = std::get_if<server::Refusal>(&info)) return send_refusal(s, id, *refusal);
            send_reply(s, mesh_info_reply(id, body.mesh, std::get<server::MeshInfo>(info)));
        } else {
            if (auto refusal = meshes.remove(s.id, body.mesh)) return send_refusal(s, id, *refusal);
            send_reply(s, server::ok_reply(id));
        }
    }

    // ---- requests ------------------------------------------------------------------------------
    void handle_decode_error(Session& s, const server::DecodeError& e) {
        if (e.code == cl::ErrorCode::ProtocolVersion || e.code == cl::ErrorCode::BadHello) {
            const std::optional<int> client_protocol =
                e.code == cl::ErrorCode::ProtocolVersion ? std::optional<int>(e.client_protocol) : std::nullopt;
            send_reply(s, server::refused_hello_reply(e.code, e.message, client_protocol));
            close_session(s, "refused: " + cl::escape_for_log(e.message, 256));
            return;
        }
        send_error(s, e.id, e.code, e.message, e.op_index);
        if (e.code == cl::ErrorCode::Oversized) close_session(s, "oversized message");
    }

    void handle_hello(Session& s, const server::HelloRequest& hello) {
        s.welcomed = true;
        s.name = cl::escape_for_log(hello.client, 64);  // only ever logged: one line, no control bytes
        s.lease_s = hello.lease_s;
        log("session " + std::to_string(s.id) + " is '" + s.name + "', lease " + g(s.lease_s) + " s");
        send_reply(s, server::welcome_reply(config, checker, s.id, s.lease_s, state.name()));
    }

    void handle_message(Session& s, std::string_view bytes) {
        s.last_rx = Clock::now();
        const server::DecodeResult result = server::decode_message(bytes, !s.welcomed);
        if (const auto* e = std::get_if<server::DecodeError>(&result)) {
            handle_decode_error(s, *e);
            return;
        }
        const auto& req = std::get<server::Request>(result);
        if (const auto* hello = std::get_if<server::HelloRequest>(&req.body)) {
            handle_hello(s, *hello);
            return;
        }
        const std::uint64_t id = *req.id;
        std::visit(
            [&](const auto& body) {
                using T = std::decay_t<decltype(body)>;
                if constexpr (std::is_same_v<T, server::HeartbeatRequest>) {
                    state.read(snapshot);
                    json ok = server::ok_reply(id);
                    ok["tick"] = snapshot.tick;
                    send_reply(s, ok);
                } else if constexpr (std::is_same_v<T, server::CommitRequest>) {
                    handle_commit(s, id, body);
                } else if constexpr (std::is_same_v<T, server::ListRequest>) {
                    json ok = server::ok_reply(id);
                    ok["objects"] = server::list_json(config.config_walls, slots);
                    send_reply(s, ok);
                } else if constexpr (std::is_same_v<T, server::StatusRequest>) {
                    state.read(snapshot);
                    std::size_t n = config.config_walls.size();
                    for (const auto& slot : slots) n += slot.state != ServerSlot::State::Free ? 1U : 0U;
                    json ok = server::status_reply(id, snapshot, sessions.size(), n);
                    ok["meshes"] = meshes.meshes();
                    ok["mesh_bytes"] = meshes.total_bytes();
                    send_reply(s, ok);
                } else if constexpr (std::is_same_v<T, server::SubscribeRequest>) {
                    s.subscribed = true;
                    s.rate_hz = body.rate_hz;
                    s.next_state = Clock::now();
                    send_reply(s, server::ok_reply(id));
                } else if constexpr (std::is_same_v<T, server::UnsubscribeRequest>) {
                    s.subscribed = false;
                    send_reply(s, server::ok_reply(id));
                } else if constexpr (std::is_same_v<T, server::SubscribeContactsRequest>) {
                    subscribe_contacts(s, id, body);
                } else if constexpr (std::is_same_v<T, server::UnsubscribeContactsRequest>) {
                    s.contacts = false;
                    s.contact_queue.clear();
                    send_reply(s, server::ok_reply(id));
                } else if constexpr (std::is_same_v<T, server::MeshBeginRequest> ||
                                     std::is_same_v<T, server::MeshChunkRequest> ||
                                     std::is_same_v<T, server::MeshEndRequest> ||
                                     std::is_same_v<T, server::MeshStatusRequest> ||
                                     std::is_same_v<T, server::MeshDeleteRequest>) {
                    handle_mesh(s, id, body);
                } else if constexpr (std::is_same_v<T, server::ByeRequest>) {
                    send_reply(s, server::ok_reply(id));
                    close_session(s, "bye");
                } else {
                    send_error(s, id, cl::ErrorCode::BadMessage, "hello: already welcomed");
                }
            },
            req.body);
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
            log("session " + std::to_string(s.id) +
                ": internal error while handling a request: " + cl::escape_for_log(what, 256));
            send_error(s, std::nullopt, cl::ErrorCode::Internal,
                       std::string("Server: internal error while handling the request (") +
                           cl::truncate_utf8(what, 256) + "); the session goes on");
        } catch (...) {
        }
    }

    void read_session(Session& s) {
        if (s.stream) {
            read_stream_session(s);
            return;
        }
        for (int i = 0; i < kMessagesPerRound && !s.closed; ++i) {
            const ssize_t n = ::recv(s.fd, buffer.data(), buffer.size(), MSG_DONTWAIT);
            if (n < 0) {
                if (errno == EAGAIN || errno == EWOULDBLOCK || errno == EINTR) return;
                close_session(s, std::string("recv failed: ") + std::strerror(errno));
                return;
            }
            // SOCK_SEQPACKET: 0 is both an empty message and the end of the stream; the peer has hung up
            // only in the second case.
            if (n == 0 && server::peer_hung_up(s.fd)) {
                close_session(s, "disconnected (EOF)");
                return;
            }
            handle_guarded(s, std::string_view(buffer.data(), static_cast<std::size_t>(n)));
            close_departed_sessions();
        }
    }

    // The stream transport: the frames already received first, then what the socket holds, at most
    // kMessagesPerRound messages per round (what stays in the framer is taken next round without POLLIN).
    void read_stream_session(Session& s) {
        int handled = 0;
        bool socket_empty = false;
        while (handled < kMessagesPerRound && !s.closed) {
            const server::LineFramer::Next next = s.framer.next();
            if (next.status == server::LineFramer::Status::Frame) {
                handle_guarded(s, next.frame);
                close_departed_sessions();
                ++handled;
                continue;
            }
            if (next.status == server::LineFramer::Status::Oversized) {
                send_error(s, std::nullopt, cl::ErrorCode::Oversized,
                           "Server: a message of more than " + std::to_string(cl::kMaxMessageBytes) +
                               " bytes without its '\\n' (stream socket, docs/protocol.md section 1)");
                close_session(s, "oversized message");
                return;
            }
            if (socket_empty) return;
            const ssize_t n = ::recv(s.fd, buffer.data(), buffer.size(), MSG_DONTWAIT);
            if (n < 0) {
                if (errno == EAGAIN || errno == EWOULDBLOCK || errno == EINTR) return;
                close_session(s, std::string("recv failed: ") + std::strerror(errno));
                return;
            }
            if (n == 0) {  // SOCK_STREAM: the end of the stream (a partial frame left is discarded)
                close_session(s, "disconnected (EOF)");
                return;
            }
            s.framer.append(std::string_view(buffer.data(), static_cast<std::size_t>(n)));
            socket_empty = static_cast<std::size_t>(n) < buffer.size();
        }
    }

    // ---- subscriptions -------------------------------------------------------------------------
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
            const std::string text = server::state_message(snapshot, s.dropped).dump();
            switch (s.stream ? s.outbox.send_if_idle(s.fd, text) : server::send_message(s.fd, text)) {
                case server::SendResult::Sent:
                    break;
                case server::SendResult::Full:
                    ++s.dropped;
                    count(&ServerCounters::states_dropped);
                    break;
                case server::SendResult::Failed:
                    close_session(s, std::string("send failed: ") + std::strerror(errno));
                    break;
            }
        }
    }

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
                if (s.contact_filter && std::find(s.contact_filter->begin(), s.contact_filter->end(), r.object_id) ==
                                            s.contact_filter->end()) {
                    continue;
                }
                if (s.contact_queue.size() >= server::kContactQueueCapacity) {
                    ++s.contact_dropped;
                    ++dropped_total;
                    continue;
                }
                if (!message) message = server::contact_message(r);
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
            switch (s.stream ? s.outbox.send_if_idle(s.fd, text) : server::send_message(s.fd, text)) {
                case server::SendResult::Sent:
                    s.contact_queue.pop_front();
                    break;
                case server::SendResult::Full:
                    return;
                case server::SendResult::Failed:
                    close_session(s, std::string("send failed: ") + std::strerror(errno));
                    return;
            }
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
            if (!s.contact_filter ||
                std::find(s.contact_filter->begin(), s.contact_filter->end(), oid) != s.contact_filter->end()) {
                ids.push_back(oid);
            }
        }
        json ok = server::ok_reply(id);
        ok["contacts"] = ids;
        send_reply(s, ok);
    }

    // At the stop, after the loop's last tick: its records (the `end` of every contact still in progress,
    // ContactDetector::end_all) go to the subscribers, each session's queue sent as its socket takes it for up
    // to kFinalContactFlush; what a session that does not read leaves then is lost with the session.
    void final_contacts() {
        drain_contacts();
        const auto until = Clock::now() + server::kFinalContactFlush;
        std::vector<pollfd> fds;
        while (Clock::now() < until) {
            fds.clear();
            for (auto& [sid, s] : sessions) {
                if (!s.closed && !s.contact_queue.empty()) fds.push_back({s.fd, POLLOUT, 0});
            }
            if (fds.empty()) return;
            if (::poll(fds.data(), fds.size(), 10) < 0 && errno != EINTR) return;
            for (auto& [sid, s] : sessions) flush_contacts(s);
        }
    }

    // The replies, states and contact messages a stream socket did not take yet, as far as it takes them now.
    void flush_stream_outboxes() {
        for (auto& [sid, s] : sessions) {
            if (s.closed || !s.stream || s.outbox.idle()) continue;
            if (s.outbox.flush(s.fd) == server::SendResult::Failed)
                close_session(s, std::string("send failed: ") + std::strerror(errno));
        }
    }

    // ---- the thread ----------------------------------------------------------------------------
    // run() again after anything that escaped a round outside a request (logged): the server thread never
    // ends by an exception while the daemon runs.
    void run_guarded() noexcept {
        while (!stop.load(std::memory_order_acquire)) {
            try {
                run();
                return;
            } catch (const std::exception& e) {
                try {
                    log(std::string("internal error in the server loop (it goes on): ") +
                        cl::escape_for_log(e.what(), 256));
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
            fds.push_back({socket.listen_fd, POLLIN, 0});
            fds.push_back({socket.wake_fd, POLLIN, 0});
            fds.push_back({stream_socket.listen_fd, POLLIN, 0});  // fd -1: ignored by poll
            bool framed_waiting = false;  // stream messages received in an earlier round and not handled yet
            for (auto& [sid, s] : sessions) {
                fds.push_back({s.fd, static_cast<short>(s.outbox.idle() ? POLLIN : POLLIN | POLLOUT), 0});
                ids.push_back(sid);
                framed_waiting = framed_waiting || (s.stream && s.framer.has_frame());
            }
            // 1 ms: leases, subscriptions, slot reclaim
            const int r = ::poll(fds.data(), fds.size(), framed_waiting ? 0 : 1);
            if (r < 0 && errno != EINTR) {
                log(std::string("poll failed: ") + std::strerror(errno));
                return;
            }
            if (stop.load(std::memory_order_acquire)) break;
            if (r > 0 || framed_waiting) {
                if ((fds[0].revents & POLLIN) != 0) accept_all(socket.listen_fd, false);
                if ((fds[2].revents & POLLIN) != 0) accept_all(stream_socket.listen_fd, true);
                close_departed_sessions();
                for (std::size_t i = 0; i < ids.size(); ++i) {
                    const short ev = fds[i + 3].revents;
                    Session& s = sessions.at(ids[i]);
                    if (s.closed) continue;
                    if ((ev & POLLIN) != 0 || (s.stream && s.framer.has_frame())) read_session(s);
                    if (!s.closed && (ev & (POLLHUP | POLLERR)) != 0 && (ev & POLLIN) == 0) close_session(s, "hung up");
                }
            }
            flush_stream_outboxes();
            const auto now = Clock::now();
            close_silent_sessions(now);
            drain_contacts();
            send_states(now);
            push_pending();
            reclaim_slots();
            meshes.collect();
            meshes.expire(now);
            for (auto it = sessions.begin(); it != sessions.end();) {
                it = it->second.closed ? sessions.erase(it) : std::next(it);
            }
        }
        final_contacts();
        for (auto& [sid, s] : sessions) close_session(s, "server stopping");
        sessions.clear();
    }
};

std::string config_walls_unstable(const GainChecker& checker, const std::vector<ConfigWallInfo>& walls) {
    const EngagementCheck verdict =
        check_engagement_patterns(checker, server::terms_of_config_walls(walls), 1.0, PatternLimit::None);
    return verdict.stable ? std::string() : verdict.why;
}

Server::Server(const ServerConfig& config, GainChecker& checker, CommitRing& ring, const StatePublisher& state,
               CommitRing* departures, ContactRing* contacts)
    : impl_(std::make_unique<Impl>(config, checker, ring, departures, state, commits_pushed_, contacts)) {
    impl_->open_socket();
    impl_->log("listening on " + impl_->config.socket_path + " (mode 0" +
               [&] {
                   std::ostringstream o;
                   o << std::oct << impl_->config.socket_mode;
                   return o.str();
               }() +
               ")" +
               (impl_->config.stream_socket_path.empty() ? std::string()
                                                         : ", stream socket " + impl_->config.stream_socket_path) +
               ", state in shared memory " + state.name());
}

Server::~Server() {
    stop();
    if (impl_->socket.listen_fd >= 0) ::close(impl_->socket.listen_fd);
    if (impl_->socket.wake_fd >= 0) ::close(impl_->socket.wake_fd);
    ::unlink(impl_->config.socket_path.c_str());
    if (impl_->stream_socket.listen_fd >= 0) {
        ::close(impl_->stream_socket.listen_fd);
        ::unlink(impl_->config.stream_socket_path.c_str());
    }
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
    (void)::write(impl_->socket.wake_fd, &one, sizeof(one));
    thread_.join();
}

const std::string& Server::socket_path() const noexcept { return impl_->config.socket_path; }

const std::string& Server::stream_socket_path() const noexcept { return impl_->config.stream_socket_path; }

ServerCounters Server::counters() const {
    std::lock_guard<std::mutex> lock(impl_->counters_mutex);
    return impl_->counters;
}

}  // namespace hapticd
