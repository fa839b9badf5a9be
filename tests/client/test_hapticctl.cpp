// SPDX-License-Identifier: Apache-2.0
// hapticctl against a real hapticd --serve (lockstep, simulated device): every subcommand, the exit code of
// each kind of failure, and that an object lives exactly as long as the session that added it.
#include <gtest/gtest.h>

#include <functional>
#include <sstream>

#include <nlohmann/json.hpp>

#include "client_process.hpp"
#include "common/test_paths.hpp"

namespace {

using clients_test::LockstepDaemon;
using clients_test::Process;
using clients_test::Result;

class Hapticctl : public ::testing::Test {
  protected:
    static void SetUpTestSuite() { daemon_ = new LockstepDaemon("hapticctl"); }
    static void TearDownTestSuite() {
        EXPECT_EQ(daemon_->stop(), 0) << daemon_->log();
        delete daemon_;
        daemon_ = nullptr;
    }
    void SetUp() override { ASSERT_TRUE(daemon_->ready()) << daemon_->log(); }

    static std::vector<std::string> with_socket(std::vector<std::string> args) {
        args.insert(args.begin(), {"--socket", daemon_->socket()});
        return args;
    }
    static Result ctl(const std::vector<std::string>& args, const std::string& tag,
                      const std::string& stdin_path = "") {
        return clients_test::run(HAPTICCTL_BINARY, with_socket(args), tag, stdin_path);
    }
    // The scene's objects (hapticctl list --json).
    static nlohmann::json objects() {
        const Result r = ctl({"list", "--json"}, "list_json");
        EXPECT_EQ(r.code, 0) << r.err;
        return nlohmann::json::parse(r.out, nullptr, false);
    }
    static bool has_object(std::uint32_t id) {
        for (const auto& o : objects()) {
            if (o.value("id", 0U) == id) return true;
        }
        return false;
    }
    // Polls until the object is gone (ramp-out, default 30 ms) or 5 s passed.
    static bool gone_within_5s(std::uint32_t id) {
        const auto end = std::chrono::steady_clock::now() + std::chrono::seconds(5);
        while (std::chrono::steady_clock::now() < end) {
            if (!has_object(id)) return true;
            std::this_thread::sleep_for(std::chrono::milliseconds(20));
        }
        return false;
    }

    static LockstepDaemon* daemon_;
};
LockstepDaemon* Hapticctl::daemon_ = nullptr;

TEST_F(Hapticctl, StatusAndListShowTheDaemonAndItsConfigWall) {
    const Result s = ctl({"status"}, "status");
    ASSERT_EQ(s.code, 0) << s.err;
    EXPECT_NE(s.out.find("device sim"), std::string::npos) << s.out;
    EXPECT_NE(s.out.find("fault none"), std::string::npos) << s.out;
    // The server accepts clients before the loop's first tick: poll until the tick advances (at most 5 s).
    nlohmann::json status;
    const auto end = std::chrono::steady_clock::now() + std::chrono::seconds(5);
    do {
        const Result j = ctl({"status", "--json"}, "status_json");
        ASSERT_EQ(j.code, 0) << j.err;
        status = nlohmann::json::parse(j.out);
    } while (status["tick"].get<std::uint64_t>() == 0 && std::chrono::steady_clock::now() < end);
    EXPECT_EQ(status["protocol"], 1);
    EXPECT_EQ(status["state_shm"], daemon_->shm());
    EXPECT_GT(status["tick"].get<std::uint64_t>(), 0U);
    // The config wall: owner 0 (the daemon), the explicit gains of the command line.
    const auto list = objects();
    ASSERT_TRUE(list.is_array());
    bool config_wall = false;
    for (const auto& o : list) {
        if (o["owner"] == 0 && o["kind"] == "plane" && o["K"] == 100.0 && o["B"] == 1.0) config_wall = true;
    }
    EXPECT_TRUE(config_wall) << list.dump();
    const Result table = ctl({"list"}, "list_table");
    EXPECT_EQ(table.code, 0);
    EXPECT_NE(table.out.find("daemon"), std::string::npos) << table.out;
}

// The device's mass as the daemon checks gains for it: one mass (the default simulated device) and the
// mass matrix of tests/server/sim3_aniso.toml, with its stiffness limit, in both outputs.
TEST_F(Hapticctl, StatusShowsTheMassTheGainsAreCheckedFor) {
    const Result iso = ctl({"status", "--json"}, "status_mass_json");
    ASSERT_EQ(iso.code, 0) << iso.err;
    const auto d = nlohmann::json::parse(iso.out)["device"];
    const double m = d["mass_matrix"][0][0].get<double>();
    EXPECT_GT(m, 0.0);
    const std::size_t axes = d["axes"].get<std::size_t>();  // the default simulated device: 1
    nlohmann::json m_identity = nlohmann::json::array();
    for (std::size_t i = 0; i < axes; ++i) {
        m_identity.push_back(nlohmann::json::array());
        for (std::size_t k = 0; k < axes; ++k) m_identity[i].push_back(i == k ? m : 0.0);
    }
    EXPECT_EQ(d["mass_matrix"], m_identity) << d.dump();
    EXPECT_TRUE(d["max_stiffness"].is_null()) << d.dump();
    EXPECT_EQ(d["velocity_estimator"], "backward") << d.dump();
    const Result iso_text = ctl({"status"}, "status_mass");
    EXPECT_NE(iso_text.out.find("max stiffness none"), std::string::npos) << iso_text.out;

    LockstepDaemon aniso("hapticctl_aniso", {"--device", HAPTICD_ANISO_PROFILE});
    ASSERT_TRUE(aniso.ready()) << aniso.log();
    const Result j =
        clients_test::run(HAPTICCTL_BINARY, {"--socket", aniso.socket(), "status", "--json"}, "status_aniso_json");
    ASSERT_EQ(j.code, 0) << j.err;
    const auto a = nlohmann::json::parse(j.out)["device"];
    // The profile's matrix, row by row (exact: the numbers are read and sent as doubles).
    EXPECT_EQ(a["mass_matrix"], (nlohmann::json{{0.45, 0.10, 0.12}, {0.10, 0.30, 0.00}, {0.12, 0.00, 0.25}}))
        << a.dump();
    EXPECT_EQ(a["max_stiffness"], 100000.0);
    // Along axis 0 a plane acts with 1 / (M^-1)_00 = det M / (M_11 M_22 - M_12^2) = 0.0295 / 0.075 (cofactors).
    const double det = 0.45 * (0.30 * 0.25) - 0.10 * (0.10 * 0.25) + 0.12 * (0.0 - 0.30 * 0.12);
    EXPECT_NEAR(a["mass"][0].get<double>(), det / (0.30 * 0.25), 1e-12) << a.dump();
    const Result t = clients_test::run(HAPTICCTL_BINARY, {"--socket", aniso.socket(), "status"}, "status_aniso");
    EXPECT_NE(t.out.find("mass matrix [[0.45,0.1,0.12],[0.1,0.3,0.0],[0.12,0.0,0.25]] kg"), std::string::npos) << t.out;
    EXPECT_NE(t.out.find("max stiffness 100000 N/m"), std::string::npos) << t.out;
    EXPECT_EQ(aniso.stop(), 0) << aniso.log();
}

TEST_F(Hapticctl, EachFailureHasItsExitCode) {
    // 3: no daemon at that socket.
    const Result none =
        clients_test::run(HAPTICCTL_BINARY, {"--socket", "/nonexistent/hapticd.sock", "status"}, "nodaemon");
    EXPECT_EQ(none.code, 3) << none.err;
    EXPECT_NE(none.err.find("connect to '/nonexistent/hapticd.sock'"), std::string::npos) << none.err;
    // 2: malformed objects, before connecting (the message names the word and the accepted form).
    const Result bad_kind = ctl({"add", "cube"}, "badkind");
    EXPECT_EQ(bad_kind.code, 2);
    EXPECT_NE(bad_kind.err.find("accepted: plane, spring, field"), std::string::npos) << bad_kind.err;
    const Result bad_vec = ctl({"add", "plane", "normal=1,0"}, "badvec");
    EXPECT_EQ(bad_vec.code, 2);
    EXPECT_NE(bad_vec.err.find("normal = '1,0' must be 3 comma-separated numbers"), std::string::npos) << bad_vec.err;
    // 5: the daemon refuses unstable gains, naming K, B and the largest stable K; nothing was added.
    const auto before = objects().size();
    const Result unstable = ctl({"add", "plane", "normal=-1,0,0", "offset=0.005", "K=1e9", "B=0"}, "unstable");
    EXPECT_EQ(unstable.code, 5) << unstable.err;
    EXPECT_NE(unstable.err.find("unstable_gains"), std::string::npos) << unstable.err;
    EXPECT_NE(unstable.err.find("largest stable K"), std::string::npos) << unstable.err;
    EXPECT_LE(objects().size(), before);  // nothing added
    // 5: not a unit normal (the daemon's check).
    const Result normal = ctl({"add", "plane", "normal=2,0,0", "K=100"}, "normal");
    EXPECT_EQ(normal.code, 5) << normal.err;
    EXPECT_NE(normal.err.find("bad_message"), std::string::npos) << normal.err;
    // 6: removing the daemon's config wall (or another session's object).
    const auto config_id = std::to_string(objects().front()["id"].get<std::uint32_t>());
    const std::string script = clients_test::write_file("remove_config.txt", "remove " + config_id + "\n");
    const Result not_owner = ctl({"session", script}, "notowner");
    EXPECT_EQ(not_owner.code, 6) << not_owner.err;
    EXPECT_NE(not_owner.err.find("not_owner"), std::string::npos) << not_owner.err;
    EXPECT_NE(not_owner.err.find("remove_config.txt:1"), std::string::npos)
        << "the message names the script line: " << not_owner.err;
    // 2: an unknown script command, naming the line.
    const std::string typo = clients_test::write_file("typo.txt", "# comment\nstatus\nfrobnicate 3\n");
    const Result t = ctl({"session", typo}, "typo");
    EXPECT_EQ(t.code, 2) << t.err;
    EXPECT_NE(t.err.find("typo.txt:3: run_session_script: unknown command 'frobnicate'"), std::string::npos) << t.err;
}

TEST_F(Hapticctl, SessionAddsModifiesAndRemovesInOneSessionThenItsObjectsGo) {
    const std::string script =
        clients_test::write_file("session.txt",
                                 "add plane normal=-1,0,0 offset=0.005 K=1000 B=5\n"
                                 "begin\n"
                                 "add spring constraint=plane point=0,0,0 direction=1,0,0 K=50 B=1\n"
                                 "add field center=0,0,0 radius=0.001 force=0.1,0,0\n"
                                 "commit\n"
                                 "modify 1000000 plane normal=-1,0,0 offset=0.004 K=1000 B=5\n");
    // The last line names an object that does not exist: exit 6 after the earlier lines took effect.
    const Result r = ctl({"session", script}, "session_unknown");
    EXPECT_EQ(r.code, 6) << r.out << r.err;
    EXPECT_NE(r.err.find("session.txt:6"), std::string::npos) << r.err;

    // A script that holds its session while a second hapticctl looks at the scene.
    const std::string hold = clients_test::write_file("hold.txt",
                                                      "add plane normal=-1,0,0 offset=0.005 K=1000 B=5\n"
                                                      "list\n"
                                                      "state\n"
                                                      "sleep 1\n"
                                                      "clear\n");
    Process p(HAPTICCTL_BINARY, with_socket({"session", hold}), "session_hold");
    std::uint32_t id = 0;
    const auto end = std::chrono::steady_clock::now() + std::chrono::seconds(10);
    while (id == 0 && std::chrono::steady_clock::now() < end) {
        const std::string out = p.out();
        const auto at = out.find("added ");
        if (at != std::string::npos) id = static_cast<std::uint32_t>(std::stoul(out.substr(at + 6)));
        std::this_thread::sleep_for(std::chrono::milliseconds(10));
    }
    ASSERT_NE(id, 0U) << p.out() << p.err();
    EXPECT_TRUE(has_object(id)) << "the object exists while its session lives";
    for (const auto& o : objects()) {
        if (o["id"] == id) {
            EXPECT_NE(o["owner"], 0);
            EXPECT_EQ(o["K"], 1000.0);
        }
    }
    EXPECT_EQ(p.wait(), 0) << p.err();
    EXPECT_NE(p.out().find("tick "), std::string::npos) << "the state line: " << p.out();
    EXPECT_TRUE(gone_within_5s(id));
}

TEST_F(Hapticctl, AddHoldsTheObjectUntilSigtermThenItRampsOut) {
    Process p(HAPTICCTL_BINARY, with_socket({"add", "plane", "normal=-1,0,0", "offset=0.005", "criterion=CE2"}),
              "add_hold");
    std::uint32_t id = 0;
    const auto end = std::chrono::steady_clock::now() + std::chrono::seconds(10);
    while (id == 0 && std::chrono::steady_clock::now() < end) {
        const std::string out = p.out();
        const auto at = out.find("added ");
        if (at != std::string::npos && out.find('\n', at) != std::string::npos) {
            id = static_cast<std::uint32_t>(std::stoul(out.substr(at + 6)));
        }
        std::this_thread::sleep_for(std::chrono::milliseconds(10));
    }
    ASSERT_NE(id, 0U) << p.out() << p.err();
    EXPECT_NE(p.out().find("K = "), std::string::npos) << "the criterion's gains are printed: " << p.out();
    EXPECT_TRUE(has_object(id));
    ASSERT_EQ(::kill(p.pid(), SIGTERM), 0);
    EXPECT_EQ(p.wait(), 0) << p.err();
    EXPECT_TRUE(gone_within_5s(id));
}

TEST_F(Hapticctl, WatchPrintsOneLinePerSampleWithAdvancingTicks) {
    for (const bool via_socket : {false, true}) {
        // 5 samples 0.1 s apart: a sample repeats the tick when the loop has not ticked since the last one (a
        // loaded machine can hold a lockstep daemon off the CPU for a sample period); over the 0.4 s they advance.
        std::vector<std::string> args{"watch", "--count", "5", "--rate", "10"};
        if (via_socket) args.push_back("--via-socket");
        const Result r = ctl(args, via_socket ? "watch_socket" : "watch_shm");
        ASSERT_EQ(r.code, 0) << r.err;
        std::istringstream lines(r.out);
        std::string line;
        std::vector<unsigned long long> ticks;
        while (std::getline(lines, line)) {
            unsigned long long tick = 0;
            ASSERT_EQ(std::sscanf(line.c_str(), "tick %llu", &tick), 1) << line;
            EXPECT_NE(line.find(" x ["), std::string::npos) << line;
            EXPECT_NE(line.find(" fault none"), std::string::npos) << line;
            ticks.push_back(tick);
        }
        ASSERT_EQ(ticks.size(), 5U) << r.out;
        for (std::size_t i = 1; i < ticks.size(); ++i) EXPECT_GE(ticks[i], ticks[i - 1]) << "ticks never go back";
        EXPECT_GT(ticks.back(), ticks.front()) << "the lockstep loop advances over the samples: " << r.out;
    }
    // 9: a shared-memory name that does not exist.
    const Result missing = clients_test::run(
        HAPTICCTL_BINARY, {"watch", "--shm", "/hapticd-no-such-state", "--count", "1"}, "watch_missing");
    EXPECT_EQ(missing.code, 9) << missing.err;
}

// Every criterion hapticopt knows on the command lines: hapticd --criterion takes all eight (amax in
// lockstep, its wall the tip of the lightest mass of the plant set moved inwards), hapticctl's refusal
// of an unknown one lists all eight, and an OV and an amax plane are added.
TEST_F(Hapticctl, EveryHapticoptCriterionIsAcceptedByName) {
    const Result d = clients_test::run(
        HAPTICD_BINARY, {"--config", "", "--lockstep", "--duration", "0.01", "--criterion", "amax"}, "hapticd_amax");
    EXPECT_EQ(d.code, 0) << d.err;
    EXPECT_NE((d.out + d.err).find("tuned for amax"), std::string::npos) << d.out << d.err;
    // Derated to stay stable over the sim profile's plant set (0.200 .. 0.330 kg, each with the arms of the paper's
    // eq. 2): the masses alone derate the amax optimum to 0.66666 (the 0.200 kg end of its ray at the region's tip,
    // 0.200/0.30 less rounding); the stiff, undamped arm narrows the tip further (docs/robust-stability.md, "The arm").
    const std::string text = d.out + d.err;
    const auto at = text.find("derated to ");
    ASSERT_NE(at, std::string::npos) << text;
    const double derating = std::stod(text.substr(at + 11));
    EXPECT_LT(derating, 0.66666);
    EXPECT_GT(derating, 0.9 * 0.66666);
    EXPECT_NE(text.find("with every arm k_H / m <= 1000 s^-2, b_H / m <= 20 s^-1 (certified)"), std::string::npos)
        << text;
    const Result bad = clients_test::run(
        HAPTICD_BINARY, {"--config", "", "--lockstep", "--duration", "0.01", "--criterion", "CE9"}, "hapticd_ce9");
    EXPECT_EQ(bad.code, 2) << bad.err;
    EXPECT_NE(bad.err.find("{amax,OV,CE0,CE1,CE2,CE0+OV,CE1+OV,CE2+OV}"), std::string::npos) << bad.err;
    const Result unknown = ctl({"add", "plane", "normal=-1,0,0", "offset=0.005", "criterion=CE9"}, "add_ce9");
    EXPECT_EQ(unknown.code, 5) << unknown.err;
    EXPECT_NE(unknown.err.find("unknown_criterion"), std::string::npos) << unknown.err;
    EXPECT_NE(unknown.err.find("accepted: amax, OV, CE0, CE1, CE2, CE0+OV, CE1+OV, CE2+OV"), std::string::npos)
        << unknown.err;
    const Result ov = ctl({"add", "plane", "normal=-1,0,0", "offset=0.005", "criterion=OV", "--for", "0.05"}, "add_ov");
    EXPECT_EQ(ov.code, 0) << ov.err;
    EXPECT_NE(ov.out.find("added "), std::string::npos) << ov.out;
    const Result amax =
        ctl({"add", "plane", "normal=-1,0,0", "offset=0.005", "criterion=amax", "--for", "0.05"}, "add_amax");
    EXPECT_EQ(amax.code, 0) << amax.err;
    EXPECT_NE(amax.out.find("added "), std::string::npos) << amax.out;
}

// watch's fields: t is the loop's time, tick x period (printed to the ms: within 0.5 ms, plus the rounding of
// the product), and contact lists the config walls the handle is behind by their `list` ids. A second
// config wall, solid below x = 2 cm, has the handle of the clients' daemon inside it from the first tick
// (the hand starts at rest at x = -5 mm and settles at +10 mm, `watch` shows x = +10.000 mm; a 15 mm step of
// the hand, damping ratio 0.26 alone, overshoots by exp(-pi 0.26 / sqrt(1 - 0.26^2)) = 43 % at most: below
// 16.5 mm); the first (at 5 cm) is not touched. Both ways of watching (shared memory, subscription).
TEST_F(Hapticctl, WatchShowsTheConfigWallInContactAndTheLoopsTime) {
    LockstepDaemon d("hapticctl_config_contact", {"--wall", "axis=0 position=0.02 direction=-1"});
    ASSERT_TRUE(d.ready()) << d.log();
    const Result st =
        clients_test::run(HAPTICCTL_BINARY, {"--socket", d.socket(), "status", "--json"}, "config_contact_status");
    ASSERT_EQ(st.code, 0) << st.err;
    const double period = nlohmann::json::parse(st.out)["device"]["period_s"].get<double>();
    ASSERT_GT(period, 0.0);
    const Result l =
        clients_test::run(HAPTICCTL_BINARY, {"--socket", d.socket(), "list", "--json"}, "config_contact_list");
    ASSERT_EQ(l.code, 0) << l.err;
    const auto list = nlohmann::json::parse(l.out);
    ASSERT_EQ(list.size(), 2U) << l.out;
    EXPECT_EQ(list[1]["id"], 2) << l.out;
    EXPECT_EQ(list[1]["owner"], 0) << l.out;
    for (const bool via_socket : {false, true}) {
        std::vector<std::string> args{"--socket", d.socket(), "watch", "--count", "5", "--rate", "50"};
        if (via_socket) args.push_back("--via-socket");
        const Result r =
            clients_test::run(HAPTICCTL_BINARY, args, via_socket ? "config_contact_socket" : "config_contact_shm");
        ASSERT_EQ(r.code, 0) << r.err;
        std::istringstream lines(r.out);
        std::string line;
        int n = 0;
        while (std::getline(lines, line)) {
            unsigned long long tick = 0;
            double t = 0.0;
            ASSERT_EQ(std::sscanf(line.c_str(), "tick %llu t %lf s", &tick, &t), 2) << line;
            ASSERT_GT(tick, 0U) << line;
            EXPECT_NEAR(t, static_cast<double>(tick) * period, 5e-4 + 1e-12 * static_cast<double>(tick)) << line;
            EXPECT_NE(line.find(" contact {2} "), std::string::npos) << line;
            ++n;
        }
        EXPECT_EQ(n, 5) << r.out;
    }
    EXPECT_EQ(d.stop(), 0) << d.log();
}

// `contacts`: its first line lists the objects in contact; a zero-force field around the handle added by
// `add ... --for 0.2` gives a begin line with the field's id and, when the session ends and the field has
// ramped out, an end line of a later tick; SIGTERM ends it with 0.
TEST_F(Hapticctl, ContactsPrintsTheBeginAndEndOfAFieldAsJsonLines) {
    Process p(HAPTICCTL_BINARY, with_socket({"contacts"}), "contacts");
    const auto until = [&](const std::function<bool(const std::vector<nlohmann::json>&)>& pred) {
        const auto end = std::chrono::steady_clock::now() + std::chrono::seconds(30);
        std::vector<nlohmann::json> lines;
        while (std::chrono::steady_clock::now() < end) {
            lines.clear();
            std::istringstream in(p.out());
            std::string line;
            while (std::getline(in, line)) lines.push_back(nlohmann::json::parse(line, nullptr, false));
            if (pred(lines)) return lines;
            std::this_thread::sleep_for(std::chrono::milliseconds(10));
        }
        return lines;
    };
    auto lines = until([](const auto& l) { return !l.empty(); });
    ASSERT_FALSE(lines.empty()) << p.err();
    ASSERT_TRUE(lines[0].contains("contacts") && lines[0]["contacts"].is_array()) << lines[0].dump();
    const Result add = ctl({"add", "field", "center=0,0,0", "radius=0.1", "--for", "0.2"}, "contacts_add");
    ASSERT_EQ(add.code, 0) << add.err;
    const auto at = add.out.find("added ");
    ASSERT_NE(at, std::string::npos) << add.out;
    const std::uint32_t id = static_cast<std::uint32_t>(std::stoul(add.out.substr(at + 6)));
    const auto of_field = [id](const std::vector<nlohmann::json>& l) {
        std::vector<nlohmann::json> mine;
        for (std::size_t i = 1; i < l.size(); ++i) {
            if (l[i].value("object_id", 0U) == id) mine.push_back(l[i]);
        }
        return mine;
    };
    lines = until([&](const auto& l) { return of_field(l).size() >= 2; });
    const auto mine = of_field(lines);
    ASSERT_EQ(mine.size(), 2U) << p.out();
    EXPECT_EQ(mine[0].value("event", ""), "begin") << mine[0].dump();
    EXPECT_EQ(mine[1].value("event", ""), "end") << mine[1].dump();
    EXPECT_LT(mine[0].value("tick", 0ULL), mine[1].value("tick", 0ULL));
    EXPECT_EQ(mine[1].value("dropped", 1ULL), 0ULL);
    EXPECT_EQ(mine[0]["position"].size(), 3U);
    EXPECT_EQ(mine[0]["force"].size(), 3U);
    ASSERT_EQ(::kill(p.pid(), SIGTERM), 0);
    EXPECT_EQ(p.wait(), 0) << p.err();
}

// The cube [-10, 10]^3 (file units, scale=0.001: 20 mm) as an OBJ (shared vertices) and as an ASCII STL (each
// facet's three vertices written out: assimp joins them), wound outward.
constexpr int kCubeFaces[12][3] = {{0, 2, 1}, {1, 2, 3}, {4, 5, 6}, {5, 7, 6}, {0, 1, 4}, {1, 5, 4},
                                   {2, 6, 3}, {3, 6, 7}, {0, 4, 2}, {2, 4, 6}, {1, 3, 5}, {3, 7, 5}};
std::string cube_vertex(int i) {
    return std::to_string((i & 1) ? 10 : -10) + " " + std::to_string((i & 2) ? 10 : -10) + " " +
           std::to_string((i & 4) ? 10 : -10);
}

// `hapticctl add mesh FILE` on the 3-axis simulated device: an OBJ and an STL cube are read (assimp), uploaded and
// added (8 vertices and 12 triangles each: the STL's 36 vertices joined), held for --for; an open cube in solid mode
// is refused by the daemon's validation naming the mode, a missing file and an unknown key before connecting (2);
// shading=30 accepted, shading=85 refused naming the crease angle's range.
TEST(HapticctlMesh, AddMeshReadsObjAndStlUploadsAndAdds) {
    LockstepDaemon daemon("hapticctl_mesh", {"--device", "sim3"});
    ASSERT_TRUE(daemon.ready()) << daemon.log();
    std::string obj, stl = "solid cube\n", open_obj;
    for (int i = 0; i < 8; ++i) obj += "v " + cube_vertex(i) + "\n";
    open_obj = obj;
    for (int f = 0; f < 12; ++f) {
        const std::string face = "f " + std::to_string(kCubeFaces[f][0] + 1) + " " +
                                 std::to_string(kCubeFaces[f][1] + 1) + " " + std::to_string(kCubeFaces[f][2] + 1) +
                                 "\n";
        obj += face;
        if (f < 11) open_obj += face;
        stl += "facet normal 0 0 0\nouter loop\n";
        for (const int v : kCubeFaces[f]) stl += "vertex " + cube_vertex(v) + "\n";
        stl += "endloop\nendfacet\n";
    }
    stl += "endsolid cube\n";
    const auto ctl = [&](std::vector<std::string> args, const std::string& tag) {
        args.insert(args.begin(), {"--socket", daemon.socket()});
        return clients_test::run(HAPTICCTL_BINARY, args, tag);
    };
    for (const auto& [name, text] : {std::pair<std::string, std::string>{"cube.obj", obj}, {"cube.stl", stl}}) {
        const std::string path = clients_test::write_file(name, text);
        const Result r = ctl({"add", "mesh", path, "scale=0.001", "position=0,0,-0.03", "K=500", "B=5", "--for", "0.2"},
                             "mesh_" + name);
        EXPECT_EQ(r.code, 0) << r.err;
        EXPECT_NE(r.out.find("8 vertices, 12 triangles (solid)"), std::string::npos) << r.out;
        EXPECT_NE(r.out.find("(mesh, K = 500 N/m, B = 5 N s/m)"), std::string::npos) << r.out;
    }
    // Force shading: shading=DEG is the crease angle (a cube's faces stay flat at 30 deg); 85 is refused by the daemon
    // naming the parameter and its range.
    const std::string cube = clients_test::write_file("shaded.obj", obj);
    const Result shaded =
        ctl({"add", "mesh", cube, "scale=0.001", "K=500", "B=5", "shading=30", "--for", "0.2"}, "shaded");
    EXPECT_EQ(shaded.code, 0) << shaded.err;
    const Result steep = ctl({"add", "mesh", cube, "scale=0.001", "K=500", "B=5", "shading=85"}, "steep");
    EXPECT_NE(steep.code, 0) << steep.out;
    EXPECT_NE(steep.err.find("mesh.shading.crease_angle_deg = 85; accepted: 0 .. 80"), std::string::npos) << steep.err;
    const Result open = ctl({"add", "mesh", clients_test::write_file("open.obj", open_obj), "K=500", "B=5"}, "open");
    EXPECT_NE(open.code, 0) << open.out;
    EXPECT_NE(open.err.find("solid"), std::string::npos) << open.err;
    const Result missing = ctl({"add", "mesh", "/nonexistent/x.stl"}, "missing");
    EXPECT_EQ(missing.code, 2) << missing.err;
    EXPECT_NE(missing.err.find("/nonexistent/x.stl"), std::string::npos) << missing.err;
    const Result key = ctl({"add", "mesh", "/nonexistent/x.stl", "colour=red"}, "badkey");
    EXPECT_EQ(key.code, 2) << key.err;
    EXPECT_NE(key.err.find("unknown key 'colour'"), std::string::npos) << key.err;
    EXPECT_EQ(daemon.stop(), 0) << daemon.log();
}

}  // namespace
