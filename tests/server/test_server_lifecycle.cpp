// SPDX-License-Identifier: Apache-2.0
// The daemon's life as a client sees it (docs/protocol.md, sections 6 and 7; docs/hapticd.md): a daemon
// killed by a fatal signal leaves a state that says so (fault, signal, a heartbeat that stops) after
// zeroing the simulated device; a stopped daemon reads stale, a quiet one does not; --serve-socket never
// removes what is not a stale hapticd socket, --serve-shm replaces only its own user's stale segment; one
// session cannot take every slot or fill the hand-over.
#include <fcntl.h>
#include <sys/mman.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>

#include "common/run_child.hpp"
#include "common/test_paths.hpp"
#include "server_fixture.hpp"

namespace hapticd::server_test {
namespace {

// Under a loaded machine the watchdog would end a daemon the test means to kill or stop itself.
const std::vector<std::string> kNoWatchdog{"--watchdog-overruns", "1000000", "--watchdog-stall-periods", "1000000"};

std::vector<std::string> with(std::vector<std::string> a, const std::vector<std::string>& b) {
    a.insert(a.end(), b.begin(), b.end());
    return a;
}

// Waits until the state has ticked and is not stale.
std::optional<cl::StateSample> wait_live(const cl::StateReader& r) {
    return wait_state(
        r, [](const cl::StateSample& s) { return s.tick > 10 && !s.stale; }, 20.0);
}

class FatalSignal : public ::testing::TestWithParam<int> {};

TEST_P(FatalSignal, TheStateSaysTheDaemonDiedAndTheSimulatedDeviceWasZeroed) {
    const int sig = GetParam();
    const Names n = names("fatal" + std::to_string(sig));
    Child daemon(HAPTICD_BINARY, daemon_args(n, with({"--scenario", "step", "--step-force", "0"}, kNoWatchdog)),
                 "fatal_daemon" + std::to_string(sig));
    ASSERT_TRUE(wait_for_socket(n.socket)) << daemon.err();
    const cl::StateReader state = cl::StateReader::open(n.shm);
    ASSERT_TRUE(wait_live(state).has_value()) << daemon.err();
    daemon.signal(sig);
    EXPECT_EQ(daemon.wait(), 128 + sig) << daemon.err();
    cl::StateSample s;
    ASSERT_TRUE(state.read(s));
    EXPECT_EQ(s.fault, static_cast<std::uint32_t>(StateFault::FatalSignal));
    EXPECT_EQ(s.fatal_signal, static_cast<std::uint32_t>(sig));
    EXPECT_TRUE(s.stale);
    EXPECT_NE(daemon.err().find("zero force written to the device"), std::string::npos) << daemon.err();
    // The heartbeat stopped with the daemon: its age only grows.
    std::this_thread::sleep_for(std::chrono::milliseconds(60));
    cl::StateSample later;
    ASSERT_TRUE(state.read(later));
    EXPECT_EQ(later.tick, s.tick);
    EXPECT_GT(later.heartbeat_age_s, state.stale_after_s());
    ::shm_unlink(n.shm.c_str());  // the dead daemon left it for its readers
}
INSTANTIATE_TEST_SUITE_P(Signals, FatalSignal, ::testing::Values(SIGSEGV, SIGBUS, SIGFPE, SIGILL, SIGABRT));

TEST(StateLiveness, AStoppedDaemonReadsStaleAQuietOneDoesNot) {
    const Names n = names("liveness");
    // --serve-wait-commit: the loop has not started (no client yet), the daemon is alive and quiet.
    Child daemon(HAPTICD_BINARY,
                 daemon_args(n, with({"--scenario", "step", "--step-force", "0", "--serve-wait-commit"}, kNoWatchdog)),
                 "liveness_daemon");
    ASSERT_TRUE(wait_for_socket(n.socket)) << daemon.err();
    const cl::StateReader state = cl::StateReader::open(n.shm);
    EXPECT_EQ(state.writer_pid(), daemon.pid());
    EXPECT_DOUBLE_EQ(state.stale_after_s(), 0.05);  // 10 periods of 1 ms is less than the 50 ms floor
    const auto quiet = wait_state(
        state, [](const cl::StateSample& s) { return !s.stale; }, 5.0);
    ASSERT_TRUE(quiet.has_value()) << "a daemon waiting for its first commit reads stale";
    EXPECT_EQ(quiet->tick, 0U);
    std::this_thread::sleep_for(std::chrono::milliseconds(200));
    cl::StateSample s;
    ASSERT_TRUE(state.read(s));
    EXPECT_FALSE(s.stale) << "age " << s.heartbeat_age_s;
    // A stopped process: stale after 50 ms, live again after SIGCONT.
    daemon.signal(SIGSTOP);
    std::this_thread::sleep_for(std::chrono::milliseconds(120));
    ASSERT_TRUE(state.read(s));
    EXPECT_TRUE(s.stale) << "age " << s.heartbeat_age_s;
    EXPECT_EQ(s.fault, 0U);
    daemon.signal(SIGCONT);
    EXPECT_TRUE(wait_state(
                    state, [](const cl::StateSample& x) { return !x.stale; }, 5.0)
                    .has_value());
    daemon.signal(SIGTERM);
    EXPECT_EQ(daemon.wait(), 0) << daemon.err();
}

TEST(ServeSocketPath, OnlyAStaleHapticdSocketIsReplaced) {
    // A regular file: left alone, exit 9, the message names the path.
    const Names file_names = names("notasocket");
    { std::ofstream(file_names.socket) << "precious\n"; }
    Child refused(HAPTICD_BINARY, daemon_args(file_names, {"--scenario", "step", "--step-force", "0"}), "socket_file");
    EXPECT_EQ(refused.wait(), 9) << refused.err();
    EXPECT_EQ(read_text(file_names.socket), "precious\n");
    EXPECT_NE(refused.err().find(file_names.socket), std::string::npos) << refused.err();
    EXPECT_NE(refused.err().find("not a socket"), std::string::npos) << refused.err();
    std::filesystem::remove(file_names.socket);

    // A live daemon's socket: the second daemon stops before touching the first's socket or state.
    const Names n = names("twice");
    Child first(HAPTICD_BINARY, daemon_args(n, {"--scenario", "step", "--step-force", "0"}), "socket_first");
    ASSERT_TRUE(wait_for_socket(n.socket)) << first.err();
    const cl::StateReader state = cl::StateReader::open(n.shm);
    ASSERT_TRUE(wait_live(state).has_value());
    Child second(HAPTICD_BINARY, daemon_args(n, {"--scenario", "step", "--step-force", "0"}), "socket_second");
    EXPECT_EQ(second.wait(), 9) << second.err();
    EXPECT_NE(second.err().find("in use"), std::string::npos) << second.err();
    EXPECT_TRUE(first.running());
    cl::Client c = cl::Client::connect({.socket_path = n.socket, .client_name = "after"});  // the socket still works
    const cl::StateReader again = cl::StateReader::open(c.welcome().state_shm);  // and the state is the first's
    EXPECT_EQ(again.writer_pid(), first.pid());
    first.signal(SIGTERM);
    EXPECT_EQ(first.wait(), 0) << first.err();

    // A stale socket (its daemon was killed): replaced.
    const Names stale = names("stale");
    Child killed(HAPTICD_BINARY, daemon_args(stale, {"--scenario", "step", "--step-force", "0"}), "socket_killed");
    ASSERT_TRUE(wait_for_socket(stale.socket)) << killed.err();
    killed.signal(SIGKILL);
    killed.wait();
    ASSERT_TRUE(std::filesystem::exists(stale.socket));
    Child next(HAPTICD_BINARY, daemon_args(stale, {"--scenario", "step", "--step-force", "0"}), "socket_next");
    EXPECT_TRUE(wait_for_socket(stale.socket)) << next.err();
    next.signal(SIGTERM);
    EXPECT_EQ(next.wait(), 0) << next.err();
}

// --serve-shm: a segment of the daemon's name that its user owns (a daemon that died) is replaced; one that
// another user owns is refused, exit 8, the message naming the option, the segment and its owner, and left
// as it was. The second part needs root (to give the segment to "nobody").
TEST(ServeShm, AStaleOwnSegmentIsReplacedAnotherUsersIsRefused) {
    const Names own = names("shm_own");
    {
        const int fd = ::shm_open(own.shm.c_str(), O_CREAT | O_EXCL | O_RDWR, 0600);
        ASSERT_GE(fd, 0) << std::strerror(errno);
        ASSERT_EQ(::ftruncate(fd, 16), 0);
        ASSERT_EQ(::write(fd, "stale stale", 11), 11);
        ::close(fd);
    }
    Child replaced(HAPTICD_BINARY, daemon_args(own, with({"--scenario", "step", "--step-force", "0"}, kNoWatchdog)),
                   "shm_own_daemon");
    ASSERT_TRUE(wait_for_socket(own.socket)) << replaced.err();
    const cl::StateReader state = cl::StateReader::open(own.shm);
    EXPECT_EQ(state.writer_pid(), replaced.pid());
    ASSERT_TRUE(wait_live(state).has_value()) << replaced.err();
    struct stat st {};
    ASSERT_EQ(::stat(("/dev/shm" + own.shm).c_str(), &st), 0);
    EXPECT_EQ(st.st_uid, ::geteuid());
    EXPECT_EQ(st.st_mode & 0777, 0640U);
    replaced.signal(SIGTERM);
    EXPECT_EQ(replaced.wait(), 0) << replaced.err();
    EXPECT_NE(::stat(("/dev/shm" + own.shm).c_str(), &st), 0) << "the daemon unlinks its segment when it stops";

    if (::geteuid() != 0) GTEST_SKIP() << "a segment of another user needs root to make (fchown)";
    const Names foreign = names("shm_foreign");
    const uid_t nobody = 65534;
    {
        const int fd = ::shm_open(foreign.shm.c_str(), O_CREAT | O_EXCL | O_RDWR, 0666);
        ASSERT_GE(fd, 0) << std::strerror(errno);
        ASSERT_EQ(::ftruncate(fd, 4096), 0);
        ASSERT_EQ(::fchown(fd, nobody, nobody), 0) << std::strerror(errno);
        ::close(fd);
    }
    Child refused(HAPTICD_BINARY, daemon_args(foreign, with({"--scenario", "step", "--step-force", "0"}, kNoWatchdog)),
                  "shm_foreign_daemon");
    EXPECT_EQ(refused.wait(), 8) << refused.err();
    const std::string path = "/dev/shm" + foreign.shm;
    EXPECT_NE(refused.err().find("--serve-shm"), std::string::npos) << refused.err();
    EXPECT_NE(refused.err().find(path), std::string::npos) << refused.err();
    EXPECT_NE(refused.err().find("uid 65534"), std::string::npos) << refused.err();
    EXPECT_NE(refused.err().find("not to this daemon's user uid 0"), std::string::npos) << refused.err();
    ASSERT_EQ(::stat(path.c_str(), &st), 0) << "the other user's segment is left in place";
    EXPECT_EQ(st.st_uid, nobody);
    EXPECT_EQ(st.st_size, 4096);
    ::shm_unlink(foreign.shm.c_str());
}

// The case: a daemon that does not run as root (here as "nobody") and a segment of its name made first by
// another user (here root): refused, exit 8, naming the segment and both users; the segment is left as it was.
// The same daemon with a name nobody holds starts, runs and removes its segment. Needs root (to drop to nobody).
TEST(ServeShm, ANonRootDaemonRefusesASegmentAnotherUserMadeFirst) {
    if (::geteuid() != 0) GTEST_SKIP() << "needs root to run the daemon as another user";
    const test::Credentials nobody = test::unprivileged_user();
    const std::string tag = std::to_string(::getpid());
    const std::string squatted = "/hapticd-test-" + tag + "-squatted";
    {
        const int fd = ::shm_open(squatted.c_str(), O_CREAT | O_EXCL | O_RDWR, 0644);
        ASSERT_GE(fd, 0) << std::strerror(errno);
        ::close(fd);
    }
    auto run_as_nobody = [&](const std::string& shm) {
        return test::run_child(
            {HAPTICD_BINARY, "--config", "", "--device", HAPTICD_SERVER_TEST_DIR + "/sim3.toml", "--serve",
             "--serve-socket", "/tmp/hapticd-test-" + tag + "-nobody.sock", "--serve-shm", shm, "--rt-priority", "0",
             "--mlock", "false", "--lockstep", "--duration", "0.05", "--wall", "axis=0 position=0.05 direction=+1"},
            std::chrono::seconds(60), &nobody);
    };
    const test::ChildResult refused = run_as_nobody(squatted);
    EXPECT_EQ(refused.exit_code, 8) << refused.output;
    EXPECT_NE(refused.output.find("/dev/shm" + squatted + " exists and belongs to uid 0"), std::string::npos)
        << refused.output;
    EXPECT_NE(refused.output.find("not to this daemon's user uid " + std::to_string(nobody.uid)), std::string::npos)
        << refused.output;
    struct stat st {};
    ASSERT_EQ(::stat(("/dev/shm" + squatted).c_str(), &st), 0);
    EXPECT_EQ(st.st_uid, 0U);
    ::shm_unlink(squatted.c_str());

    const std::string own = "/hapticd-test-" + tag + "-nobody";
    const test::ChildResult ran = run_as_nobody(own);
    EXPECT_EQ(ran.exit_code, 0) << ran.output;
    EXPECT_NE(::stat(("/dev/shm" + own).c_str(), &st), 0) << "the daemon unlinks its segment when it stops";
    ::shm_unlink(own.c_str());
    std::filesystem::remove("/tmp/hapticd-test-" + tag + "-nobody.sock");
}

// Bilateral: each ramp scene of a batch is one engagement pattern, so a batch's check (1000 ramp scenes at
// --ramp-time 1) stays short enough under sanitizers on a loaded machine for the gain changes below to reach
// the daemon within one ramp of each other (unilateral planes took 4 patterns per scene, and under ASan with
// the machine loaded by 3 more processes the ramps drained between the changes). The planes pass within
// 3 mm of the handle's start (z = 0): the springs' forces stay well below the device's 10 N.
cl::Plane near_plane(double offset) {
    return cl::Plane{.normal = {0.0, 0.0, -1.0},
                     .offset = offset,
                     .bilateral = true,
                     .gains = cl::Gains::explicit_gains(100.0, 50.0)};
}

TEST(SessionLimits, OneSessionCannotTakeEverySlotNorFillTheHandOver) {
    const Names n = names("limits");
    const std::string summary_path = (scratch() / "limits_summary.json").string();
    // Ramps of 1 s: a batch waits in the loop's queue until the earlier batches' ramps have ended, so the three
    // gain changes below must reach the daemon within 1 s of each other.
    Child daemon(HAPTICD_BINARY,
                 daemon_args(n, {"--scenario", "step", "--step-force", "0", "--session-max-objects", "3",
                                 "--session-max-in-flight", "2", "--ramp-time", "1", "--summary-json", summary_path}),
                 "limits_daemon");
    ASSERT_TRUE(wait_for_socket(n.socket)) << daemon.err();
    cl::Client greedy = cl::Client::connect({.socket_path = n.socket, .client_name = "greedy"});
    // Two planes, then gain changes of the first (each a 1 s ramp: the batch waits in the loop's queue until
    // the ramps before it have ended): at most 2 in flight refuses one of the changes, and the session never
    // holds more than 2 objects here, so the refusal is the in-flight limit's.
    int accepted = 0, limited = 0;
    std::string message;
    std::uint32_t first_id = 0;
    for (int i = 0; i < 5; ++i) {
        try {
            if (i < 2) {
                const auto ids = greedy.commit(cl::Batch().add(near_plane(-0.001 * i))).object_ids;
                if (i == 0) first_id = ids.at(0);
                ++accepted;
            } else {
                cl::Plane changed = near_plane(0.0);
                changed.gains = cl::Gains::explicit_gains(i % 2 == 0 ? 150.0 : 100.0, 50.0);
                greedy.commit(cl::Batch().modify(first_id, changed));
            }
        } catch (const cl::Error& e) {
            ASSERT_EQ(e.code(), cl::ErrorCode::SessionLimit) << e.what();
            ++limited;
            message = e.what();
        }
    }
    EXPECT_EQ(accepted, 2);
    EXPECT_GE(limited, 1);
    EXPECT_NE(message.find("session-max-in-flight"), std::string::npos) << message;
    // Another session is not limited by the greedy one's queue.
    cl::Client other = cl::Client::connect({.socket_path = n.socket, .client_name = "other"});
    EXPECT_NO_THROW(other.commit(cl::Batch().add(near_plane(0.001))));
    // The object limit: the greedy session's third object is accepted and its fourth refused for the object
    // limit. While the queue drains (two 1 s ramps) the in-flight limit refuses too: those refusals are retried
    // every 100 ms, for at most 60 s.
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(60);
    std::string refusal;
    while (refusal.empty()) {
        try {
            greedy.commit(cl::Batch().add(near_plane(-0.0005 - 0.001 * accepted)));
            ++accepted;
            ASSERT_LE(accepted, 3) << "a fourth object was accepted";
        } catch (const cl::Error& e) {
            ASSERT_EQ(e.code(), cl::ErrorCode::SessionLimit) << e.what();
            const std::string what = e.what();
            if (what.find("session-max-in-flight") == std::string::npos) {
                refusal = what;
            } else {
                ASSERT_LT(std::chrono::steady_clock::now(), deadline) << "the queue did not drain: " << what;
                std::this_thread::sleep_for(std::chrono::milliseconds(100));
            }
        }
    }
    EXPECT_EQ(accepted, 3);
    EXPECT_NE(refusal.find("session-max-objects"), std::string::npos) << refusal;
    daemon.signal(SIGTERM);
    EXPECT_EQ(daemon.wait(), 0) << daemon.err();
    const json summary = json::parse(read_text(summary_path), nullptr, false);
    EXPECT_EQ(summary.value("session_max_objects", 0), 3) << summary.dump();
    EXPECT_EQ(summary.value("session_max_in_flight", 0), 2) << summary.dump();
}

TEST(SessionLimits, OutOfRangeLimitsAreRefusedNamingTheOption) {
    const Names n = names("limits_bad");
    Child objects(HAPTICD_BINARY, daemon_args(n, {"--session-max-objects", "0"}), "limits_bad_objects");
    EXPECT_EQ(objects.wait(), 4) << objects.err();
    EXPECT_NE(objects.err().find("session-max-objects"), std::string::npos) << objects.err();
    EXPECT_NE(objects.err().find("1 .. 64"), std::string::npos) << objects.err();
    Child flight(HAPTICD_BINARY, daemon_args(n, {"--session-max-in-flight", "65"}), "limits_bad_flight");
    EXPECT_EQ(flight.wait(), 4) << flight.err();
    EXPECT_NE(flight.err().find("session-max-in-flight"), std::string::npos) << flight.err();
    // The same keys in a config file: refused with the file's line, accepted ones reach the summary.
    const std::string config = (scratch() / "limits.toml").string();
    { std::ofstream(config) << "session-max-objects = 70\n"; }
    Child from_file(HAPTICD_BINARY, {"--config", config, "--dry-run"}, "limits_bad_file");
    EXPECT_EQ(from_file.wait(), 4) << from_file.err();
    EXPECT_NE(from_file.err().find("line 1"), std::string::npos) << from_file.err();
    EXPECT_NE(from_file.err().find("session-max-objects = 70"), std::string::npos) << from_file.err();
    { std::ofstream(config) << "session-max-in-flight = 3\n"; }
    const std::string summary_path = (scratch() / "limits_file_summary.json").string();
    Child accepted(HAPTICD_BINARY, {"--config", config, "--dry-run", "--summary-json", summary_path}, "limits_file");
    EXPECT_EQ(accepted.wait(), 0) << accepted.err();
    EXPECT_EQ(json::parse(read_text(summary_path), nullptr, false).value("session_max_in_flight", 0), 3);
}

}  // namespace
}  // namespace hapticd::server_test
