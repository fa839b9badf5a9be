// SPDX-License-Identifier: Apache-2.0
// Transport and sessions of the control server (docs/protocol.md, sections 2 to 4): the listening
// SOCK_SEQPACKET socket (path, mode, group) and its wake-up eventfd, accepting a connection with its peer's
// credentials (SO_PEERCRED), one Session per connection, non-blocking sends, the hello timeout and the lease,
// and finding the sessions whose peer has gone. What a session's messages mean is the server's (server_requests.cpp);
// nothing here touches the scene.
#pragma once

#include <poll.h>

#include <chrono>
#include <cstddef>
#include <cstdint>
#include <deque>
#include <optional>
#include <string>
#include <vector>

#include <hapticopt/criterion.hpp>

#include "server/stream_framing.hpp"

namespace hapticd::server {

using Clock = std::chrono::steady_clock;

inline constexpr std::size_t kMaxSessions = 256;
inline constexpr int kHelloTimeoutS = 5;  // a connection that never says hello is closed (it would hold a session)
// Contact messages a session may have waiting for room in its socket: 256 of ~250 bytes.
inline constexpr std::size_t kContactQueueCapacity = 256;
// At the daemon's stop, how long the server waits for the sessions' sockets to take their last contact messages.
inline constexpr std::chrono::milliseconds kFinalContactFlush{200};

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
    bool stream = false;                    // came through the stream socket: '\n'-framed (stream_framing.hpp)
    LineFramer framer{65536};               // stream: received bytes cut into messages
    StreamOutbox outbox;                    // stream: sent bytes the socket has not taken yet
    // A request waiting for criteria's first tuning (server/criterion_worker.hpp): nothing more is read from the
    // session until it is answered, and the session is not silent meanwhile (the server owes it a reply).
    // A commit waiting for the scene checker (server/scene_check_worker.hpp) is parked too: `checking` while the
    // checker runs its scenes, else until the checker is free (the oldest parked_seq first).
    std::optional<std::string> parked;
    std::vector<hapticopt::Criterion> awaiting;  // the criteria it waits for
    bool checking = false;
    std::uint64_t parked_seq = 0;
};

struct ListeningSocket {
    int listen_fd = -1;
    int wake_fd = -1;  // an eventfd that wakes the server's poll (stop)
};

// Creates the socket directory if needed, removes a stale socket (remove_stale_socket), binds `path` with
// `mode` (never wider while it exists) and group `gid` (< 0: the process's), listens; then the eventfd (only
// when `with_wake_fd`). `type`: SOCK_SEQPACKET (the control socket) or SOCK_STREAM (the stream socket).
// std::runtime_error naming the path and the call on failure (SocketPathError for a path in use).
[[nodiscard]] ListeningSocket open_listening_socket(const std::string& path, unsigned mode, int gid, int type,
                                                    bool with_wake_fd);

// A connection taken from the listening socket, non-blocking, with its peer's credentials (pid 0, uid and gid
// -1 when SO_PEERCRED fails).
struct Peer {
    int fd = -1;
    long pid = 0;
    long uid = -1;
    long gid = -1;
};
// The next pending connection; none when no connection waits (or accept failed: tried again next round).
[[nodiscard]] std::optional<Peer> accept_peer(int listen_fd);

// One message, never blocking (MSG_DONTWAIT | MSG_NOSIGNAL): Full when the socket has no room (errno
// EAGAIN), Failed for any other error (errno kept for the caller's message).
[[nodiscard]] SendResult send_message(int fd, const std::string& text) noexcept;
// A message on either transport: as is (SOCK_SEQPACKET) or through the session's outbox as a reply (stream).
[[nodiscard]] SendResult send_to(Session& s, const std::string& text);

// SOCK_SEQPACKET: a zero-length read is both an empty message and the end of the stream; true for the
// latter (or when poll fails).
[[nodiscard]] bool peer_hung_up(int fd) noexcept;

// What ends a session that says nothing: no hello within kHelloTimeoutS, or no message within its lease.
enum class Silence { None, NoHello, LeaseLost };
// Silent for longer than the hello timeout or its lease, and nothing from it waiting to be read: a message waiting
// in its socket (or a whole frame in a stream session's buffer) is the client speaking while the server thread was
// busy with another session's request (a criterion's first tuning can take a second), so it is not silence.
[[nodiscard]] Silence silence_of(const Session& s, Clock::time_point now);

// Finds the sessions whose peer has gone (POLLRDHUP, POLLHUP or POLLERR) with one zero-timeout poll; keeps
// its storage between calls. A stream session's peer has gone only on POLLHUP or POLLERR: POLLRDHUP alone is a
// half-close (shutdown(SHUT_WR), e.g. socat at the end of its input), after which the requests it sent are
// still answered and the end of the stream closes the session.
class DepartureDetector {
  public:
    void clear();
    void watch(int fd, std::uint64_t session, bool stream = false);
    // The watched sessions whose peer has gone, in the order watched.
    [[nodiscard]] const std::vector<std::uint64_t>& departed();

  private:
    std::vector<pollfd> fds_;
    std::vector<std::uint64_t> ids_;
    std::vector<short> gone_;  // the revents that mean the peer has gone, per fd
    std::vector<std::uint64_t> departed_;
};

}  // namespace hapticd::server
