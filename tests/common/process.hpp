// SPDX-License-Identifier: Apache-2.0
// A program as a child process of a test (posix_spawn, the test's environment): stdin from a file or
// /dev/null, stdout and stderr in files of a scratch directory, a bounded wait (the child is killed with
// SIGKILL on destruction if it still runs), and the small file helpers the process tests share.
#pragma once

#include <fcntl.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <optional>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "common/test_paths.hpp"

extern char** environ;

namespace hapticd::test {

/// temp_directory_path()/<prefix>_<pid>, created; one per test process, so parallel ctest runs never share it.
inline std::filesystem::path scratch_dir(const std::string& prefix = "hapticd_test") {
    const auto dir = std::filesystem::temp_directory_path() / (prefix + "_" + std::to_string(::getpid()));
    std::filesystem::create_directories(dir);
    return dir;
}

/// The whole file ("" when it cannot be read).
inline std::string read_file(const std::string& path) {
    std::ifstream in(path);
    std::stringstream s;
    s << in.rdbuf();
    return s.str();
}

/// Writes `text` to <dir>/<name> and returns the path.
inline std::string write_file(const std::string& name, const std::string& text,
                              const std::filesystem::path& dir = scratch_dir()) {
    const auto path = dir / name;
    std::ofstream(path) << text;
    return path.string();
}

/// CLOCK_MONOTONIC in seconds.
inline double monotonic_s() {
    timespec ts{};
    ::clock_gettime(CLOCK_MONOTONIC, &ts);
    return static_cast<double>(ts.tv_sec) + 1e-9 * static_cast<double>(ts.tv_nsec);
}

class Process {
  public:
    /// Starts `binary` with `args`; stdin from `stdin_path` ("": /dev/null); stdout and stderr in
    /// <dir>/<tag>.stdout and <dir>/<tag>.stderr. pid() is -1 when posix_spawn failed.
    Process(const std::string& binary, const std::vector<std::string>& args, const std::string& tag,
            const std::string& stdin_path = "", const std::filesystem::path& dir = scratch_dir()) {
        out_path_ = (dir / (tag + ".stdout")).string();
        err_path_ = (dir / (tag + ".stderr")).string();
        std::vector<std::string> full{binary};
        full.insert(full.end(), args.begin(), args.end());
        std::vector<char*> argv;
        for (auto& a : full) argv.push_back(a.data());
        argv.push_back(nullptr);
        posix_spawn_file_actions_t fa;
        posix_spawn_file_actions_init(&fa);
        posix_spawn_file_actions_addopen(&fa, 0, stdin_path.empty() ? "/dev/null" : stdin_path.c_str(), O_RDONLY, 0);
        posix_spawn_file_actions_addopen(&fa, 1, out_path_.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
        posix_spawn_file_actions_addopen(&fa, 2, err_path_.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
        if (posix_spawn(&pid_, binary.c_str(), &fa, nullptr, argv.data(), environ) != 0) pid_ = -1;
        posix_spawn_file_actions_destroy(&fa);
    }
#ifdef HAPTICD_BINARY
    /// hapticd (HAPTICD_BINARY, defined by the test target) with `args`; output in scratch_dir().
    Process(const std::vector<std::string>& args, const std::string& tag) : Process(HAPTICD_BINARY, args, tag) {}
#endif
    Process(const Process&) = delete;
    Process& operator=(const Process&) = delete;
    ~Process() {
        if (pid_ > 0 && !reaped_) {
            ::kill(pid_, SIGKILL);
            int st = 0;
            ::waitpid(pid_, &st, 0);
        }
    }

    [[nodiscard]] pid_t pid() const { return pid_; }
    void signal(int signal_number) const {
        if (pid_ > 0 && !reaped_) ::kill(pid_, signal_number);
    }

    /// The exit code, 128 + the signal when a signal ended it, or -1 when it still runs after `timeout`.
    int wait(std::chrono::duration<double> timeout = std::chrono::seconds(30)) {
        const auto end = std::chrono::steady_clock::now() + timeout;
        while (running()) {
            if (std::chrono::steady_clock::now() >= end) return -1;
            std::this_thread::sleep_for(std::chrono::milliseconds(2));
        }
        return code_;
    }
    /// False once the child has ended (it is then reaped, and wait() returns its code at once).
    [[nodiscard]] bool running() {
        if (reaped_ || pid_ <= 0) return false;
        int st = 0;
        if (::waitpid(pid_, &st, WNOHANG) != pid_) return true;
        reaped_ = true;
        code_ = WIFEXITED(st) ? WEXITSTATUS(st) : WIFSIGNALED(st) ? 128 + WTERMSIG(st) : -2;
        return false;
    }

    [[nodiscard]] std::string out() const { return read_file(out_path_); }
    [[nodiscard]] std::string err() const { return read_file(err_path_); }

  private:
    pid_t pid_ = -1;
    bool reaped_ = false;
    int code_ = -1;
    std::string out_path_;
    std::string err_path_;
};

struct Result {
    int code;
    std::string out;
    std::string err;
};

/// Runs `binary` to its end (at most 30 s) and returns its code and output.
inline Result run(const std::string& binary, const std::vector<std::string>& args, const std::string& tag,
                  const std::string& stdin_path = "", const std::filesystem::path& dir = scratch_dir()) {
    Process p(binary, args, tag, stdin_path, dir);
    const int code = p.wait();
    return {code, p.out(), p.err()};
}

#ifdef HAPTICD_BINARY
/// Runs hapticd (HAPTICD_BINARY) to its end (at most 30 s).
inline Result run(const std::vector<std::string>& args, const std::string& tag) {
    return run(HAPTICD_BINARY, args, tag);
}
#endif

}  // namespace hapticd::test
