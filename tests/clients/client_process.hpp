// SPDX-License-Identifier: Apache-2.0
// Runs a program as a child process (posix_spawn) with stdout/stderr captured to files, and a hapticd
// --serve daemon in lockstep for the client tests (stopped with SIGTERM).
#pragma once

#include <fcntl.h>
#include <signal.h>
#include <spawn.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "../daemon/process_runner.hpp"

namespace clients_test {

using hapticd::test::read_file;
using hapticd::test::Result;

inline std::filesystem::path scratch_dir() {
    const auto dir = std::filesystem::temp_directory_path() / ("hapticd_clients_" + std::to_string(::getpid()));
    std::filesystem::create_directories(dir);
    return dir;
}

// A program as a child process (tests/daemon/process_runner.hpp), its output in this suite's scratch directory.
class Process : public hapticd::test::Process {
public:
    Process(const std::string& binary, const std::vector<std::string>& args, const std::string& tag,
            const std::string& stdin_path = "")
        : hapticd::test::Process(binary, args, tag, stdin_path, scratch_dir()) {}
};

inline Result run(const std::string& binary, const std::vector<std::string>& args, const std::string& tag,
                  const std::string& stdin_path = "") {
    Process p(binary, args, tag, stdin_path);
    const int code = p.wait();
    return {code, p.out(), p.err()};
}

// hapticd --serve in lockstep on the simulated device: a config wall at x = 5 cm (soft: K = 100 N/m, B = 1
// N s/m, so that client objects along x pass the summed-gain check), the simulated hand holding the handle
// at x = -5 mm and pushing towards +x with 2 N (scenario hold). Runs until SIGTERM.
class LockstepDaemon {
public:
    // extra: more hapticd arguments (e.g. --device PROFILE).
    explicit LockstepDaemon(const std::string& tag, const std::vector<std::string>& extra = {})
        : socket_((scratch_dir() / (tag + ".sock")).string()),
          shm_("/hapticd-clients-" + std::to_string(::getpid()) + "-" + tag),
          process_(HAPTICD_BINARY, arguments(socket_, shm_, extra), tag + "_daemon") {
        // Ready when a connect succeeds (the socket file exists from bind(), before listen()).
        const auto end = std::chrono::steady_clock::now() + std::chrono::seconds(20);
        while (!ready_ && std::chrono::steady_clock::now() < end) {
            ready_ = connectable(socket_);
            if (!ready_) std::this_thread::sleep_for(std::chrono::milliseconds(5));
        }
    }
    static std::vector<std::string> arguments(const std::string& socket, const std::string& shm, const std::vector<std::string>& extra) {
        std::vector<std::string> a{"--config", "", "--lockstep", "--serve", "--serve-socket", socket, "--serve-shm", shm, "--wall",
                                   "axis=0 position=0.05 direction=+1", "--stiffness", "100", "--damping", "1", "--scenario", "hold",
                                   "--hold-distance", "0.055", "--hold-force", "2"};
        a.insert(a.end(), extra.begin(), extra.end());
        return a;
    }
    static bool connectable(const std::string& path) {
        const int fd = ::socket(AF_UNIX, SOCK_SEQPACKET | SOCK_CLOEXEC, 0);
        sockaddr_un addr{};
        addr.sun_family = AF_UNIX;
        std::strncpy(addr.sun_path, path.c_str(), sizeof addr.sun_path - 1);
        const bool ok = fd >= 0 && ::connect(fd, reinterpret_cast<const sockaddr*>(&addr), sizeof addr) == 0;
        if (fd >= 0) ::close(fd);
        return ok;
    }
    ~LockstepDaemon() { stop(); }
    int stop() {
        if (stopped_) return code_;
        stopped_ = true;
        ::kill(process_.pid(), SIGTERM);
        code_ = process_.wait();
        return code_;
    }
    [[nodiscard]] bool ready() const { return ready_; }
    [[nodiscard]] const std::string& socket() const { return socket_; }
    [[nodiscard]] const std::string& shm() const { return shm_; }
    [[nodiscard]] std::string log() const { return process_.out() + process_.err(); }

private:
    std::string socket_;
    std::string shm_;
    Process process_;
    bool ready_ = false;
    bool stopped_ = false;
    int code_ = -1;
};

inline std::string write_file(const std::string& name, const std::string& text) {
    const auto path = scratch_dir() / name;
    std::ofstream(path) << text;
    return path.string();
}

}  // namespace clients_test
