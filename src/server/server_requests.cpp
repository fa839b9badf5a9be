// SPDX-License-Identifier: Apache-2.0
// Each request of a session decoded (server/message_decoder.hpp) and answered (server/replies.hpp):
// hello, commit (staged by server/commit_transaction.hpp, its scenes checked by server/commit_check_worker.hpp,
// handed whole to the loop's ring),
// meshes, list, status, subscriptions, bye; whatever escapes answered `internal` (Server::Impl,
// server_impl.hpp).
#include "server/server_impl.hpp"

#include <algorithm>
#include <chrono>
#include <stdexcept>
#include <string_view>
#include <type_traits>
#include <variant>

#include "client/text_limits.hpp"
#include "server/commit_transaction.hpp"
#include "server/replies.hpp"

namespace hapticd {

namespace {

using nlohmann::json;
namespace cl = hapticd::client;

}  // namespace

// Per-session limit (docs/protocol.md, section 7): one session may not fill the hand-over ring.
bool Server::Impl::refuse_over_in_flight_limit(Session& s, std::uint64_t id) {
    if (state.read(snapshot)) {
        while (!s.in_flight.empty() && s.in_flight.front() <= snapshot.last_commit_seq) s.in_flight.pop_front();
    }
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

// The batch staged (operations, summed stiffness) here, its scenes checked by scene_checker while the session is
// parked (finish_scene_check answers it), then handed to the loop behind the waiting departures and adopted once it
// is in the ring; busy when the ring has no room (nothing changes). A ring already full, or departures still
// waiting for it, answer busy before the batch is staged: a busy server does not spend the checks.
void Server::Impl::handle_commit(Session& s, std::uint64_t id, const server::CommitRequest& req,
                                 std::string_view bytes) {
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
            out.shading = [this, session = s.id, mesh](double crease_angle_deg) {
                return meshes.shading(session, mesh, crease_angle_deg);
            };
        }
        return out;
    };
    server::StagedOutcome staged = server::stage_commit(server::CommitContext{config, checker, resolver, &lookup},
                                                        slots, s.id, next_object_id, req);
    if (const auto* r = std::get_if<server::CommitRefusal>(&staged)) {
        count(&ServerCounters::commits_refused);
        send_error(s, id, r->refusal.code, r->refusal.message, r->op_index, r->refusal.largest_stable_K,
                   r->refusal.damping_needed);
        return;
    }
    server::StagedCommit& st = std::get<server::StagedCommit>(staged);
    if (!scene_checker.start(std::move(st.terms), st.step)) {  // park_for_scene_check let it through: never
        send_error(s, id, cl::ErrorCode::Busy, "commit: another commit's scenes are being checked; retry", -1);
        return;
    }
    scene_check = SceneCheck{s.id, id, std::move(st.plan), Clock::now()};
    s.parked.emplace(bytes);
    s.checking = true;
}

// The checked batch handed to the loop (behind the waiting departures) and its table adopted: the slots the batch
// changes only, since the table may have changed meanwhile by slots reclaimed (a drained slot that became free;
// every other change cancels the check, restart_scene_check).
void Server::Impl::adopt_commit(Session& s, std::uint64_t id, server::CommitPlan& plan) {
    ObjectCommit& c = plan.batch;
    push_pending();  // older ramp-outs first, so batches reach the loop in order
    if (!pending.empty()) {
        send_error(s, id, cl::ErrorCode::Busy, "commit: the hand-over queue to the loop is full; retry", -1);
        return;
    }
    c.seq = next_commit_seq;
    if (mesh_observer != nullptr) {  // before the push: the recording holds a mesh before any batch that renders it
        for (std::uint32_t i = 0; i < c.count; ++i) {
            const SlotUpdate& u = c.updates[i];
            const auto& held = plan.slots[u.slot].resolved.mesh;
            if (u.params.kind == ObjectKind::Mesh && u.params.mesh != nullptr && held.get() == u.params.mesh) {
                mesh_observer->on_mesh(u.params.mesh_id, held);
            }
        }
    }
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
    for (std::uint32_t k = 0; k < c.count; ++k) {
        const std::size_t i = c.updates[k].slot;
        ServerSlot& planned = plan.slots[i];
        if (planned.state == ServerSlot::State::Draining && planned.drain_seq == server::kNotPushed)
            planned.drain_seq = seq;
        // a modify that replaced a mesh object's hierarchy
        if (slots[i].resolved.mesh && slots[i].resolved.mesh != planned.resolved.mesh)
            retired.push_back(Retired{slots[i].resolved.mesh, seq, 0});
        slots[i] = planned;
    }
    next_object_id = plan.next_object_id;
    if (c.count > 0) s.in_flight.push_back(seq);
    json ok = server::ok_reply(id);
    ok["commit_seq"] = seq;
    ok["object_ids"] = plan.new_ids;
    ok["scenes_checked"] = plan.scenes_checked;
    ok["scenes_sampled"] = plan.scenes_sampled;
    send_reply(s, ok);
}

bool Server::Impl::park_for_scene_check(Session& s, std::string_view bytes) {
    if (scene_checks_idle()) return false;
    s.parked.emplace(bytes);
    s.parked_seq = next_parked_seq++;
    return true;
}

void Server::Impl::restart_scene_check() {
    if (!scene_check) return;
    scene_checker.cancel();
    const auto it = sessions.find(scene_check->session);
    if (it != sessions.end()) {
        it->second.checking = false;  // still parked: staged again on the new scene ahead of later commits
        it->second.parked_seq = 0;
    }
    log("session " + std::to_string(scene_check->session) +
        ": the scene changed during its commit's check (a departure); the commit is checked again");
    scene_check.reset();
    count(&ServerCounters::scene_checks_restarted);
}

void Server::Impl::drop_scene_check_of(const Session& s) {
    if (!scene_check || scene_check->session != s.id) return;
    scene_checker.cancel();
    scene_check.reset();
}

void Server::Impl::finish_scene_check() {
    if (!scene_check) return;
    std::optional<server::SceneCheckWorker::Outcome> outcome = scene_checker.take();
    if (!outcome) return;
    SceneCheck check = std::move(*scene_check);
    scene_check.reset();
    const auto it = sessions.find(check.session);  // a closing session's check is dropped (drop_scene_check_of)
    if (it == sessions.end() || it->second.closed) return;
    Session& s = it->second;
    s.parked.reset();
    s.checking = false;
    try {
        if (outcome->failure != nullptr) {
            internal_error(s, outcome->failure);
        } else if (server::CommitOutcome o = server::finish_commit(std::move(check.plan), outcome->verdict);
                   const auto* r = std::get_if<server::CommitRefusal>(&o)) {
            count(&ServerCounters::commits_refused);
            send_error(s, check.request_id, r->refusal.code, r->refusal.message, r->op_index,
                       r->refusal.largest_stable_K, r->refusal.damping_needed);
        } else {
            adopt_commit(s, check.request_id, std::get<server::CommitPlan>(o));
        }
    } catch (const std::exception& e) {
        internal_error(s, e.what());
    } catch (...) {
        internal_error(s, "an unknown exception");
    }
    s.last_rx = Clock::now();
}

bool Server::Impl::scene_checks_idle() const {
    return !scene_check && !departure_check && departures_waiting.empty() && scene_checker.idle();
}

std::size_t Server::Impl::commits_waiting_for_check() const {
    return static_cast<std::size_t>(std::count_if(sessions.begin(), sessions.end(), [](const auto& entry) {
        const Session& s = entry.second;
        return !s.closed && s.parked && !s.checking && s.awaiting.empty();
    }));
}

// Meshes (docs/protocol.md, section 4a): the mesh requests answered from the session's uploads (server/mesh_store.hpp).
void Server::Impl::send_refusal(Session& s, std::uint64_t id, const server::Refusal& r) {
    send_error(s, id, r.code, r.message);
}

json Server::Impl::mesh_info_reply(std::uint64_t id, std::uint32_t mesh, const server::MeshInfo& info) {
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
void Server::Impl::handle_mesh(Session& s, std::uint64_t id, const Request& body) {
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

void Server::Impl::handle_decode_error(Session& s, const server::DecodeError& e) {
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

void Server::Impl::handle_hello(Session& s, const server::HelloRequest& hello) {
    s.welcomed = true;
    s.name = cl::escape_for_log(hello.client, 64);  // only ever logged: one line, no control bytes
    s.lease_s = hello.lease_s;
    log("session " + std::to_string(s.id) + " is '" + s.name + "', lease " + g(s.lease_s) + " s");
    send_reply(s, server::welcome_reply(config, checker, s.id, s.lease_s, state.name()));
}

void Server::Impl::handle_message(Session& s, std::string_view bytes) {
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
                if (!park_for_criteria(s, bytes, body) && !park_for_scene_check(s, bytes))
                    handle_commit(s, id, body, bytes);
            } else if constexpr (std::is_same_v<T, server::ListRequest>) {
                json ok = server::ok_reply(id);
                ok["objects"] = server::list_json(config.config_walls, slots);
                send_reply(s, ok);
            } else if constexpr (std::is_same_v<T, server::StatusRequest>) {
                state.read(snapshot);
                std::size_t n = config.config_walls.size();
                for (const auto& slot : slots) n += slot.state != ServerSlot::State::Free ? 1U : 0U;
                json ok = server::status_reply(id, snapshot, sessions.size(), n);
                ok["commit_check"] =
                    scene_check ? json{{"session", scene_check->session},
                                       {"running_s",
                                        std::chrono::duration<double>(Clock::now() - scene_check->started).count()}}
                                : json(nullptr);
                ok["commits_waiting"] = commits_waiting_for_check();
                ok["departures_waiting"] = departures_waiting.size() + (departure_check ? 1U : 0U);
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
bool Server::Impl::park_for_criteria(Session& s, std::string_view bytes, const server::CommitRequest& req) {
    std::vector<hapticopt::Criterion> missing;
    for (const server::CommitOperation& op : req.ops) {
        if (!op.object) continue;
        std::visit(
            [&](const auto& object) {
                if constexpr (requires { object.gains.criterion; }) {
                    // A name that is not a criterion waits for nothing: resolution refuses it (unknown_criterion).
                    const std::optional<hapticopt::Criterion> c = server::named_criterion(object.gains);
                    if (c && !checker.criterion_ready(*c) &&
                        std::find(missing.begin(), missing.end(), *c) == missing.end())
                        missing.push_back(*c);
                }
            },
            *op.object);
    }
    if (missing.empty()) return false;
    for (const hapticopt::Criterion c : missing) criterion_worker.request(c);
    log("session " + std::to_string(s.id) + " waits for the first tuning of criterion " +
        std::string(hapticopt::to_string(missing.front())) +
        (missing.size() > 1 ? " and " + std::to_string(missing.size() - 1) + " more" : std::string()));
    s.parked.emplace(bytes);
    s.awaiting = std::move(missing);
    return true;
}

// The checked commit or the planned departure first, and the next departure's plan; then the requests whose criteria
// are ready; then, while the scene checker is free and no departure waits, the commits waiting for it, the oldest first
// (a commit whose check a departure cancelled comes before all).
void Server::Impl::resume_parked() {
    finish_scene_check();
    finish_departure();
    start_departure();
    for (auto& [sid, s] : sessions) {
        if (s.closed || !s.parked || s.awaiting.empty()) continue;
        if (!std::all_of(s.awaiting.begin(), s.awaiting.end(),
                         [&](hapticopt::Criterion c) { return checker.criterion_ready(c); }))
            continue;
        const std::string bytes = std::move(*s.parked);
        s.parked.reset();
        s.awaiting.clear();
        handle_guarded(s, bytes);
        close_departed_sessions();
    }
    while (scene_checks_idle()) {
        Session* next = nullptr;
        for (auto& [sid, s] : sessions) {
            if (s.closed || !s.parked || s.checking || !s.awaiting.empty()) continue;
            if (next == nullptr || s.parked_seq < next->parked_seq) next = &s;
        }
        if (next == nullptr) break;
        const std::string bytes = std::move(*next->parked);
        next->parked.reset();
        handle_guarded(*next, bytes);
        close_departed_sessions();
    }
}

// The lease counts the client's silence from the reply too: a client waiting for its answer (a criterion's first
// tuning can take seconds) need not send anything meanwhile.
void Server::Impl::handle_guarded(Session& s, std::string_view bytes) {
    try {
        handle_message(s, bytes);
    } catch (const std::exception& e) {
        internal_error(s, e.what());
    } catch (...) {
        internal_error(s, "an unknown exception");
    }
    s.last_rx = Clock::now();
}

void Server::Impl::internal_error(Session& s, const char* what) noexcept {
    try {
        log("session " + std::to_string(s.id) +
            ": internal error while handling a request: " + cl::escape_for_log(what, 256));
        send_error(s, std::nullopt, cl::ErrorCode::Internal,
                   std::string("Server: internal error while handling the request (") + cl::truncate_utf8(what, 256) +
                       "); the session goes on");
    } catch (...) {
    }
}

}  // namespace hapticd
