// SPDX-License-Identifier: Apache-2.0
// The lock that keeps two daemons off one control socket (and so off one instance's state segment): an exclusive
// flock(2) on the file SOCKET.lock beside the socket, taken before the socket path is probed and the state segment
// created (server/serve_runtime.hpp), held until the process ends (the kernel releases it when the daemon dies).
// Without it two daemons started at once on one name could both find no socket, and the second could replace the
// first's state segment before its bind failed. The file stays (removing it would race with a starting daemon).
#pragma once

#include <string>

namespace hapticd {

class SocketLock {
  public:
    SocketLock() = default;  // holds nothing
    // Locks SOCKET.lock (created mode 0600 when missing). Throws StartupError: ErrorKind::SocketPathInUse when
    // another process holds it (the message names the socket and the lock), ErrorKind::Server when the file
    // cannot be opened or locked.
    static SocketLock acquire(const std::string& socket_path);
    SocketLock(SocketLock&& other) noexcept;
    SocketLock& operator=(SocketLock&& other) noexcept;
    SocketLock(const SocketLock&) = delete;
    SocketLock& operator=(const SocketLock&) = delete;
    ~SocketLock();

    [[nodiscard]] const std::string& path() const noexcept { return path_; }

  private:
    int fd_ = -1;
    std::string path_;
};

}  // namespace hapticd
