// SPDX-License-Identifier: Apache-2.0
// The daemon's control socket seen from a test: whether a SOCK_SEQPACKET connect succeeds (the socket file
// exists from bind(), before listen(), so only a connect says the daemon is ready) and waiting for it.
#pragma once

#include <sys/socket.h>
#include <sys/un.h>
#include <unistd.h>

#include <chrono>
#include <cstring>
#include <string>
#include <thread>

namespace hapticd::test {

inline bool connectable(const std::string& path) {
    const int fd = ::socket(AF_UNIX, SOCK_SEQPACKET | SOCK_CLOEXEC, 0);
    if (fd < 0) return false;
    sockaddr_un addr{};
    addr.sun_family = AF_UNIX;
    std::strncpy(addr.sun_path, path.c_str(), sizeof addr.sun_path - 1);
    const bool ok = ::connect(fd, reinterpret_cast<const sockaddr*>(&addr), sizeof addr) == 0;
    ::close(fd);
    return ok;
}

/// True once a connect to `path` succeeds, false after `timeout`.
inline bool wait_for_socket(const std::string& path, std::chrono::duration<double> timeout = std::chrono::seconds(30)) {
    const auto end = std::chrono::steady_clock::now() + timeout;
    while (std::chrono::steady_clock::now() < end) {
        if (connectable(path)) return true;
        std::this_thread::sleep_for(std::chrono::milliseconds(5));
    }
    return false;
}

}  // namespace hapticd::test
