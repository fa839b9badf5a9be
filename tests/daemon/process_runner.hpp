// SPDX-License-Identifier: Apache-2.0
// Runs hapticd (or another program) as a child process (posix_spawn), with stdout/stderr captured to files.
#pragma once

#include <fcntl.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

extern char** environ;

namespace hapticd::test {

inline std::string read_file(const std::string& path) {
    std::ifstream in(path);
    std::stringstream s;
    s << in.rdbuf();
    return s.str();
}

inline std::filesystem::path scratch_dir() {
    const auto dir = std::filesystem::temp_directory_path() /
                     ("hapticd_test_" + std::to_string(::getpid()));
    std::filesystem::create_directories(dir);
    return dir;
}

class Process {
public:
    // hapticd (HAPTICD_BINARY) with `args`; stdout and stderr in scratch_dir()/<tag>.stdout|.stderr.
    explicit Process(const std::vector<std::string>& args, const std::string& tag) : Process(HAPTICD_BINARY, args, tag) {}
    // Any program; stdin from `stdin_path` ("": /dev/null), stdout and stderr in <dir>/<tag>.stdout|.stderr.
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

    // Exit code, or -1 on timeout (the process is then killed), or 128+signal when killed by a signal.
    int wait(std::chrono::milliseconds timeout = std::chrono::milliseconds(20000)) {
        const auto end = std::chrono::steady_clock::now() + timeout;
        int st = 0;
        while (std::chrono::steady_clock::now() < end) {
            const pid_t r = ::waitpid(pid_, &st, WNOHANG);
            if (r == pid_) {
                reaped_ = true;
                if (WIFEXITED(st)) return WEXITSTATUS(st);
                if (WIFSIGNALED(st)) return 128 + WTERMSIG(st);
                return -2;
            }
            std::this_thread::sleep_for(std::chrono::milliseconds(2));
        }
        return -1;
    }

    [[nodiscard]] std::string out() const { return read_file(out_path_); }
    [[nodiscard]] std::string err() const { return read_file(err_path_); }

private:
    pid_t pid_ = -1;
    bool reaped_ = false;
    std::string out_path_;
    std::string err_path_;
};

struct Result {
    int code;
    std::string out;
    std::string err;
};

inline Result run(const std::vector<std::string>& args, const std::string& tag) {
    Process p(args, tag);
    const int code = p.wait();
    return {code, p.out(), p.err()};
}

inline std::string write_file(const std::string& name, const std::string& text) {
    const auto path = scratch_dir() / name;
    std::ofstream(path) << text;
    return path.string();
}

}  // namespace hapticd::test
