// SPDX-License-Identifier: Apache-2.0
#include "server/sessions.hpp"

#include <fcntl.h>
#include <sys/eventfd.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/un.h>
#include <unistd.h>

#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <stdexcept>

#include "server/server.hpp"

namespace hapticd {

std::string default_server_socket_path() {
    if (const char* s = std::getenv("RUNTIME_DIRECTORY"); s != nullptr && *s != '\0')
        return std::string(s) + "/hapticd.sock";
    if (const char* s = std::getenv("XDG_RUNTIME_DIR"); s != nullptr && *s != '\0')
        return std::string(s) + "/hapticd.sock";
    return "/run/hapticd/hapticd.sock";
}

std::string stream_socket_path_for(const std::string& socket_path) { return socket_path + ".stream"; }

void remove_stale_socket(const std::string& path, int type) {
    sockaddr_un addr{};
    if (path.size() >= sizeof(addr.sun_path)) return;  // refused by the bind with the accepted length
    struct stat st {};
    if (::lstat(path.c_str(), &st) != 0) {
        if (errno == ENOENT) return;
        throw SocketPathError("Server: socket path '" + path + "': lstat: " + std::strerror(errno));
    }
    if (!S_ISSOCK(st.st_mode)) {
        throw SocketPathError("Server: socket path '" + path +
                              "' exists and is not a socket; hapticd replaces only a stale socket "
                              "of its own: remove the file or choose another --serve-socket");
    }
    const int probe = ::socket(AF_UNIX, type | SOCK_CLOEXEC, 0);
    if (probe < 0) throw SocketPathError(std::string("Server: socket: ") + std::strerror(errno));
    addr.sun_family = AF_UNIX;
    std::memcpy(addr.sun_path, path.c_str(), path.size() + 1);
    const int c = ::connect(probe, reinterpret_cast<const sockaddr*>(&addr), sizeof(addr));
    const int connect_errno = errno;
    ::close(probe);
    if (c == 0) {
        throw SocketPathError("Server: socket path '" + path +
                              "' is in use: a process is listening on it (another hapticd?); "
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

namespace server {

ListeningSocket open_listening_socket(const std::string& path, unsigned mode, int gid, int type, bool with_wake_fd) {
    ListeningSocket out;
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
            throw std::runtime_error("Server: cannot create the socket directory '" + dir +
                                     "': " + std::strerror(errno));
        }
    }
    std::memcpy(addr.sun_path, path.c_str(), path.size() + 1);
    out.listen_fd = ::socket(AF_UNIX, type | SOCK_NONBLOCK | SOCK_CLOEXEC, 0);
    if (out.listen_fd < 0) throw std::runtime_error(std::string("Server: socket: ") + std::strerror(errno));
    // From here on a failure closes what is open.
    auto fail = [&out](const std::string& what) {
        ::close(out.listen_fd);
        if (out.wake_fd >= 0) ::close(out.wake_fd);
        throw std::runtime_error(what);
    };
    try {
        remove_stale_socket(path, type);
    } catch (...) {
        ::close(out.listen_fd);
        throw;
    }
    // Bind with a restrictive umask so the file never exists with a wider mode than asked for.
    const mode_t old = ::umask(0177);
    const int b = ::bind(out.listen_fd, reinterpret_cast<const sockaddr*>(&addr), sizeof(addr));
    const int bind_errno = errno;
    ::umask(old);
    if (b != 0) fail("Server: bind('" + path + "'): " + std::strerror(bind_errno));
    if (gid >= 0 && ::chown(path.c_str(), static_cast<uid_t>(-1), static_cast<gid_t>(gid)) != 0) {
        fail("Server: chown('" + path + "', group " + std::to_string(gid) + "): " + std::strerror(errno));
    }
    if (::chmod(path.c_str(), static_cast<mode_t>(mode)) != 0)
        fail("Server: chmod('" + path + "'): " + std::strerror(errno));
    if (::listen(out.listen_fd, 64) != 0) fail(std::string("Server: listen: ") + std::strerror(errno));
    if (!with_wake_fd) return out;
    out.wake_fd = ::eventfd(0, EFD_NONBLOCK | EFD_CLOEXEC);
    if (out.wake_fd < 0) fail(std::string("Server: eventfd: ") + std::strerror(errno));
    return out;
}

std::optional<Peer> accept_peer(int listen_fd) {
    const int fd = ::accept4(listen_fd, nullptr, nullptr, SOCK_NONBLOCK | SOCK_CLOEXEC);
    if (fd < 0) return std::nullopt;
    ucred cred{};
    socklen_t len = sizeof(cred);
    const bool have = ::getsockopt(fd, SOL_SOCKET, SO_PEERCRED, &cred, &len) == 0;
    Peer p;
    p.fd = fd;
    p.pid = have ? static_cast<long>(cred.pid) : 0;
    p.uid = have ? static_cast<long>(cred.uid) : -1;
    p.gid = have ? static_cast<long>(cred.gid) : -1;
    return p;
}

SendResult send_message(int fd, const std::string& text) noexcept {
    const ssize_t n = ::send(fd, text.data(), text.size(), MSG_DONTWAIT | MSG_NOSIGNAL);
    if (n >= 0) return SendResult::Sent;
    return errno == EAGAIN || errno == EWOULDBLOCK ? SendResult::Full : SendResult::Failed;
}

SendResult send_to(Session& s, const std::string& text) {
    return s.stream ? s.outbox.send_reply(s.fd, text) : send_message(s.fd, text);
}

bool peer_hung_up(int fd) noexcept {
    pollfd p{fd, POLLRDHUP, 0};
    const int r = ::poll(&p, 1, 0);
    return r < 0 || (r > 0 && (p.revents & (POLLRDHUP | POLLHUP | POLLERR)) != 0);
}

namespace {

bool input_waiting(const Session& s) noexcept {
    if (s.stream && s.framer.has_frame()) return true;
    pollfd p{s.fd, POLLIN, 0};
    return ::poll(&p, 1, 0) > 0 && (p.revents & POLLIN) != 0;
}

}  // namespace

Silence silence_of(const Session& s, Clock::time_point now) {
    if (s.closed || s.parked) return Silence::None;
    Silence silence = Silence::None;
    if (!s.welcomed && now - s.last_rx > std::chrono::seconds(kHelloTimeoutS)) silence = Silence::NoHello;
    if (silence == Silence::None && s.lease_s > 0.0 && now - s.last_rx > std::chrono::duration<double>(s.lease_s))
        silence = Silence::LeaseLost;
    return silence != Silence::None && input_waiting(s) ? Silence::None : silence;
}

void DepartureDetector::clear() {
    fds_.clear();
    ids_.clear();
    gone_.clear();
}

void DepartureDetector::watch(int fd, std::uint64_t session, bool stream) {
    fds_.push_back({fd, POLLRDHUP, 0});
    ids_.push_back(session);
    gone_.push_back(static_cast<short>(stream ? (POLLHUP | POLLERR) : (POLLRDHUP | POLLHUP | POLLERR)));
}

const std::vector<std::uint64_t>& DepartureDetector::departed() {
    departed_.clear();
    if (fds_.empty() || ::poll(fds_.data(), fds_.size(), 0) <= 0) return departed_;
    for (std::size_t i = 0; i < fds_.size(); ++i) {
        if ((fds_[i].revents & gone_[i]) != 0) departed_.push_back(ids_[i]);
    }
    return departed_;
}

}  // namespace server
}  // namespace hapticd
