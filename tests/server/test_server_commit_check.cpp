// SPDX-License-Identifier: Apache-2.0
// A commit's scene check off the server thread (server/commit_check_worker.hpp; docs/protocol.md, section 3), with
// real processes: while one commit's scenes are checked the server answers other sessions, parks their commits behind
// it (status: commit_check, commits_waiting), a departure during the check stages the commit again on the scene
// the departure leaves, and a departure's plan runs off the server thread too (status: departures_waiting). The daemon:
// the simulated Falcon (config/devices/falcon.toml: its plant set, window:15, 6 ms) with a 180 N/m, 7.35 N s/m config
// wall and a 10 ms ramp; a plane at 45 degrees to that wall makes a sum whose gains do not commute, checked on the
// sampled plants at 10 scenes (1.2 s in a release build on an idle machine).
#include <string>

#include "server_fixture.hpp"

namespace hapticd::server_test {
namespace {

std::vector<std::string> falcon_args(const Names& n) {
    return {"--config",       "",        "--device",    HAPTICD_SERVER_TEST_DIR + "/../../config/devices/falcon.toml",
            "--simulate",     "--serve", "--stiffness", "180",
            "--damping",      "7.35",    "--ramp-time", "0.01",
            "--serve-socket", n.socket,  "--serve-shm", n.shm,
            "--rt-priority",  "0",       "--mlock",     "false"};
}

json commit_of(std::uint64_t id, const json& object) {
    return json{{"type", "commit"}, {"id", id}, {"ops", json::array({json{{"op", "add"}, {"object", object}}})}};
}

// A liveness guard for a reply that waits for a check, not a latency bound: 1.2 s in a release build, over 60 s under
// TSan or ASan + UBSan beside two busy loops.
constexpr double kCheckTimeoutS = 600.0;

const json kOblique = plane({0.7071067811865476, 0.7071067811865476, 0.0}, 0.06, json{{"K", 100.0}, {"B", 1.0}});

// A session as the test drives it: hello, then requests sent and replies read one by one.
struct RawSession {
    explicit RawSession(const std::string& socket) : connection(socket) {
        connection.send(R"({"type":"hello","protocol":1,"client":"commit_check"})");
        const json w = connection.receive_json();
        EXPECT_EQ(w.value("type", ""), "welcome") << w.dump();
        id = w.value("session", std::uint64_t{0});
    }
    json request(const json& message) const {
        connection.send(message.dump());
        return connection.receive_json();
    }
    RawConnection connection;
    std::uint64_t id = 0;
};

// Status from `watcher` until pred(status) holds, or until `checked` has its reply (then nullopt: the check ended
// before the watcher saw what it waits for).
template <class Pred>
std::optional<json> status_until(const RawSession& watcher, const RawSession& checked, Pred pred) {
    const double end = monotonic_s() + RawConnection::kReplyTimeoutS;
    for (std::uint64_t i = 1000; monotonic_s() < end; ++i) {
        const json s = watcher.request(json{{"type", "status"}, {"id", i}});
        if (s.value("type", "") != "ok") {
            ADD_FAILURE() << s.dump();
            return std::nullopt;
        }
        if (pred(s)) return s;
        if (checked.connection.receive(0.0)) return std::nullopt;  // the checked commit answered first
    }
    return std::nullopt;
}

bool checking(const json& status, std::uint64_t session) {
    const auto c = status.find("commit_check");
    return c != status.end() && c->is_object() && c->value("session", std::uint64_t{0}) == session;
}

// Session A's oblique plane is being checked: B's status is answered meanwhile and names A's check; C's commit (a
// bilateral plane along z, orthogonal to both: a check of 10 scalar verdicts) is parked behind it (commits_waiting 1,
// no reply) and answered after A's, its batch after A's.
TEST(ServerCommitCheck, OtherSessionsAreAnsweredAndTheirCommitsWaitWhileAScenesCheckRuns) {
    const Names n = names("commit_check");
    Child daemon(HAPTICD_BINARY, falcon_args(n), "commit_check_daemon");
    ASSERT_TRUE(wait_for_socket(n.socket)) << daemon.err();
    const RawSession a(n.socket), b(n.socket), c(n.socket);
    a.connection.send(commit_of(1, kOblique).dump());
    const std::optional<json> seen = status_until(b, a, [&](const json& s) { return checking(s, a.id); });
    ASSERT_TRUE(seen) << "session A's commit was answered before B saw its check running";
    EXPECT_GE(seen->at("commit_check").value("running_s", -1.0), 0.0) << seen->dump();
    EXPECT_EQ(seen->value("commits_waiting", 99), 0) << seen->dump();

    c.connection.send(commit_of(1, plane({0.0, 0.0, 1.0}, 0.06, json{{"K", 50.0}, {"B", 1.0}}, true)).dump());
    const std::optional<json> queued =
        status_until(b, a, [&](const json& s) { return checking(s, a.id) && s.value("commits_waiting", 0) == 1; });
    ASSERT_TRUE(queued) << "C's commit was not seen waiting while A's check ran";
    EXPECT_FALSE(c.connection.receive(0.0)) << "C's commit was answered while A's check ran";

    const json a_reply = a.connection.receive_json(kCheckTimeoutS);
    ASSERT_EQ(a_reply.value("type", ""), "ok") << a_reply.dump();
    const json c_reply = c.connection.receive_json(kCheckTimeoutS);
    ASSERT_EQ(c_reply.value("type", ""), "ok") << c_reply.dump();
    EXPECT_GT(c_reply.value("commit_seq", 0), a_reply.value("commit_seq", 0));
    const json listed = b.request(json{{"type", "list"}, {"id", 1}});
    ASSERT_EQ(listed.value("type", ""), "ok") << listed.dump();
    EXPECT_EQ(listed.at("objects").size(), 3U) << listed.dump();  // the config wall, A's and C's planes
    const json idle = b.request(json{{"type", "status"}, {"id", 2}});
    EXPECT_TRUE(idle.at("commit_check").is_null()) << idle.dump();
    EXPECT_EQ(idle.value("commits_waiting", 99), 0) << idle.dump();
    daemon.signal(SIGTERM);
    EXPECT_EQ(daemon.wait(), 0) << daemon.err();
}

// Session D holds a plane; A's oblique plane is being checked when D leaves: the departure changes the scene under
// the check, which is cancelled and run again on the scene without D's plane (the daemon's log says so); A's commit
// is then accepted and D's plane is gone.
TEST(ServerCommitCheck, ADepartureDuringACheckStagesTheCommitAgainOnTheSceneItLeaves) {
    const Names n = names("commit_check_departure");
    Child daemon(HAPTICD_BINARY, falcon_args(n), "commit_check_departure_daemon");
    ASSERT_TRUE(wait_for_socket(n.socket)) << daemon.err();
    const RawSession a(n.socket), b(n.socket);
    std::optional<RawSession> d(std::in_place, n.socket);
    const json held = d->request(commit_of(1, plane({0.0, 0.0, 1.0}, 0.06, json{{"K", 50.0}, {"B", 1.0}}, true)));
    ASSERT_EQ(held.value("type", ""), "ok") << held.dump();
    const std::uint32_t d_object = held.at("object_ids").at(0).get<std::uint32_t>();

    a.connection.send(commit_of(1, kOblique).dump());
    ASSERT_TRUE(status_until(b, a, [&](const json& s) { return checking(s, a.id); }))
        << "session A's commit was answered before B saw its check running";
    d.reset();  // D leaves while A's check runs

    const json a_reply = a.connection.receive_json(kCheckTimeoutS);  // checked twice: before and after the departure
    ASSERT_EQ(a_reply.value("type", ""), "ok") << a_reply.dump();
    EXPECT_NE(
        daemon.err().find("the scene changed during its commit's check (a departure); the commit is checked again"),
        std::string::npos)
        << daemon.err();
    const json listed = b.request(json{{"type", "list"}, {"id", 1}});
    ASSERT_EQ(listed.value("type", ""), "ok") << listed.dump();
    for (const json& o : listed.at("objects")) EXPECT_NE(o.value("id", 0U), d_object) << listed.dump();
    daemon.signal(SIGTERM);
    EXPECT_EQ(daemon.wait(), 0) << daemon.err();
}

// Session D's oblique plane leaves: its ramp-out's scenes are the check's (1.2 s in a release build). Meanwhile B is
// answered and sees the departure being planned (departures_waiting 1); C's commit, sent then, is answered once the
// plan is in (the daemon's log says so), and D's plane ramps out.
TEST(ServerCommitCheck, ADeparturesPlanRunsOffTheServerThreadAndCommitsWaitForIt) {
    const Names n = names("commit_check_plan");
    Child daemon(HAPTICD_BINARY, falcon_args(n), "commit_check_plan_daemon");
    ASSERT_TRUE(wait_for_socket(n.socket)) << daemon.err();
    const RawSession b(n.socket), c(n.socket);
    std::optional<RawSession> d(std::in_place, n.socket);
    d->connection.send(commit_of(1, kOblique).dump());
    const json held = d->connection.receive_json(kCheckTimeoutS);
    ASSERT_EQ(held.value("type", ""), "ok") << held.dump();
    const std::uint32_t d_object = held.at("object_ids").at(0).get<std::uint32_t>();
    d.reset();

    const double end = monotonic_s() + kCheckTimeoutS;
    std::optional<json> planning;
    for (std::uint64_t i = 1000; monotonic_s() < end && !planning; ++i) {
        const json s = b.request(json{{"type", "status"}, {"id", i}});
        ASSERT_EQ(s.value("type", ""), "ok") << s.dump();
        if (s.value("departures_waiting", 0) == 1) planning = s;
        if (daemon.err().find("departure planned in") != std::string::npos) break;
    }
    ASSERT_TRUE(planning) << "B never saw D's departure being planned: " << daemon.err();
    c.connection.send(commit_of(1, plane({0.0, 0.0, 1.0}, 0.06, json{{"K", 50.0}, {"B", 1.0}}, true)).dump());
    const json c_reply = c.connection.receive_json(kCheckTimeoutS);
    ASSERT_EQ(c_reply.value("type", ""), "ok") << c_reply.dump();
    EXPECT_NE(daemon.err().find("1 of its objects ramp out, departure planned in"), std::string::npos) << daemon.err();
    const json listed = b.request(json{{"type", "list"}, {"id", 1}});
    ASSERT_EQ(listed.value("type", ""), "ok") << listed.dump();
    for (const json& o : listed.at("objects")) {  // gone, or still in its 10 ms ramp-out
        if (o.value("id", 0U) == d_object) {
            EXPECT_TRUE(o.value("ramping_out", false)) << listed.dump();
        }
    }
    const json idle = b.request(json{{"type", "status"}, {"id", 2}});
    EXPECT_EQ(idle.value("departures_waiting", 99), 0) << idle.dump();
    daemon.signal(SIGTERM);
    EXPECT_EQ(daemon.wait(), 0) << daemon.err();
}

}  // namespace
}  // namespace hapticd::server_test
