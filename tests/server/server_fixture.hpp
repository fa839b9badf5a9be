// SPDX-License-Identifier: Apache-2.0
// Real processes for the server tests: hapticd --serve on the 3-axis simulated device, and test clients
// (hapticd_test_client, on the client library). Each test gets its own socket path and shared-memory name.
#pragma once

#include <algorithm>

#include <fcntl.h>
#include <poll.h>
#include <signal.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <unistd.h>

#include <chrono>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <optional>
#include <sstream>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "common/process.hpp"
#include "common/test_paths.hpp"
#include "common/unix_socket.hpp"
#include "hapticd/client.hpp"

namespace hapticd::server_test {

namespace cl = hapticd::client;
using nlohmann::json;

using hapticd::test::monotonic_s;
using hapticd::test::wait_for_socket;

inline std::filesystem::path scratch() { return hapticd::test::scratch_dir("hapticd_server_test"); }

inline std::string read_text(const std::string& path) { return hapticd::test::read_file(path); }

// A child process (tests/common/process.hpp) with its output in this suite's scratch directory.
class Child : public hapticd::test::Process {
  public:
    Child(const std::string& binary, const std::vector<std::string>& args, const std::string& tag)
        : Process(binary, args, tag, "", scratch()) {}
    // The first stdout line as JSON, waiting up to timeout_s for it.
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
};

struct Names {
    std::string socket;
    std::string shm;
};

inline Names names(const std::string& tag) {
    return Names{(scratch() / (tag + ".sock")).string(), "/hapticd-test-" + std::to_string(::getpid()) + "-" + tag};
}

// hapticd --serve on tests/server/<profile> (default sim3.toml) with a config wall that is never touched
// (x > 0.05 m), the loop at normal priority (--rt-priority 0) and memory unlocked. The device is free (no
// simulated hand: the analysis' plant of the profile) unless `extra` sets --hand-stiffness. An option in
// `extra` that is also one of these defaults replaces the default (hapticd takes each option once).
inline std::vector<std::string> daemon_args(const Names& n, const std::vector<std::string>& extra,
                                            const std::string& profile = "sim3.toml") {
    const std::vector<std::pair<std::string, std::string>> defaults{
        {"--config", ""},
        {"--device", HAPTICD_SERVER_TEST_DIR + "/" + profile},
        {"--serve-socket", n.socket},
        {"--serve-shm", n.shm},
        {"--rt-priority", "0"},
        {"--mlock", "false"},
        {"--wall", "axis=0 position=0.05 direction=+1"},
        {"--hand-damping", "0"},
        {"--hand-stiffness", "0"}};
    const auto in_extra = [&](const std::string& option) {
        return std::find(extra.begin(), extra.end(), option) != extra.end();
    };
    std::vector<std::string> a{"--serve"};
    for (const auto& [option, value] : defaults) {
        // A simulated hand is one option pair: --hand-stiffness in `extra` leaves --hand-damping to it too.
        const bool hand = option == "--hand-damping" || option == "--hand-stiffness";
        if (in_extra(option) || (hand && in_extra("--hand-stiffness"))) continue;
        a.insert(a.end(), {option, value});
    }
    a.insert(a.end(), extra.begin(), extra.end());
    return a;
}

inline std::vector<std::string> client_args(const Names& n, const json& ops, const std::vector<std::string>& extra) {
    std::vector<std::string> a{n.socket, "commit", ops.dump()};
    a.insert(a.end(), extra.begin(), extra.end());
    return a;
}

// A raw SEQPACKET connection for malformed messages. A reply is waited for up to kReplyTimeoutS by default: a liveness
// guard, not a latency bound. A commit's checks over the plant set take what the scene and the machine make them take
// (an oblique plane beside the config wall, a sum whose gains do not commute: 0.75 s in a release build on an idle
// machine, more than 5 s under ASan + UBSan beside two busy loops).
class RawConnection {
  public:
    static constexpr double kReplyTimeoutS = 60.0;
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
    std::optional<std::string> receive(double timeout_s = kReplyTimeoutS) const {
        pollfd p{fd_, POLLIN, 0};
        if (::poll(&p, 1, static_cast<int>(timeout_s * 1000)) <= 0) return std::nullopt;
        std::string buf(70000, '\0');
        const ssize_t n = ::recv(fd_, buf.data(), buf.size(), 0);
        if (n <= 0) return std::string();
        buf.resize(static_cast<std::size_t>(n));
        return buf;
    }
    json receive_json(double timeout_s = kReplyTimeoutS) const {
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

// The shared daemon's arguments: the step scenario with zero force.
inline std::vector<std::string> step_daemon_args(const Names& n) {
    return daemon_args(n, {"--scenario", "step", "--step-force", "0"});
}

// One hapticd --serve (Args: by default the step scenario, zero force) shared by every test of a suite; it must end
// with exit code 0 on SIGTERM. Tag names its socket, shared memory and log files.
template <const char* Tag, std::vector<std::string> (*Args)(const Names&) = step_daemon_args>
class SharedDaemonTest : public ::testing::Test {
  protected:
    static void SetUpTestSuite() {
        n_ = new Names(names(Tag));
        daemon_ = new Child(HAPTICD_BINARY, Args(*n_), std::string(Tag) + "_daemon");
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
    return json{{"kind", "plane"},
                {"normal", n},
                {"offset", offset},
                {"mode", bilateral ? "bilateral" : "unilateral"},
                {"gains", gains}};
}

}  // namespace hapticd::server_test
