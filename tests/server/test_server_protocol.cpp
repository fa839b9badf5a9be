// SPDX-License-Identifier: Apache-2.0
// The protocol's error paths against a running hapticd --serve (docs/protocol.md, section 8): wrong
// version, malformed, truncated and oversized messages, ownership; the socket's mode and owner and a
// second user's client; the loop undisturbed and nothing else lost.
#include <grp.h>
#include <pwd.h>
#include <sys/stat.h>

#include "common/test_paths.hpp"
#include "server_fixture.hpp"

namespace hapticd::server_test {
namespace {

constexpr char kProtoTag[] = "proto";
class ServerProtocol : public SharedDaemonTest<kProtoTag> {};

TEST_F(ServerProtocol, WrongVersionIsRefusedNamingBothVersionsAndClosed) {
    RawConnection c(n_->socket);
    ASSERT_TRUE(c.connected());
    c.send(R"({"type":"hello","protocol":2,"client":"future"})");
    const json r = c.receive_json();
    EXPECT_EQ(r.value("type", ""), "refused") << r.dump();
    EXPECT_EQ(r.value("code", ""), "protocol_version");
    EXPECT_EQ(r.value("server_protocol", 0), 1);
    EXPECT_EQ(r.value("client_protocol", 0), 2);
    EXPECT_TRUE(c.receive_json().value("eof", false));  // closed after the refusal
    // The client library reports the same as a typed error.
    try {
        (void)cl::Client::connect({.socket_path = n_->socket, .protocol = 7});
        ADD_FAILURE() << "protocol 7 was accepted";
    } catch (const cl::Error& e) {
        EXPECT_EQ(e.code(), cl::ErrorCode::ProtocolVersion) << e.what();
    }
}

TEST_F(ServerProtocol, AFirstMessageThatIsNotHelloIsRefused) {
    RawConnection c(n_->socket);
    c.send(R"({"type":"commit","id":1,"ops":[]})");
    const json r = c.receive_json();
    EXPECT_EQ(r.value("code", ""), "bad_hello") << r.dump();
    EXPECT_TRUE(c.receive_json().value("eof", false));
}

TEST_F(ServerProtocol, MalformedAndTruncatedMessagesGetAnErrorAndTheConnectionStaysOpen) {
    RawConnection c(n_->socket);
    c.hello();
    c.send("{not json");
    json r = c.receive_json();
    EXPECT_EQ(r.value("code", ""), "bad_json") << r.dump();
    EXPECT_TRUE(r["id"].is_null());
    c.send(R"({"type":"commit","id":3,"ops":[{"op":"add","object":{"kind":"pla)");  // truncated
    EXPECT_EQ(c.receive_json().value("code", ""), "bad_json");
    c.send(std::string("\xff\xfe\x00garbage", 10));
    EXPECT_EQ(c.receive_json().value("code", ""), "bad_json");
    c.send(R"({"type":"teleport","id":4})");
    r = c.receive_json();
    EXPECT_EQ(r.value("code", ""), "bad_message");
    EXPECT_EQ(r.value("id", 0), 4);
    c.send(
        R"({"type":"commit","id":5,"ops":[{"op":"add","object":{"kind":"plane","normal":[0,0,2],"offset":0,"gains":{"K":10,"B":1}}}]})");
    r = c.receive_json();
    EXPECT_EQ(r.value("code", ""), "bad_message") << r.dump();
    EXPECT_EQ(r.value("op_index", -2), 0);
    EXPECT_NE(r.value("message", "").find("normal"), std::string::npos) << r.dump();
    c.send(
        R"({"type":"commit","id":6,"ops":[{"op":"add","object":{"kind":"plane","normal":[0,0,1],"offset":0,"gains":{"K":-1,"B":1}}}]})");
    EXPECT_EQ(c.receive_json().value("code", ""), "bad_message");
    c.send(
        R"({"type":"commit","id":7,"ops":[{"op":"add","object":{"kind":"plane","normal":[0,0,1],"offset":0,"gains":{"criterion":"CE9"}}}]})");
    EXPECT_EQ(c.receive_json().value("code", ""), "unknown_criterion");
    c.send(R"({"type":"heartbeat","id":8})");  // still open and served
    r = c.receive_json();
    EXPECT_EQ(r.value("type", ""), "ok") << r.dump();
    EXPECT_EQ(r.value("id", 0), 8);
}

// The commit's reply counts its scene verdicts and those accepted on the samples (docs/protocol.md, section 5): a plane
// parallel to the config wall (x) commutes with it in every scene (exact verdicts: none sampled); a plane at 45 degrees
// does not, and its ramp's scenes with both engaged rest on the samples while its final scene's patterns are proven
// (the numerical range; sim3: one mass range, no arm, no delay).
TEST_F(ServerProtocol, TheCommitReplyCountsTheSceneVerdictsAndThoseOnTheSamples) {
    RawConnection c(n_->socket);
    c.hello();
    c.send(
        R"({"type":"commit","id":1,"ops":[{"op":"add","object":{"kind":"plane","normal":[1,0,0],"offset":0.04,"gains":{"K":100,"B":1}}}]})");
    json r = c.receive_json();
    ASSERT_EQ(r.value("type", ""), "ok") << r.dump();
    EXPECT_GE(r.value("scenes_checked", 0), 30) << r.dump();  // the final scene and 29 ramp scenes at least
    EXPECT_EQ(r.value("scenes_sampled", -1), 0) << r.dump();
    c.send(
        R"({"type":"commit","id":2,"ops":[{"op":"add","object":{"kind":"plane","normal":[0.7071067811865476,0.7071067811865476,0],"offset":0.04,"gains":{"K":100,"B":1}}}]})");
    r = c.receive_json();
    ASSERT_EQ(r.value("type", ""), "ok") << r.dump();
    EXPECT_GT(r.value("scenes_sampled", 0), 0) << r.dump();
    EXPECT_LT(r.value("scenes_sampled", 0), r.value("scenes_checked", 0)) << r.dump();
    // The C++ client's CommitResult carries both.
    cl::Client client = cl::Client::connect({.socket_path = n_->socket, .client_name = "scenes"});
    const cl::CommitResult result = client.commit(cl::Batch().add(
        cl::Plane{.normal = {0.6, 0.8, 0.0}, .offset = 0.04, .gains = cl::Gains::explicit_gains(100.0, 1.0)}));
    EXPECT_GT(result.scenes_sampled, 0U);
    EXPECT_LT(result.scenes_sampled, result.scenes_checked);
    client.bye();
}

TEST_F(ServerProtocol, AnOversizedMessageIsRefusedAndClosedOthersUndisturbed) {
    cl::Client keeper = cl::Client::connect({.socket_path = n_->socket, .client_name = "keeper"});
    const auto kept = keeper.commit(cl::Batch().add(cl::Plane{
        .normal = {0, 0, -1}, .offset = -0.05, .bilateral = false, .gains = cl::Gains::explicit_gains(100.0, 1.0)}));
    const cl::StateReader state = cl::StateReader::open(keeper.welcome().state_shm);
    cl::StateSample before;
    ASSERT_TRUE(state.read(before));
    RawConnection c(n_->socket);
    c.hello();
    c.send(R"({"type":"heartbeat","id":1,"pad":")" + std::string(70000, 'x') + "\"}");
    const json r = c.receive_json();
    EXPECT_EQ(r.value("code", ""), "oversized") << r.dump().substr(0, 200);
    EXPECT_TRUE(c.receive_json().value("eof", false));
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
    cl::StateSample after;
    ASSERT_TRUE(state.read(after));
    EXPECT_GT(after.tick, before.tick);  // the loop kept ticking
    EXPECT_EQ(after.fault, 0U);
    bool still_there = false;
    for (const auto& o : keeper.list()) still_there = still_there || o.id == kept.object_ids.at(0);
    EXPECT_TRUE(still_there);  // nothing else lost
    keeper.commit(cl::Batch().clear());
}

TEST_F(ServerProtocol, AClientCannotTouchAnotherClientsOrTheDaemonsObjects) {
    cl::Client a = cl::Client::connect({.socket_path = n_->socket, .client_name = "a"});
    cl::Client b = cl::Client::connect({.socket_path = n_->socket, .client_name = "b"});
    const cl::Plane p{
        .normal = {0, 0, -1}, .offset = -0.05, .bilateral = false, .gains = cl::Gains::explicit_gains(100.0, 1.0)};
    const std::uint32_t id = a.commit(cl::Batch().add(p)).object_ids.at(0);
    auto expect_code = [&](const cl::Batch& batch, cl::ErrorCode code) {
        try {
            b.commit(batch);
            ADD_FAILURE() << "accepted";
        } catch (const cl::Error& e) {
            EXPECT_EQ(e.code(), code) << e.what();
        }
    };
    expect_code(cl::Batch().remove(id), cl::ErrorCode::NotOwner);
    expect_code(cl::Batch().modify(id, p), cl::ErrorCode::NotOwner);
    expect_code(cl::Batch().remove(1), cl::ErrorCode::NotOwner);  // the config wall
    expect_code(cl::Batch().remove(999999), cl::ErrorCode::UnknownObject);
    // All-or-nothing: a valid add followed by a foreign remove adds nothing.
    const std::size_t objects_before = b.list().size();
    expect_code(cl::Batch().add(p).remove(id), cl::ErrorCode::NotOwner);
    EXPECT_EQ(b.list().size(), objects_before);
    b.commit(cl::Batch().clear());  // clear touches only b's objects
    bool still_there = false;
    for (const auto& o : a.list()) still_there = still_there || o.id == id;
    EXPECT_TRUE(still_there);
    a.commit(cl::Batch().remove(id));
}

// Device limits (sim3.toml: max_force 10 N, workspace +-0.06 m) and a field's negative stiffness.
TEST_F(ServerProtocol, ForcesAndPositionsBeyondTheDeviceAndNegativeStiffnessAreRefused) {
    cl::Client c = cl::Client::connect({.socket_path = n_->socket, .client_name = "limits"});
    auto expect_code = [&](const cl::ObjectDescription& object, cl::ErrorCode code) {
        try {
            c.commit(cl::Batch().add(object));
            ADD_FAILURE() << "accepted";
        } catch (const cl::Error& e) {
            EXPECT_EQ(e.code(), code) << e.what();
            EXPECT_EQ(e.op_index(), 0) << e.what();
        }
    };
    cl::Field strong{.center = {0, 0, 0}, .radius = 0.01, .force = {0, 0, 12.0}, .jacobian = {}};
    expect_code(strong, cl::ErrorCode::BeyondDeviceLimits);  // |F0| = 12 N > 10 N
    cl::Field steep{.center = {0, 0, 0},
                    .radius = 0.01,
                    .force = {0, 0, 5.0},
                    .jacobian = {cl::Vec3{-600, 0, 0}, cl::Vec3{0, 0, 0}, cl::Vec3{0, 0, 0}}};
    expect_code(steep, cl::ErrorCode::BeyondDeviceLimits);  // 5 N + 600 N/m * 0.01 m = 11 N
    cl::Field repulsive{.center = {0, 0, 0},
                        .radius = 0.01,
                        .force = {0, 0, 0},
                        .jacobian = {cl::Vec3{100, 0, 0}, cl::Vec3{0, 0, 0}, cl::Vec3{0, 0, 0}}};
    expect_code(repulsive, cl::ErrorCode::UnstableGains);  // sym(J) has +100 N/m
    expect_code(cl::Spring{.constraint = cl::Constraint::Point,
                           .point = {0.1, 0, 0},
                           .direction = {1, 0, 0},
                           .gains = cl::Gains::explicit_gains(100, 1)},
                cl::ErrorCode::BeyondDeviceLimits);  // outside +-0.06 m
    // An attracting field without damping is a spring with B = 0: the sampled loop is then not
    // asymptotically stable (the largest stable K at B = 0 is 0), so it is refused; with damping it passes.
    cl::Field attracting{.center = {0, 0, 0},
                         .radius = 0.01,
                         .force = {0, 0, 1.0},
                         .jacobian = {cl::Vec3{-100, 0, 0}, cl::Vec3{0, -100, 0}, cl::Vec3{0, 0, -100}}};
    expect_code(attracting, cl::ErrorCode::UnstableGains);
    attracting.damping = 1.0;
    EXPECT_EQ(c.commit(cl::Batch().add(attracting)).object_ids.size(), 1U);
    cl::Field constant{.center = {0, 0, 0}, .radius = 0.01, .force = {0, 0, 1.0}, .jacobian = {}};
    EXPECT_EQ(c.commit(cl::Batch().add(constant)).object_ids.size(), 1U);
    c.commit(cl::Batch().clear());
}

// The profile's stiffness limit (sim3_aniso.toml: max_stiffness = 100000 N/m): an explicit plane, a
// spring, a criterion whose optimum is stiffer, a field's Jacobian and the sum of objects that are each
// within it are refused with beyond_device_limits, naming K, the limit and the profile key; a stiffness
// below it passes. The limit also appears in the welcome.
TEST(ServerStiffnessLimit, StiffnessBeyondMaxStiffnessIsRefusedNamingTheKey) {
    const Names n = names("stiff");
    Child daemon(HAPTICD_BINARY, daemon_args(n, {"--scenario", "step", "--step-force", "0"}, "sim3_aniso.toml"),
                 "stiff_daemon");
    ASSERT_TRUE(wait_for_socket(n.socket)) << daemon.err();
    cl::Client c = cl::Client::connect({.socket_path = n.socket, .client_name = "stiff"});
    ASSERT_TRUE(c.welcome().device.max_stiffness.has_value());
    EXPECT_EQ(*c.welcome().device.max_stiffness, 100000.0);
    auto expect_limit = [&](const cl::Batch& batch, int op_index, const std::string& k_text) {
        try {
            c.commit(batch);
            ADD_FAILURE() << "accepted: " << k_text;
        } catch (const cl::Error& e) {
            const std::string what = e.what();
            EXPECT_EQ(e.code(), cl::ErrorCode::BeyondDeviceLimits) << what;
            EXPECT_EQ(e.op_index(), op_index) << what;
            EXPECT_NE(what.find("max_stiffness = 100000 N/m"), std::string::npos) << what;
            EXPECT_NE(what.find(k_text), std::string::npos) << what;
        }
    };
    // Along x the mass is 0.359 kg: K = 120000 N/m (alpha = 0.334) with B = 100 N s/m is inside the
    // stability region, so only the limit refuses it.
    const cl::Plane stiff{
        .normal = {-1, 0, 0}, .offset = -0.05, .bilateral = false, .gains = cl::Gains::explicit_gains(120000.0, 100.0)};
    expect_limit(cl::Batch().add(stiff), 0, "K = 120000 N/m");
    expect_limit(cl::Batch().add(cl::Spring{.constraint = cl::Constraint::Point,
                                            .point = {0, 0, 0},
                                            .direction = {1, 0, 0},
                                            .gains = cl::Gains::explicit_gains(150000.0, 100.0)}),
                 0, "K = 150000 N/m");
    cl::Field steep{.center = {0, 0, 0},
                    .radius = 5e-5,
                    .force = {0, 0, 0},
                    .jacobian = {cl::Vec3{-120000, 0, 0}, cl::Vec3{0, 0, 0}, cl::Vec3{0, 0, 0}},
                    .damping = 100.0};
    expect_limit(cl::Batch().add(steep), 0, "-sym(J)) = 120000 N/m");
    // Two planes along z of 60000 N/m each: each within the limit, their sum (120000) not.
    const cl::Plane half{
        .normal = {0, 0, -1}, .offset = -0.05, .bilateral = false, .gains = cl::Gains::explicit_gains(60000.0, 100.0)};
    expect_limit(cl::Batch().add(half).add(half), -1, "120000 N/m");
    // The config wall on axis 0 (CE2 for 0.359 kg, 88 840 N/m) plus a plane of 20000 N/m along x: over.
    const cl::Plane small{
        .normal = {-1, 0, 0}, .offset = -0.05, .bilateral = false, .gains = cl::Gains::explicit_gains(20000.0, 50.0)};
    expect_limit(cl::Batch().add(small), -1, "summed stiffness");
    // Within the limit: accepted (a plane along z, which the config wall does not share).
    const cl::Plane fine{
        .normal = {0, 0, -1}, .offset = -0.05, .bilateral = false, .gains = cl::Gains::explicit_gains(50000.0, 100.0)};
    EXPECT_EQ(c.commit(cl::Batch().add(fine)).object_ids.size(), 1U);
    daemon.signal(SIGTERM);
    EXPECT_EQ(daemon.wait(), 0) << daemon.err();
}

// A config wall above the profile's max_stiffness is refused at start-up (exit code 4), naming K, the
// limit and the key; without the limit (sim3.toml) the same wall starts.
TEST(ServerStiffnessLimit, AConfigWallAboveMaxStiffnessIsRefusedAtStartUp) {
    const std::vector<std::string> args{
        "--config",    "",       "--dry-run", "--wall", "axis=0 position=0.05 direction=+1",
        "--stiffness", "150000", "--damping", "150"};
    std::vector<std::string> limited = args, unlimited = args;
    limited.insert(limited.end(), {"--device", HAPTICD_SERVER_TEST_DIR + "/sim3_aniso.toml"});
    unlimited.insert(unlimited.end(), {"--device", HAPTICD_SERVER_TEST_DIR + "/sim3.toml"});
    Child refused(HAPTICD_BINARY, limited, "stiff_wall_refused");
    EXPECT_EQ(refused.wait(), 4) << refused.err();
    EXPECT_NE(refused.err().find("max_stiffness = 100000"), std::string::npos) << refused.err();
    EXPECT_NE(refused.err().find("K = 150000"), std::string::npos) << refused.err();
    Child started(HAPTICD_BINARY, unlimited, "stiff_wall_unlimited");
    EXPECT_EQ(started.wait(), 0) << started.err();
}

// The welcome's device on a full mass matrix (sim3_aniso.toml, eigenvalues 0.176 .. 0.541 kg): the client's
// DeviceInfo has M as the profile writes it (the JSON numbers round-trip exactly), per axis the mass along
// it 1 / (M^-1)_aa, and the limit. The reference for 1 / (M^-1)_aa is the closed form det(M) / C_aa (C_aa
// the cofactor), not the daemon's Eigen inverse; 1e-12 relative: both round a 3 x 3 inverse of condition
// 3.1 (a few ulp), while M_aa in place of the mass along axis a is 9 % off on axis 1. On one mass
// (sim3.toml, 0.30 kg) mass_matrix is 0.30 I.
TEST(ServerWelcome, DeviceInfoGivesTheMassMatrixAndTheMassAlongEachAxis) {
    const double M[3][3] = {{0.45, 0.10, 0.12}, {0.10, 0.30, 0.00}, {0.12, 0.00, 0.25}};
    const double det = M[0][0] * (M[1][1] * M[2][2] - M[1][2] * M[2][1]) -
                       M[0][1] * (M[1][0] * M[2][2] - M[1][2] * M[2][0]) +
                       M[0][2] * (M[1][0] * M[2][1] - M[1][1] * M[2][0]);
    const double cofactor[3] = {M[1][1] * M[2][2] - M[1][2] * M[2][1], M[0][0] * M[2][2] - M[0][2] * M[2][0],
                                M[0][0] * M[1][1] - M[0][1] * M[1][0]};
    for (const std::string profile : {"sim3_aniso.toml", "sim3.toml"}) {
        SCOPED_TRACE(profile);
        const bool aniso = profile == "sim3_aniso.toml";
        const Names n = names(aniso ? "welcome_aniso" : "welcome_iso");
        Child daemon(
            HAPTICD_BINARY,
            daemon_args(n, {"--scenario", "step", "--step-force", "0", "--stiffness", "2000", "--damping", "5"},
                        profile),
            aniso ? "welcome_aniso_daemon" : "welcome_iso_daemon");
        ASSERT_TRUE(wait_for_socket(n.socket)) << daemon.err();
        const cl::DeviceInfo d =
            cl::Client::connect({.socket_path = n.socket, .client_name = "welcome"}).welcome().device;
        ASSERT_EQ(d.axes, 3U);
        for (std::size_t i = 0; i < 3; ++i) {
            for (std::size_t j = 0; j < 3; ++j) {
                EXPECT_EQ(d.mass_matrix[i][j], aniso ? M[i][j] : (i == j ? 0.30 : 0.0)) << i << "," << j;
            }
            const double m_i = aniso ? det / cofactor[i] : 0.30;
            EXPECT_NEAR(d.mass[i], m_i, 1e-12 * m_i) << "axis " << i;
        }
        EXPECT_EQ(d.max_stiffness, aniso ? std::optional<double>(100000.0) : std::nullopt);
        daemon.signal(SIGTERM);
        EXPECT_EQ(daemon.wait(), 0) << daemon.err();
    }
}

// A welcome whose device.mass_matrix is not axes x axes numbers is not protocol 1: Client::connect throws
// bad_message naming the field and the shape. The server is a socket of this test (hapticd never sends
// such a welcome); the well-formed one it also sends is read, so the fake is a working server.
TEST(ServerWelcome, AMassMatrixThatIsNotAxesByAxesNumbersIsAnError) {
    const std::string path = (scratch() / "fake_welcome.sock").string();
    const json good_device = {{"name", "fake"},
                              {"axes", 2},
                              {"period_s", 0.001},
                              {"mass", {0.3, 0.4, 0.3}},
                              {"mass_matrix", {{0.3, 0.01}, {0.01, 0.4}}},
                              {"delay_s", 0.0},
                              {"max_force", 10.0},
                              {"max_stiffness", nullptr}};
    const std::vector<json> matrices{{{0.3, 0.01}, {0.01, 0.4}},  // well-formed: accepted
                                     {{0.3, 0.0, 0.0}, {0.0, 0.4, 0.0}},
                                     json::array({{0.3}, {0.4}}),
                                     {{0.3, "0"}, {0.0, 0.4}},
                                     nullptr,
                                     json::array({0.3, 0.4})};
    for (std::size_t k = 0; k < matrices.size(); ++k) {
        SCOPED_TRACE(matrices[k].dump());
        ::unlink(path.c_str());
        const int listener = ::socket(AF_UNIX, SOCK_SEQPACKET | SOCK_CLOEXEC, 0);
        ASSERT_GE(listener, 0);
        sockaddr_un addr{};
        addr.sun_family = AF_UNIX;
        std::strncpy(addr.sun_path, path.c_str(), sizeof(addr.sun_path) - 1);
        ASSERT_EQ(::bind(listener, reinterpret_cast<const sockaddr*>(&addr), sizeof(addr)), 0) << std::strerror(errno);
        ASSERT_EQ(::listen(listener, 1), 0);
        json device = good_device;
        if (matrices[k].is_null()) {
            device.erase("mass_matrix");
        } else {
            device["mass_matrix"] = matrices[k];
        }
        const std::string welcome =
            json{{"type", "welcome"},          {"protocol", 1},   {"session", 1},         {"lease_s", 0.0},
                 {"max_message_bytes", 65536}, {"capacity", 64},  {"state_shm", "/fake"}, {"ramp_s", 0.03},
                 {"max_force_rate", 10000},    {"device", device}}
                .dump();
        std::thread server([&] {
            const int fd = ::accept(listener, nullptr, nullptr);
            if (fd < 0) return;
            std::vector<char> hello(70000);
            if (::recv(fd, hello.data(), hello.size(), 0) > 0)
                (void)::send(fd, welcome.data(), welcome.size(), MSG_NOSIGNAL);
            ::close(fd);
        });
        try {
            const cl::Client c = cl::Client::connect({.socket_path = path, .client_name = "fake", .timeout_s = 5.0});
            EXPECT_EQ(k, 0U) << "accepted";
            EXPECT_EQ(c.welcome().device.mass_matrix[0][1], 0.01);
            EXPECT_EQ(c.welcome().device.mass_matrix[1][1], 0.4);
            EXPECT_EQ(c.welcome().device.mass_matrix[2][2], 0.0);
        } catch (const cl::Error& e) {
            const std::string what = e.what();
            EXPECT_NE(k, 0U) << what;
            EXPECT_EQ(e.code(), cl::ErrorCode::BadMessage) << what;
            EXPECT_EQ(what.rfind("Client::connect: the welcome's device.mass_matrix", 0), 0U) << what;
            EXPECT_NE(what.find("2 rows of 2 numbers"), std::string::npos) << what;
        }
        server.join();
        ::close(listener);
    }
    ::unlink(path.c_str());
}

bool running_as_root() { return ::geteuid() == 0; }

TEST_F(ServerProtocol, SocketModeAndOwnerAndASecondUserIsRefused) {
    struct stat st {};
    ASSERT_EQ(::stat(n_->socket.c_str(), &st), 0);
    EXPECT_TRUE(S_ISSOCK(st.st_mode));
    EXPECT_EQ(st.st_mode & 0777, 0660U);
    EXPECT_EQ(st.st_uid, ::geteuid());
    EXPECT_EQ(st.st_gid, ::getegid());
    if (!running_as_root()) GTEST_SKIP() << "the second-user check needs root (setuid to nobody)";
    const passwd* nobody = ::getpwnam("nobody");
    ASSERT_NE(nobody, nullptr);
    // The directory must be traversable by nobody for the file mode to be what decides.
    ::chmod(scratch().c_str(), 0755);
    const pid_t pid = ::fork();
    if (pid == 0) {
        if (::setgid(nobody->pw_gid) != 0 || ::setuid(nobody->pw_uid) != 0) ::_exit(3);
        const int fd = ::socket(AF_UNIX, SOCK_SEQPACKET, 0);
        sockaddr_un addr{};
        addr.sun_family = AF_UNIX;
        std::strncpy(addr.sun_path, n_->socket.c_str(), sizeof(addr.sun_path) - 1);
        const int r = ::connect(fd, reinterpret_cast<const sockaddr*>(&addr), sizeof(addr));
        ::_exit(r != 0 && errno == EACCES ? 0 : 1);
    }
    int status = 0;
    ASSERT_EQ(::waitpid(pid, &status, 0), pid);
    ASSERT_TRUE(WIFEXITED(status));
    EXPECT_EQ(WEXITSTATUS(status), 0) << "nobody could connect to a 0660 root socket (3: setuid failed)";
}

// With --serve-mode 0666 the same second user is served: the mode, not the server, decides.
TEST(ServerSocketMode, AWiderModeLetsTheSecondUserIn) {
    if (!running_as_root()) GTEST_SKIP() << "needs root (setuid to nobody)";
    const Names n = names("mode");
    Child daemon(HAPTICD_BINARY, daemon_args(n, {"--serve-mode", "0666", "--scenario", "step", "--step-force", "0"}),
                 "mode_daemon");
    ASSERT_TRUE(wait_for_socket(n.socket)) << daemon.err();
    struct stat st {};
    ASSERT_EQ(::stat(n.socket.c_str(), &st), 0);
    EXPECT_EQ(st.st_mode & 0777, 0666U);
    const passwd* nobody = ::getpwnam("nobody");
    ASSERT_NE(nobody, nullptr);
    ::chmod(scratch().c_str(), 0755);
    const pid_t pid = ::fork();
    if (pid == 0) {
        if (::setgid(nobody->pw_gid) != 0 || ::setuid(nobody->pw_uid) != 0) ::_exit(3);
        try {
            cl::Client c = cl::Client::connect({.socket_path = n.socket, .client_name = "nobody"});
            ::_exit(c.welcome().protocol == 1 ? 0 : 1);
        } catch (...) {
            ::_exit(2);
        }
    }
    int status = 0;
    ASSERT_EQ(::waitpid(pid, &status, 0), pid);
    EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0) << status;
    daemon.signal(SIGTERM);
    EXPECT_EQ(daemon.wait(), 0);
    EXPECT_NE(daemon.err().find("uid " + std::to_string(nobody->pw_uid)), std::string::npos);  // SO_PEERCRED logged
}

}  // namespace
}  // namespace hapticd::server_test
