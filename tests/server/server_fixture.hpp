// SPDX-License-Identifier: Apache-2.0
// Real processes for the server tests: hapticd --serve on the 3-axis simulated device, and test clients
// (hapticd_test_client, on the client library). Each test gets its own socket path and shared-memory name.
#pragma once

#include <algorithm>

#include <fcntl.h>
#include <poll.h>
#include <signal.h>
#include <spawn.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>

#include <chrono>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <optional>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "hapticd/client.hpp"

extern char** environ;

namespace hapticd::server_test {

namespace cl = hapticd::client;
using nlohmann::json;

inline std::filesystem::path scratch() {
    const auto d = std::filesystem::temp_directory_path() / ("hapticd_server_test_" + std::to_string(::getpid()));
    std::filesystem::create_directories(d);
    return d;
}

inline std::string read_text(const std::string& path) {
    std::ifstream in(path);
    std::stringstream s;
    s << in.rdbuf();
    return s.str();
}

inline double monotonic_s() {
    timespec ts{};
    ::clock_gettime(CLOCK_MONOTONIC, &ts);
    return static_cast<double>(ts.tv_sec) + 1e-9 * static_cast<double>(ts.tv_nsec);
}

// A child process with stdout/stderr in files.
class Child {
public:
    Child(const std::string& binary, const std::vector<std::string>& args, const std::string& tag) {
        out_ = (scratch() / (tag + ".out")).string();
        err_ = (scratch() / (tag + ".err")).string();
        std::vector<std::string> full{binary};
        full.insert(full.end(), args.begin(), args.end());
        std::vector<char*> argv;
        for (auto& a : full) argv.push_back(a.data());
        argv.push_back(nullptr);
        posix_spawn_file_actions_t fa;
        posix_spawn_file_actions_init(&fa);
        posix_spawn_file_actions_addopen(&fa, 1, out_.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
        posix_spawn_file_actions_addopen(&fa, 2, err_.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
        if (posix_spawn(&pid_, binary.c_str(), &fa, nullptr, argv.data(), environ) != 0) pid_ = -1;
        posix_spawn_file_actions_destroy(&fa);
    }
    Child(const Child&) = delete;
    Child& operator=(const Child&) = delete;
    ~Child() {
        if (pid_ > 0 && !reaped_) {
            ::kill(pid_, SIGKILL);
            int st = 0;
            ::waitpid(pid_, &st, 0);
        }
    }
    [[nodiscard]] pid_t pid() const { return pid_; }
    void signal(int s) const { ::kill(pid_, s); }
    // Exit code, 128 + signal, or -1 on timeout.
    int wait(double timeout_s = 30.0) {
        const double end = monotonic_s() + timeout_s;
        int st = 0;
        while (monotonic_s() < end) {
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
    [[nodiscard]] bool running() {
        int st = 0;
        if (reaped_) return false;
        if (::waitpid(pid_, &st, WNOHANG) == pid_) {
            reaped_ = true;
            return false;
        }
        return true;
    }
    [[nodiscard]] std::string out() const { return read_text(out_); }
    [[nodiscard]] std::string err() const { return read_text(err_); }
    // The first stdout line, waiting up to timeout_s for it.
    std::optional<json> first_line(double timeout_s = 20.0) const {
        const double end = monotonic_s() + timeout_s;
        while (monotonic_s() < end) {
            const std::string text = out();
            const auto nl = text.find('\n');
            if (nl != std::string::npos) return json::parse(text.substr(0, nl), nullptr, false);
            std::this_thread::sleep_for(std::chrono::milliseconds(5));
        }
        return std::nullopt;
    }

private:
    pid_t pid_ = -1;
    bool reaped_ = false;
    std::string out_, err_;
};

struct Names {
    std::string socket;
    std::string shm;
};

inline Names names(const std::string& tag) {
    return Names{(scratch() / (tag + ".sock")).string(), "/hapticd-test-" + std::to_string(::getpid()) + "-" + tag};
}

// hapticd --serve on tests/server/<profile> (default sim3.toml) with a config wall that is never touched
// (x > 0.05 m). The device is free (no simulated hand: the analysis' plant of the profile) unless `extra`
// sets --hand-stiffness.
inline std::vector<std::string> daemon_args(const Names& n, const std::vector<std::string>& extra,
                                            const std::string& profile = "sim3.toml") {
    std::vector<std::string> a{"--config", "", "--device", std::string(HAPTICD_SERVER_TEST_DIR "/") + profile, "--serve",
                               "--serve-socket", n.socket, "--serve-shm", n.shm, "--rt-priority", "0", "--mlock", "false",
                               "--wall", "axis=0 position=0.05 direction=+1"};
    if (std::find(extra.begin(), extra.end(), "--hand-stiffness") == extra.end()) {
        a.insert(a.end(), {"--hand-damping", "0", "--hand-stiffness", "0"});
    }
    a.insert(a.end(), extra.begin(), extra.end());
    return a;
}

// Waits until the daemon's socket accepts a connection (it is created before the loop starts).
inline bool wait_for_socket(const std::string& path, double timeout_s = 30.0) {
    const double end = monotonic_s() + timeout_s;
    while (monotonic_s() < end) {
        if (std::filesystem::exists(path)) {
            const int fd = ::socket(AF_UNIX, SOCK_SEQPACKET, 0);
            sockaddr_un addr{};
            addr.sun_family = AF_UNIX;
            std::strncpy(addr.sun_path, path.c_str(), sizeof(addr.sun_path) - 1);
            const bool ok = ::connect(fd, reinterpret_cast<const sockaddr*>(&addr), sizeof(addr)) == 0;
            ::close(fd);
            if (ok) return true;
        }
        std::this_thread::sleep_for(std::chrono::milliseconds(10));
    }
    return false;
}

inline std::vector<std::string> client_args(const Names& n, const json& ops, const std::vector<std::string>& extra) {
    std::vector<std::string> a{n.socket, "commit", ops.dump()};
    a.insert(a.end(), extra.begin(), extra.end());
    return a;
}

// A raw SEQPACKET connection for malformed messages.
class RawConnection {
public:
    explicit RawConnection(const std::string& path) {
        fd_ = ::socket(AF_UNIX, SOCK_SEQPACKET, 0);
        sockaddr_un addr{};
        addr.sun_family = AF_UNIX;
        std::strncpy(addr.sun_path, path.c_str(), sizeof(addr.sun_path) - 1);
        connected_ = ::connect(fd_, reinterpret_cast<const sockaddr*>(&addr), sizeof(addr)) == 0;
    }
    ~RawConnection() { ::close(fd_); }
    RawConnection(const RawConnection&) = delete;
    RawConnection& operator=(const RawConnection&) = delete;
    [[nodiscard]] bool connected() const { return connected_; }
    void send(const std::string& bytes) const { (void)::send(fd_, bytes.data(), bytes.size(), MSG_NOSIGNAL); }
    // One message; std::nullopt on timeout; "" on EOF.
    std::optional<std::string> receive(double timeout_s = 5.0) const {
        pollfd p{fd_, POLLIN, 0};
        if (::poll(&p, 1, static_cast<int>(timeout_s * 1000)) <= 0) return std::nullopt;
        std::string buf(70000, '\0');
        const ssize_t n = ::recv(fd_, buf.data(), buf.size(), 0);
        if (n <= 0) return std::string();
        buf.resize(static_cast<std::size_t>(n));
        return buf;
    }
    json receive_json(double timeout_s = 5.0) const {
        const auto m = receive(timeout_s);
        if (!m) return json{{"timeout", true}};
        if (m->empty()) return json{{"eof", true}};
        return json::parse(*m, nullptr, false);
    }
    void hello() const {
        send(R"({"type":"hello","protocol":1,"client":"raw"})");
        const json w = receive_json();
        EXPECT_EQ(w.value("type", ""), "welcome") << w.dump();
    }

private:
    int fd_ = -1;
    bool connected_ = false;
};

// Polls the shared-memory state until pred(sample) or the timeout.
template <class Pred>
std::optional<cl::StateSample> wait_state(const cl::StateReader& r, Pred pred, double timeout_s) {
    const double end = monotonic_s() + timeout_s;
    cl::StateSample s;
    while (monotonic_s() < end) {
        if (r.read(s) && pred(s)) return s;
        std::this_thread::sleep_for(std::chrono::microseconds(100));
    }
    return std::nullopt;
}

// One hapticd --serve (step scenario, zero force) shared by every test of a suite; it must end with exit
// code 0 on SIGTERM. Tag names its socket, shared memory and log files.
template <const char* Tag>
class SharedDaemonTest : public ::testing::Test {
protected:
    static void SetUpTestSuite() {
        n_ = new Names(names(Tag));
        daemon_ = new Child(HAPTICD_BINARY, daemon_args(*n_, {"--scenario", "step", "--step-force", "0"}), std::string(Tag) + "_daemon");
        ASSERT_TRUE(wait_for_socket(n_->socket)) << daemon_->err();
    }
    static void TearDownTestSuite() {
        daemon_->signal(SIGTERM);
        EXPECT_EQ(daemon_->wait(), 0) << daemon_->err();
        delete daemon_;
        delete n_;
    }
    static inline Names* n_ = nullptr;
    static inline Child* daemon_ = nullptr;
};

inline json plane(const std::array<double, 3>& n, double offset, const json& gains, bool bilateral = false) {
    return json{{"kind", "plane"}, {"normal", n}, {"offset", offset}, {"mode", bilateral ? "bilateral" : "unilateral"}, {"gains", gains}};
}

}  // namespace hapticd::server_test
