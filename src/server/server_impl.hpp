// SPDX-License-Identifier: Apache-2.0
// The server thread's state and its member functions (Server::Impl, server.hpp), private to hapticd_server:
// the poll loop and the facade in server.cpp, sending and the sessions' lifetimes in server_sessions.cpp, the
// departure rule's batches and slot reclaim in server_departures.cpp, each request's handling in
// server_requests.cpp, the state and contact subscriptions in server_subscriptions.cpp.
#pragma once

#include <atomic>
#include <chrono>
#include <cstdint>
#include <deque>
#include <iostream>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

#include "server/commit_transaction.hpp"
#include "server/criterion_worker.hpp"
#include "server/mesh_store.hpp"
#include "server/message_decoder.hpp"
#include "server/object_limits.hpp"
#include "server/object_resolution.hpp"
#include "server/scene_check_worker.hpp"
#include "server/server.hpp"
#include "server/sessions.hpp"
#include "server/state_publisher.hpp"

namespace hapticd {

struct Server::Impl {
    using json = nlohmann::json;
    using Clock = server::Clock;
    using ServerSlot = server::ServerSlot;
    using Session = server::Session;

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
    std::vector<char> buffer = std::vector<char>(client::kMaxMessageBytes + 1);
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
    MeshObserver* mesh_observer = nullptr;  // --record: told of each hierarchy a pushed batch renders

    void log(const std::string& line) const {
        if (config.log_connections) std::cerr << "hapticd: server: " << line << "\n";
    }

    void count(std::uint64_t ServerCounters::*counter, std::uint64_t n = 1) {
        std::lock_guard<std::mutex> lock(counters_mutex);
        counters.*counter += n;
    }

    // A number as the messages print it.
    static std::string g(double v) { return server::short_number(v); }

    // ---- the poll loop (server.cpp) --------------------------------------------------------------
    void open_socket();
    void run_guarded() noexcept;
    void run();
    void read_session(Session& s);
    void read_stream_session(Session& s);

    // ---- sending and sessions (server_sessions.cpp) ----------------------------------------------
    void send_reply(Session& s, json message);
    void send_error(Session& s, std::optional<std::uint64_t> id, client::ErrorCode code, const std::string& message,
                    int op_index = -1, std::optional<double> largest = std::nullopt,
                    std::optional<std::pair<double, double>> damping = std::nullopt);
    void accept_all(int listen_fd, bool stream);
    // depart false: no departure plan (the server stops after the loop has ended: nothing would render a ramp-out).
    void close_session(Session& s, const std::string& why, bool depart = true);
    void close_departed_sessions();
    void close_silent_sessions(Clock::time_point now);

    // ---- departures (server_departures.cpp) ------------------------------------------------------
    // A closed session's objects wait, rendered as they were, until their departure is planned by scene_checker
    // (one session at a time, in the order they left, ahead of every commit's check): the session's number, its
    // label for the log, and when it was queued (the log's "planned in" counts from there: the wait for the worker
    // and for earlier departures included).
    struct Departure {
        std::uint64_t session = 0;
        std::string label;
        Clock::time_point queued;
    };
    std::deque<Departure> departures_waiting;
    std::optional<Departure> departure_check;  // the one whose plan scene_checker makes
    // Queues the session's departure: the number of its objects that leave (0: it had none, nothing queued).
    std::size_t queue_departure(const Session& s);
    // The next waiting departure's plan started, when the worker is free.
    void start_departure();
    // The plan taken once it is in: its batch handed to the loop (behind the waiting departures), its events sent.
    void finish_departure();
    void ramp_out(const Departure& d, const DeparturePlan& plan, double planned_ms);
    void push_pending();
    void reclaim_slots();

    // ---- requests (server_requests.cpp) ----------------------------------------------------------
    void handle_guarded(Session& s, std::string_view bytes);
    void internal_error(Session& s, const char* what) noexcept;
    void handle_message(Session& s, std::string_view bytes);
    void handle_decode_error(Session& s, const server::DecodeError& e);
    void handle_hello(Session& s, const server::HelloRequest& hello);
    bool refuse_over_in_flight_limit(Session& s, std::uint64_t id);
    void handle_commit(Session& s, std::uint64_t id, const server::CommitRequest& req, std::string_view bytes);
    void adopt_commit(Session& s, std::uint64_t id, server::CommitPlan& plan);
    void send_refusal(Session& s, std::uint64_t id, const server::Refusal& r);
    json mesh_info_reply(std::uint64_t id, std::uint32_t mesh, const server::MeshInfo& info);
    template <class Request>
    void handle_mesh(Session& s, std::uint64_t id, const Request& body);

    // ---- subscriptions (server_subscriptions.cpp) ------------------------------------------------
    void send_states(Clock::time_point now);
    void drain_contacts();
    void flush_contacts(Session& s);
    void subscribe_contacts(Session& s, std::uint64_t id, const server::SubscribeContactsRequest& req);
    void final_contacts();
    void flush_stream_outboxes();

    // ---- criteria's first tunings (server_requests.cpp; server/criterion_worker.hpp) ---------------
    // Parks the commit when a criterion it names is not tuned yet: true when parked (no reply yet).
    bool park_for_criteria(Session& s, std::string_view bytes, const server::CommitRequest& req);
    // Takes again each parked request whose criteria are ready.
    void resume_parked();

    // ---- commits' scene checks (server_requests.cpp; server/scene_check_worker.hpp) ------------------
    // The commit whose scenes scene_checker checks: its plan, staged on the scene as it is (a departure meanwhile
    // restarts the check: restart_scene_check; commits wait for it: park_for_scene_check).
    struct SceneCheck {
        std::uint64_t session = 0;
        std::uint64_t request_id = 0;
        server::CommitPlan plan;
        Clock::time_point started;
    };
    std::optional<SceneCheck> scene_check;
    std::uint64_t next_parked_seq = 1;
    // Parks a commit while another's scenes are being checked or a departure waits for its plan: true when parked (no
    // reply yet).
    bool park_for_scene_check(Session& s, std::string_view bytes);
    // The scene changed under the check in progress (a departure): it is cancelled; its commit waits to be staged
    // again on the new scene.
    void restart_scene_check();
    // Drops the check of a closing session's commit.
    void drop_scene_check_of(const Session& s);
    // Answers the checked commit once its verdict is in.
    void finish_scene_check();
    [[nodiscard]] std::size_t commits_waiting_for_check() const;

    // No commit's check and no departure's plan running, waiting or not yet taken.
    [[nodiscard]] bool scene_checks_idle() const;

    // Last: destroyed first, so their threads end while the checker they use lives.
    server::SceneCheckWorker scene_checker{checker};
    server::CriterionWorker criterion_worker{checker};
};

}  // namespace hapticd
