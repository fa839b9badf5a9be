// SPDX-License-Identifier: Apache-2.0
// hapticd under systemd's notify protocol, for real: the test owns the datagram socket that NOTIFY_SOCKET
// names (as systemd's manager does), sets WATCHDOG_USEC, runs the hapticd binary and reads what it sends.
//  * READY=1 comes once, after the tuning (its line is already on stdout) and only when the device opened
//    (a missing device or refused gains: no READY=1 at all);
//  * WATCHDOG=1 keeps coming while the loop runs, from a thread that is not real-time;
//  * WATCHDOG=1 stops while the loop stalls and comes back when it advances again. The stall is real: in
//    lockstep the trace ring is blocking, so a trace written into a FIFO that the test stops reading halts
//    the loop after the pipe, stdio's buffer and the ring are full (a few hundred ticks);
//  * STOPPING=1 ends the conversation.
#include <fcntl.h>
#include <poll.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/un.h>
#include <unistd.h>

#include <gtest/gtest.h>

#include <chrono>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

#include "daemon/exit_codes.hpp"
#include "common/process.hpp"

namespace hapticd {
namespace {

using Clock = std::chrono::steady_clock;
using std::chrono::milliseconds;

struct Notification {
    Clock::time_point at;
    std::string text;
};

// The service manager's end: a bound AF_UNIX datagram socket.
class NotifyListener {
  public:
    explicit NotifyListener(const std::string& path) : path_(path) {
        std::filesystem::remove(path_);
        fd_ = ::socket(AF_UNIX, SOCK_DGRAM | SOCK_CLOEXEC, 0);
        sockaddr_un addr{};
        addr.sun_family = AF_UNIX;
        std::strncpy(addr.sun_path, path_.c_str(), sizeof addr.sun_path - 1);
        bound_ = fd_ >= 0 && ::bind(fd_, reinterpret_cast<const sockaddr*>(&addr), sizeof addr) == 0;
    }
    NotifyListener(const NotifyListener&) = delete;
    NotifyListener& operator=(const NotifyListener&) = delete;
    ~NotifyListener() {
        if (fd_ >= 0) ::close(fd_);
        std::filesystem::remove(path_);
    }
    [[nodiscard]] bool ok() const { return bound_; }
    [[nodiscard]] int fd() const { return fd_; }

    // Reads every datagram that is waiting (non-blocking).
    void drain(std::vector<Notification>& into) const {
        char buf[4096];
        for (;;) {
            const ssize_t n = ::recv(fd_, buf, sizeof buf, MSG_DONTWAIT);
            if (n <= 0) return;
            into.push_back({Clock::now(), std::string(buf, static_cast<std::size_t>(n))});
        }
    }

  private:
    std::string path_;
    int fd_ = -1;
    bool bound_ = false;
};

bool starts_with(const std::string& s, const char* prefix) { return s.rfind(prefix, 0) == 0; }

std::size_t count_prefix(const std::vector<Notification>& v, const char* prefix,
                         Clock::time_point from = Clock::time_point::min(),
                         Clock::time_point to = Clock::time_point::max()) {
    std::size_t n = 0;
    for (const auto& m : v) {
        if (starts_with(m.text, prefix) && m.at >= from && m.at <= to) ++n;
    }
    return n;
}

// Sets NOTIFY_SOCKET and WATCHDOG_USEC for the child processes the test starts (posix_spawn passes environ on)
// and removes them afterwards, so no other test of this binary sees them.
class SystemdNotify : public ::testing::Test {
  protected:
    // 100 ms: hapticd checks its heartbeat every 50 ms (half of it, as sd_watchdog_enabled(3) recommends).
    static constexpr long kWatchdogUsec = 100000;

    void SetUp() override {
        socket_path_ = (test::scratch_dir() /
                        ("notify_" + std::string(::testing::UnitTest::GetInstance()->current_test_info()->name())))
                           .string();
        listener_ = std::make_unique<NotifyListener>(socket_path_);
        ASSERT_TRUE(listener_->ok()) << "bind " << socket_path_ << ": " << std::strerror(errno);
        ::setenv("NOTIFY_SOCKET", socket_path_.c_str(), 1);
        ::setenv("WATCHDOG_USEC", std::to_string(kWatchdogUsec).c_str(), 1);
        ::unsetenv("WATCHDOG_PID");
    }
    void TearDown() override {
        ::unsetenv("NOTIFY_SOCKET");
        ::unsetenv("WATCHDOG_USEC");
        listener_.reset();
    }

    // Collects notifications until the process exits (or the timeout); returns its exit code.
    int collect_until_exit(test::Process& p, std::vector<Notification>& got,
                           milliseconds timeout = milliseconds(20000)) {
        const auto end = Clock::now() + timeout;
        int code = -1;
        while (Clock::now() < end) {
            listener_->drain(got);
            code = p.wait(milliseconds(5));
            if (code != -1) break;
        }
        listener_->drain(got);  // datagrams sent just before the exit
        return code;
    }

    std::string socket_path_;
    std::unique_ptr<NotifyListener> listener_;
};

std::vector<std::string> base_args(std::initializer_list<std::string> extra) {
    std::vector<std::string> a{"--config", ""};
    a.insert(a.end(), extra);
    return a;
}

// Scheduling policy (field 41 of /proc/<pid>/task/<tid>/stat) of the thread named `name`; -1 if none.
int thread_policy(pid_t pid, const std::string& name) {
    const std::filesystem::path tasks = "/proc/" + std::to_string(pid) + "/task";
    std::error_code ec;
    for (const auto& t : std::filesystem::directory_iterator(tasks, ec)) {
        std::string comm = test::read_file((t.path() / "comm").string());
        while (!comm.empty() && comm.back() == '\n') comm.pop_back();
        if (comm != name) continue;
        const std::string stat = test::read_file((t.path() / "stat").string());
        const auto close_paren = stat.rfind(')');
        if (close_paren == std::string::npos) return -1;
        std::istringstream fields(stat.substr(close_paren + 2));  // field 3 onwards
        std::string f;
        for (int i = 3; i <= 41 && fields >> f; ++i) {
            if (i == 41) return std::stoi(f);
        }
    }
    return -1;
}

TEST_F(SystemdNotify, ReadyAfterTuningAndOpenThenWatchdogWhileTheLoopRuns) {
    // A real-time run of 1.5 s at 1 kHz (SCHED_FIFO when permitted, as under the unit's LimitRTPRIO), the
    // daemon's own overrun watchdog relaxed so that a loaded test machine cannot end the run early.
    test::Process p(base_args({"--criterion", "CE2", "--duration", "1.5", "--watchdog-overruns", "1000000",
                               "--watchdog-stall-periods", "1000000"}),
                    "notify_run");
    ASSERT_GT(p.pid(), 0);
    std::vector<Notification> got;
    std::string stdout_at_ready;
    int keepalive_thread_policy = -2;
    const auto end = Clock::now() + milliseconds(20000);
    int code = -1;
    while (Clock::now() < end) {
        const std::size_t before = got.size();
        listener_->drain(got);
        for (std::size_t i = before; i < got.size(); ++i) {
            if (starts_with(got[i].text, "READY=1")) stdout_at_ready = p.out();
            if (starts_with(got[i].text, "WATCHDOG=1") && keepalive_thread_policy == -2) {
                keepalive_thread_policy = thread_policy(p.pid(), "hapticd-wdog");
            }
        }
        code = p.wait(milliseconds(5));
        if (code != -1) break;
    }
    listener_->drain(got);
    ASSERT_EQ(code, kExitOk) << p.err();

    ASSERT_FALSE(got.empty());
    EXPECT_EQ(count_prefix(got, "READY=1"), 1U);
    ASSERT_TRUE(starts_with(got.front().text, "READY=1")) << got.front().text;
    // The STATUS line names the device and the tuned gains; the tuning was printed before READY=1.
    EXPECT_NE(got.front().text.find("STATUS=device 'sim' open and homed"), std::string::npos) << got.front().text;
    EXPECT_NE(got.front().text.find("tuned for CE2: K = "), std::string::npos) << got.front().text;
    EXPECT_NE(stdout_at_ready.find("tuned for CE2: K = "), std::string::npos) << stdout_at_ready;
    const auto k_at = got.front().text.find("K = ");
    ASSERT_NE(k_at, std::string::npos);
    const std::string k_text = got.front().text.substr(k_at, got.front().text.find(',', k_at) - k_at);
    EXPECT_NE(p.out().find(k_text), std::string::npos) << "the STATUS gains are the printed ones: " << k_text;

    ASSERT_TRUE(starts_with(got.back().text, "STOPPING=1")) << got.back().text;
    EXPECT_EQ(count_prefix(got, "STOPPING=1"), 1U);
    // 1.5 s of loop with a check every 50 ms gives ~30 keep-alives on an idle machine. At least 5: the
    // keep-alive thread is SCHED_OTHER and the test machine's 2 cores are shared by parallel builds, so it
    // may be starved for a while; what is checked is that the keep-alive keeps coming, not its period.
    const std::size_t keepalives = count_prefix(got, "WATCHDOG=1");
    EXPECT_GE(keepalives, 5U);
    for (std::size_t i = 1; i + 1 < got.size(); ++i) {
        EXPECT_EQ(got[i].text, "WATCHDOG=1") << "between READY=1 and STOPPING=1 only keep-alives, got: " << got[i].text;
    }
    // The keep-alive thread is not real-time (policy 0 = SCHED_OTHER), whatever the loop thread got.
    EXPECT_EQ(keepalive_thread_policy, 0);
}

TEST_F(SystemdNotify, NoReadyWhenTheDeviceIsMissingOrTheGainsAreRefused) {
    {
        // The tuning succeeds, then the Falcon cannot be found: exit 6, and systemd never hears READY=1.
        test::Process p(base_args({"--device", "falcon", "--criterion", "CE2", "--duration", "1"}), "notify_nodevice");
        std::vector<Notification> got;
        EXPECT_EQ(collect_until_exit(p, got), kExitDeviceError) << p.err();
        EXPECT_NE(p.out().find("tuned for CE2"), std::string::npos) << "the tuning ran before the device failed";
        EXPECT_EQ(count_prefix(got, "READY=1"), 0U);
        EXPECT_EQ(count_prefix(got, "WATCHDOG=1"), 0U);
    }
    {
        // Explicit gains outside the stability region: exit 5 before the device is touched, no READY=1.
        test::Process p(base_args({"--stiffness", "1e9", "--damping", "0", "--duration", "1"}), "notify_unstable");
        std::vector<Notification> got;
        EXPECT_EQ(collect_until_exit(p, got), kExitUnstableGains) << p.err();
        EXPECT_TRUE(got.empty()) << got.front().text;
    }
}

TEST_F(SystemdNotify, WatchdogStopsWhileTheLoopStallsAndResumesWithIt) {
    const std::string fifo = (test::scratch_dir() / "notify_stall.fifo").string();
    std::filesystem::remove(fifo);
    ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0) << std::strerror(errno);
    // The read end is open before hapticd opens the write end (so its fopen does not wait for a reader).
    const int trace_fd = ::open(fifo.c_str(), O_RDONLY | O_NONBLOCK | O_CLOEXEC);
    ASSERT_GE(trace_fd, 0) << std::strerror(errno);
    // Lockstep: ticks back to back, paced only by the blocking trace ring; 10^6 s of ticks (10^9) is far more than
    // the test lets it run, SIGTERM ends it.
    test::Process p(base_args({"--lockstep", "--stiffness", "3000", "--damping", "10", "--duration", "1e6", "--trace",
                               fifo, "--trace-capacity", "64"}),
                    "notify_stall");
    ASSERT_GT(p.pid(), 0);
    std::vector<Notification> got;
    std::size_t trace_bytes = 0;
    // Reads the trace (the loop advances) and/or the notifications for `span`.
    auto pump = [&](milliseconds span, bool read_trace) {
        const auto end = Clock::now() + span;
        char buf[65536];
        while (Clock::now() < end) {
            pollfd fds[2] = {{listener_->fd(), POLLIN, 0}, {trace_fd, POLLIN, 0}};
            ::poll(fds, read_trace ? 2 : 1, 5);
            listener_->drain(got);
            if (read_trace) {
                const ssize_t n = ::read(trace_fd, buf, sizeof buf);
                if (n > 0) trace_bytes += static_cast<std::size_t>(n);
            }
        }
    };

    // Running: wait for READY=1, then read the trace for 600 ms.
    const auto ready_deadline = Clock::now() + milliseconds(20000);
    while (count_prefix(got, "READY=1") == 0 && Clock::now() < ready_deadline) pump(milliseconds(20), true);
    ASSERT_EQ(count_prefix(got, "READY=1"), 1U) << p.err();
    pump(milliseconds(600), true);
    const std::size_t running_keepalives = count_prefix(got, "WATCHDOG=1");
    EXPECT_GE(running_keepalives, 1U) << "no keep-alive while the loop ran (" << trace_bytes << " trace bytes read)";

    // Stalled: stop reading for 1.5 s. The loop halts within a few hundred ticks (~ms); the check after that
    // finds the heartbeat unchanged. Keep-alives are counted from 400 ms into the pause: one check period
    // (50 ms) plus a margin for the process being descheduled on the shared machine.
    const auto pause_start = Clock::now();
    pump(milliseconds(1500), false);
    const auto pause_end = Clock::now();
    EXPECT_EQ(count_prefix(got, "WATCHDOG=1", pause_start + milliseconds(400), pause_end), 0U)
        << "WATCHDOG=1 sent while the loop was stalled";

    // Resumed: read again until two more keep-alives came (at most 10 s).
    const std::size_t before_resume = count_prefix(got, "WATCHDOG=1");
    const auto resume_deadline = Clock::now() + milliseconds(10000);
    while (count_prefix(got, "WATCHDOG=1") < before_resume + 2 && Clock::now() < resume_deadline)
        pump(milliseconds(20), true);
    EXPECT_GE(count_prefix(got, "WATCHDOG=1", pause_end), 2U) << "no keep-alive after the loop resumed";

    // SIGTERM: keep reading so that the loop can reach the tick that sees it.
    ASSERT_EQ(::kill(p.pid(), SIGTERM), 0);
    int code = -1;
    const auto stop_deadline = Clock::now() + milliseconds(20000);
    while (code == -1 && Clock::now() < stop_deadline) {
        pump(milliseconds(10), true);
        code = p.wait(milliseconds(1));
    }
    listener_->drain(got);
    ::close(trace_fd);
    EXPECT_EQ(code, kExitOk) << p.err();
    ASSERT_FALSE(got.empty());
    EXPECT_TRUE(starts_with(got.back().text, "STOPPING=1")) << got.back().text;
    // hapticd says on stderr (the journal) that it withheld the keep-alive, and when it resumed.
    EXPECT_NE(p.err().find("loop heartbeat stalled at tick"), std::string::npos) << p.err();
    EXPECT_NE(p.err().find("WATCHDOG=1 resumed"), std::string::npos) << p.err();
}

}  // namespace
}  // namespace hapticd
