// SPDX-License-Identifier: Apache-2.0
// The server's session rules in process (server/sessions.hpp): silence_of ends a session that said nothing for its
// lease (or sent no hello), unless a message from it is waiting to be read — the server thread may have been busy
// with another session's request for longer than the lease while this client kept speaking.
#include <sys/socket.h>
#include <unistd.h>

#include <chrono>

#include <gtest/gtest.h>

#include "server/sessions.hpp"

namespace hapticd::server {
namespace {

struct SocketPair {
    int fd[2] = {-1, -1};
    SocketPair() { EXPECT_EQ(::socketpair(AF_UNIX, SOCK_SEQPACKET, 0, fd), 0); }
    ~SocketPair() {
        ::close(fd[0]);
        ::close(fd[1]);
    }
    SocketPair(const SocketPair&) = delete;
    SocketPair& operator=(const SocketPair&) = delete;
};

TEST(Sessions, ASessionIsSilentOnlyWhenNothingFromItIsWaiting) {
    SocketPair pair;
    Session s;
    s.fd = pair.fd[0];
    s.welcomed = true;
    s.lease_s = 0.3;
    const Clock::time_point now = Clock::now();
    s.last_rx = now - std::chrono::milliseconds(200);
    EXPECT_EQ(silence_of(s, now), Silence::None);  // within its lease
    s.last_rx = now - std::chrono::seconds(1);
    EXPECT_EQ(silence_of(s, now), Silence::LeaseLost);
    // A heartbeat that arrived while the server was busy: not silence until it has been read.
    const char beat[] = R"({"type":"heartbeat"})";
    ASSERT_EQ(::send(pair.fd[1], beat, sizeof beat - 1, 0), static_cast<ssize_t>(sizeof beat - 1));
    EXPECT_EQ(silence_of(s, now), Silence::None);
    char buffer[64];
    ASSERT_GT(::recv(pair.fd[0], buffer, sizeof buffer, 0), 0);
    EXPECT_EQ(silence_of(s, now), Silence::LeaseLost);
    // The same for a hello that waits.
    Session fresh;
    fresh.fd = pair.fd[0];
    fresh.last_rx = now - std::chrono::seconds(kHelloTimeoutS + 1);
    EXPECT_EQ(silence_of(fresh, now), Silence::NoHello);
    ASSERT_EQ(::send(pair.fd[1], beat, sizeof beat - 1, 0), static_cast<ssize_t>(sizeof beat - 1));
    EXPECT_EQ(silence_of(fresh, now), Silence::None);
    // A closed session is never silent; without a lease, silence never ends a welcomed session.
    s.closed = true;
    EXPECT_EQ(silence_of(s, now), Silence::None);
    Session unleased;
    unleased.fd = pair.fd[0];
    unleased.welcomed = true;
    unleased.last_rx = now - std::chrono::hours(1);
    EXPECT_EQ(silence_of(unleased, now), Silence::None);
}

}  // namespace
}  // namespace hapticd::server
