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

extern char** environ;

namespace clients_test {

inline std::string read_file(const std::string& path) {
    std::ifstream in(path);
    std::stringstream s;
    s << in.rdbuf();
    return s.str();
}

inline std::filesystem::path scratch_dir() {
    const auto dir = std::filesystem::temp_directory_path() / ("hapticd_clients_" + std::to_string(::getpid()));
    std::filesystem::create_directories(dir);
    return dir;
}

class Process {
public:
    Process(const std::string& binary, const std::vector<std::string>& args, const std::string& tag,
            const std::string& stdin_path = "") {
        out_path_ = (scratch_dir() / (tag + ".stdout")).string();
        err_path_ = (scratch_dir() / (tag + ".stderr")).string();
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
    // Exit code, -1 on timeout, 128+signal when killed by a signal.
    int wait(std::chrono::milliseconds timeout = std::chrono::milliseconds(20000)) {
        const auto end = std::chrono::steady_clock::now() + timeout;
        int st = 0;
        while (std::chrono::steady_clock::now() < end) {
            if (::waitpid(pid_, &st, WNOHANG) == pid_) {
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

inline Result run(const std::string& binary, const std::vector<std::string>& args, const std::string& tag,
                  const std::string& stdin_path = "") {
    Process p(binary, args, tag, stdin_path);
    const int code = p.wait();
    return {code, p.out(), p.err()};
}

// hapticd --serve in lockstep on the simulated device: a config wall at x = 5 cm (soft: K = 100 N/m, B = 1
// N s/m, so that client objects along x pass the summed-gain check), the simulated hand starting at
// x = -1 cm and pushing towards +x with 2 N (scenario hold). Runs until SIGTERM.
class LockstepDaemon {
public:
    explicit LockstepDaemon(const std::string& tag)
        : socket_((scratch_dir() / (tag + ".sock")).string()),
          shm_("/hapticd-clients-" + std::to_string(::getpid()) + "-" + tag),
          process_(HAPTICD_BINARY,
                   {"--config", "", "--lockstep", "--serve", "--serve-socket", socket_, "--serve-shm", shm_, "--wall",
                    "axis=0 position=0.05 direction=+1", "--stiffness", "100", "--damping", "1", "--scenario", "hold",
                    "--hold-distance", "0.06", "--hold-force", "2"},
                   tag + "_daemon") {
        // Ready when a connect succeeds (the socket file exists from bind(), before listen()).
        const auto end = std::chrono::steady_clock::now() + std::chrono::seconds(20);
        while (!ready_ && std::chrono::steady_clock::now() < end) {
            ready_ = connectable(socket_);
            if (!ready_) std::this_thread::sleep_for(std::chrono::milliseconds(5));
        }
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
