// SPDX-License-Identifier: Apache-2.0
// The client programs' tests: programs as child processes in this suite's scratch directory, and a hapticd
// --serve daemon in lockstep (stopped with SIGTERM).
#pragma once

#include <signal.h>

#include <chrono>
#include <filesystem>
#include <string>
#include <thread>
#include <vector>

#include "common/process.hpp"
#include "common/test_paths.hpp"
#include "common/unix_socket.hpp"

namespace clients_test {

using hapticd::test::read_file;
using hapticd::test::Result;

inline std::filesystem::path scratch_dir() { return hapticd::test::scratch_dir("hapticd_clients"); }

// A program as a child process (tests/common/process.hpp), its output in this suite's scratch directory.
class Process : public hapticd::test::Process {
  public:
    Process(const std::string& binary, const std::vector<std::string>& args, const std::string& tag,
            const std::string& stdin_path = "")
        : hapticd::test::Process(binary, args, tag, stdin_path, scratch_dir()) {}
};

inline Result run(const std::string& binary, const std::vector<std::string>& args, const std::string& tag,
                  const std::string& stdin_path = "") {
    return hapticd::test::run(binary, args, tag, stdin_path, scratch_dir());
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
        ready_ = hapticd::test::wait_for_socket(socket_, std::chrono::seconds(20));
    }
    static std::vector<std::string> arguments(const std::string& socket, const std::string& shm,
                                              const std::vector<std::string>& extra) {
        std::vector<std::string> a{"--config",        "",
                                   "--lockstep",      "--serve",
                                   "--serve-socket",  socket,
                                   "--serve-shm",     shm,
                                   "--wall",          "axis=0 position=0.05 direction=+1",
                                   "--stiffness",     "100",
                                   "--damping",       "1",
                                   "--scenario",      "hold",
                                   "--hold-distance", "0.055",
                                   "--hold-force",    "2"};
        a.insert(a.end(), extra.begin(), extra.end());
        return a;
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
    return hapticd::test::write_file(name, text, scratch_dir());
}

}  // namespace clients_test
