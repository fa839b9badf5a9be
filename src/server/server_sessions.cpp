// SPDX-License-Identifier: Apache-2.0
// The server thread's sending and its sessions' lifetimes (Server::Impl, server_impl.hpp): replies that
// never block, accept, close (the departure rule on close), departed and silent sessions.
#include "server/server_impl.hpp"

#include <sys/socket.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <cstring>

#include "server/replies.hpp"
#include "server/reply_text.hpp"

namespace hapticd {

namespace {

namespace cl = hapticd::client;

}  // namespace

// Replies: a full socket means the client does not read -> disconnect (never block).
void Server::Impl::send_reply(Session& s, json message) {
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

void Server::Impl::send_error(Session& s, std::optional<std::uint64_t> id, cl::ErrorCode code,
                              const std::string& message, int op_index, std::optional<double> largest,
                              std::optional<std::pair<double, double>> damping) {
    send_reply(s, server::error_reply(id, code, message, op_index, largest, damping));
}

void Server::Impl::accept_all(int listen_fd, bool stream) {
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

void Server::Impl::close_session(Session& s, const std::string& why, bool depart) {
    if (s.closed) return;
    s.closed = true;
    ::close(s.fd);
    s.fd = -1;
    drop_scene_check_of(s);
    const std::size_t leaving = depart ? queue_departure(s) : 0;
    meshes.drop_session(s.id);
    log("session " + std::to_string(s.id) + " (" + (s.name.empty() ? "unnamed" : s.name) + ", pid " +
        std::to_string(s.pid) + ", uid " + std::to_string(s.uid) + ") closed: " + why +
        (leaving == 0
             ? std::string()
             : "; " + std::to_string(leaving) + " of its objects leave the scene once their departure is planned"));
    count(&ServerCounters::sessions_closed);
}

// Closes every session whose peer has gone, ahead of the messages still waiting on the others: a
// request's checks take milliseconds (tens on a loaded machine), so a departure noticed only at the next
// poll would wait behind every message of the round.
void Server::Impl::close_departed_sessions() {
    departures.clear();
    for (auto& [sid, other] : sessions) {
        if (!other.closed) departures.watch(other.fd, sid, other.stream);
    }
    for (const std::uint64_t sid : departures.departed()) close_session(sessions.at(sid), "disconnected (EOF)");
}

// The hello timeout and the leases: a silent session is told why and closed.
void Server::Impl::close_silent_sessions(Clock::time_point now) {
    for (auto& [sid, s] : sessions) {
        switch (server::silence_of(s, now)) {
            case server::Silence::None:
                break;
            case server::Silence::NoHello:
                (void)server::send_to(s, server::refused_hello_reply(
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

}  // namespace hapticd
