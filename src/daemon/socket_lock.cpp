// SPDX-License-Identifier: Apache-2.0
#include "daemon/socket_lock.hpp"

#include <fcntl.h>
#include <sys/file.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <utility>

#include "common/startup_error.hpp"

namespace hapticd {

SocketLock SocketLock::acquire(const std::string& socket_path) {
    SocketLock lock;
    lock.path_ = socket_path + ".lock";
    lock.fd_ = ::open(lock.path_.c_str(), O_RDWR | O_CREAT | O_CLOEXEC | O_NOFOLLOW, 0600);
    if (lock.fd_ < 0) {
        throw StartupError(ErrorKind::Server, "socket lock '" + lock.path_ + "' of --serve-socket '" + socket_path +
                                                  "': open: " + std::strerror(errno));
    }
    if (::flock(lock.fd_, LOCK_EX | LOCK_NB) != 0) {
        const int e = errno;
        if (e == EWOULDBLOCK) {
            throw StartupError(ErrorKind::SocketPathInUse,
                               "socket path '" + socket_path + "' is in use: another process holds its lock '" +
                                   lock.path_ +
                                   "' (another hapticd with the same --instance or --serve-socket?); stop it or "
                                   "choose another --instance or --serve-socket");
        }
        throw StartupError(ErrorKind::Server, "socket lock '" + lock.path_ + "': flock: " + std::strerror(e));
    }
    return lock;
}

SocketLock::SocketLock(SocketLock&& other) noexcept
    : fd_(std::exchange(other.fd_, -1)), path_(std::move(other.path_)) {}

SocketLock& SocketLock::operator=(SocketLock&& other) noexcept {
    if (this != &other) {
        if (fd_ >= 0) ::close(fd_);
        fd_ = std::exchange(other.fd_, -1);
        path_ = std::move(other.path_);
    }
    return *this;
}

SocketLock::~SocketLock() {
    if (fd_ >= 0) ::close(fd_);
}

}  // namespace hapticd
