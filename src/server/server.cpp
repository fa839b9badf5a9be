// SPDX-License-Identifier: Apache-2.0
// The server thread: one poll loop over the listening socket and the sessions (server/sessions.hpp), each
// request decoded (server/message_decoder.hpp) and answered (server/replies.hpp); commits planned by the
// commit transaction (server/commit_transaction.hpp) and handed whole to the loop's ring; a departed
// session's objects ramped out by the departure rule (server/departure_plan.hpp); state and contact messages
// sent to the sessions that subscribe.
// The poll loop and the facade here; the rest of Server::Impl (server_impl.hpp) in server_sessions.cpp,
// server_departures.cpp, server_requests.cpp and server_subscriptions.cpp.
#include "server/server.hpp"

#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <sstream>
#include <stdexcept>
#include <string_view>

#include "client/text_limits.hpp"
#include "server/server_impl.hpp"
#include "server/stream_framing.hpp"
#include "tuning/engagement_patterns.hpp"
#include "tuning/object_checks.hpp"

namespace hapticd {

namespace {

namespace cl = hapticd::client;

constexpr int kMessagesPerRound = 16;

}  // namespace

void Server::Impl::open_socket() {
    if (config.socket_path.empty()) config.socket_path = default_server_socket_path();
    if (config.stream_socket_path.empty()) config.stream_socket_path = stream_socket_path_for(config.socket_path);
    if (config.stream_socket_path == "none") config.stream_socket_path.clear();
    socket =
        server::open_listening_socket(config.socket_path, config.socket_mode, config.socket_gid, SOCK_SEQPACKET, true);
    if (config.stream_socket_path.empty()) return;
    try {
        stream_socket = server::open_listening_socket(config.stream_socket_path, config.socket_mode, config.socket_gid,
                                                      SOCK_STREAM, false);
    } catch (...) {
        ::close(socket.listen_fd);
        ::close(socket.wake_fd);
        ::unlink(config.socket_path.c_str());
        throw;
    }
}

// run() again after anything that escaped a round outside a request (logged): the server thread never
// ends by an exception while the daemon runs.
void Server::Impl::run_guarded() noexcept {
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

void Server::Impl::run() {
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
            // A parked session (waiting for a criterion's tuning) is not read: its messages wait in order.
            const short in = s.parked ? 0 : POLLIN;
            fds.push_back({s.fd, static_cast<short>(s.outbox.idle() ? in : in | POLLOUT), 0});
            ids.push_back(sid);
            framed_waiting = framed_waiting || (s.stream && !s.parked && s.framer.has_frame());
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
                if (!s.parked && ((ev & POLLIN) != 0 || (s.stream && s.framer.has_frame()))) read_session(s);
                if (!s.closed && (ev & (POLLHUP | POLLERR)) != 0 && (ev & POLLIN) == 0) close_session(s, "hung up");
            }
        }
        resume_parked();
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
    // The daemon stops its loop before the server (daemon/run.cpp): the sessions' objects need no ramp-out, and a
    // departure's checks (seconds over the Falcon's set) would only delay the exit.
    for (auto& [sid, s] : sessions) close_session(s, "server stopping", false);
    sessions.clear();
}

void Server::Impl::read_session(Session& s) {
    if (s.stream) {
        read_stream_session(s);
        return;
    }
    for (int i = 0; i < kMessagesPerRound && !s.closed && !s.parked; ++i) {
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
void Server::Impl::read_stream_session(Session& s) {
    int handled = 0;
    bool socket_empty = false;
    while (handled < kMessagesPerRound && !s.closed && !s.parked) {
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

void Server::set_mesh_observer(MeshObserver* observer) noexcept { impl_->mesh_observer = observer; }

const std::string& Server::socket_path() const noexcept { return impl_->config.socket_path; }

const std::string& Server::stream_socket_path() const noexcept { return impl_->config.stream_socket_path; }

ServerCounters Server::counters() const {
    std::lock_guard<std::mutex> lock(impl_->counters_mutex);
    return impl_->counters;
}

}  // namespace hapticd
