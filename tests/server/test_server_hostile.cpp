// SPDX-License-Identifier: Apache-2.0
// A hostile or careless client against a running hapticd --serve (docs/protocol.md, sections 5 and 8):
// messages that used to end the daemon (a reply cut inside a UTF-8 character, a plane at offset 1e308),
// replies beyond the size limit, and the protocol's edges (NUL bytes, empty messages, an empty criterion,
// numbers beyond a double, control characters in the client's name). After each, the daemon still runs,
// the loop ticks without a fault and the same session is still served.
#include "server_fixture.hpp"

namespace hapticd::server_test {
namespace {

constexpr char kHostileTag[] = "hostile";
class HostileClient : public SharedDaemonTest<kHostileTag> {
  protected:
    // The daemon runs, the loop ticks without a fault, and `c` is still served.
    static void expect_alive(const RawConnection& c, std::uint64_t id) {
        ASSERT_TRUE(daemon_->running()) << daemon_->err();
        c.send(R"({"type":"status","id":)" + std::to_string(id) + "}");
        const json r = c.receive_json();
        EXPECT_EQ(r.value("type", ""), "ok") << r.dump();
        EXPECT_EQ(r.value("fault", ""), "none") << r.dump();
    }
    static json commit_one(const RawConnection& c, std::uint64_t id, const json& object) {
        c.send(json{{"type", "commit"}, {"id", id}, {"ops", json::array({json{{"op", "add"}, {"object", object}}})}}
                   .dump());
        return c.receive_json();
    }
};

// Valid UTF-8 throughout (what json::dump with the strict handler would have thrown on).
bool valid_utf8(const std::string& s) {
    std::size_t i = 0;
    while (i < s.size()) {
        const auto c = static_cast<unsigned char>(s[i]);
        const std::size_t n = c < 0x80 ? 1 : (c >> 5) == 0x6 ? 2 : (c >> 4) == 0xe ? 3 : (c >> 3) == 0x1e ? 4 : 0;
        if (n == 0 || i + n > s.size()) return false;
        for (std::size_t k = 1; k < n; ++k) {
            if ((static_cast<unsigned char>(s[i + k]) & 0xc0) != 0x80) return false;
        }
        i += n;
    }
    return true;
}

TEST_F(HostileClient, AValueCutInsideAUtf8CharacterIsAnsweredNotFatal) {
    RawConnection c(n_->socket);
    c.hello();
    // 54 bytes: the type's 40th byte is the first of the two bytes of U+00E9.
    c.send(R"({"type":")" + std::string(39, 'a') + "\xc3\xa9" + R"(","id":1})");
    const auto raw = c.receive();
    ASSERT_TRUE(raw.has_value());
    ASSERT_FALSE(raw->empty()) << "the session was closed";
    EXPECT_TRUE(valid_utf8(*raw)) << *raw;
    const json r = json::parse(*raw, nullptr, false);
    EXPECT_EQ(r.value("code", ""), "bad_message") << *raw;
    EXPECT_NE(r.value("message", "").find("type"), std::string::npos) << *raw;
    expect_alive(c, 2);
    // The same through gains.criterion and plane.mode.
    json p = plane({0, 0, 1}, 0.0, json{{"criterion", std::string(39, 'C') + "\xc3\xa9"}});
    json r2 = commit_one(c, 3, p);
    EXPECT_EQ(r2.value("code", ""), "unknown_criterion") << r2.dump();
    p = plane({0, 0, 1}, 0.0, json{{"K", 10}, {"B", 1}});
    p["mode"] = std::string(38, 'm') + "\xc3\xa9";  // quoted: bytes 39-40 are U+00E9
    r2 = commit_one(c, 4, p);
    EXPECT_EQ(r2.value("code", ""), "bad_message") << r2.dump();
    expect_alive(c, 5);
}

TEST_F(HostileClient, APlaneOutsideTheWorkspaceIsRefusedNamingOffsetAndTheRange) {
    RawConnection c(n_->socket);
    c.hello();
    json r = commit_one(c, 1, plane({0, 0, 1}, 1e308, json{{"K", 100}, {"B", 1}}));
    EXPECT_EQ(r.value("code", ""), "beyond_device_limits") << r.dump();
    const std::string m = r.value("message", "");
    EXPECT_NE(m.find("plane.offset"), std::string::npos) << m;
    EXPECT_NE(m.find("-0.06 .. 0.06"), std::string::npos) << m;  // sim3.toml: +-0.06 m on every axis
    // An oblique normal: n.x over the box spans +-0.06 (|n_0| + |n_1|) = +-0.084853 m.
    const double s = std::sqrt(0.5);
    r = commit_one(c, 2, plane({s, s, 0}, 0.09, json{{"K", 100}, {"B", 1}}));
    EXPECT_EQ(r.value("code", ""), "beyond_device_limits") << r.dump();
    r = commit_one(c, 3, plane({s, s, 0}, 0.08, json{{"K", 100}, {"B", 1}}));
    EXPECT_EQ(r.value("type", ""), "ok") << r.dump();
    // Explicit gains beyond the plausibility bound are refused before the stability test.
    r = commit_one(c, 4, plane({0, 0, 1}, -0.05, json{{"K", 1e300}, {"B", 1e300}}));
    EXPECT_EQ(r.value("code", ""), "bad_message") << r.dump();
    EXPECT_NE(r.value("message", "").find("K <= 1e+12"), std::string::npos) << r.dump();
    json f{{"kind", "field"},
           {"center", {0, 0, 0}},
           {"radius", 0.01},
           {"force", {0, 0, 0}},
           {"jacobian", {{0, 0, 0}, {0, 0, 0}, {0, 0, 0}}},
           {"damping", 1e300}};
    r = commit_one(c, 7, f);
    EXPECT_EQ(r.value("code", ""), "bad_message") << r.dump();
    EXPECT_NE(r.value("message", "").find("field.damping"), std::string::npos) << r.dump();
    expect_alive(c, 5);
    c.send(R"({"type":"commit","id":6,"ops":[{"op":"clear"}]})");
    EXPECT_EQ(c.receive_json().value("type", ""), "ok");
}

TEST_F(HostileClient, AReplyStaysWithinTheLimitWhateverTheClientQuotes) {
    RawConnection c(n_->socket);
    c.hello();
    // 30000 quotes: 60000 bytes escaped in the request; quoted whole and escaped again, 120 KB.
    json p = plane({0, 0, 1}, 0.0, json{{"K", 10}, {"B", 1}});
    p["offset"] = std::string(30000, '"');
    c.send(json{{"type", "commit"}, {"id", 1}, {"ops", json::array({json{{"op", "add"}, {"object", p}}})}}.dump());
    const auto raw = c.receive();
    ASSERT_TRUE(raw.has_value() && !raw->empty());
    EXPECT_LE(raw->size(), 65536U);
    const json r = json::parse(*raw, nullptr, false);
    EXPECT_EQ(r.value("code", ""), "bad_message") << raw->substr(0, 300);
    EXPECT_NE(r.value("message", "").find("object.offset"), std::string::npos) << raw->substr(0, 300);
    expect_alive(c, 2);
}

TEST_F(HostileClient, ProtocolEdgesAreAnsweredAndTheSessionStays) {
    RawConnection c(n_->socket);
    c.hello();
    // A NUL byte after a complete object: the whole message is refused, not cut there.
    c.send(std::string(R"({"type":"heartbeat","id":1})") + std::string(1, '\0') + "trailing");
    json r = c.receive_json();
    EXPECT_EQ(r.value("code", ""), "bad_json") << r.dump();
    EXPECT_NE(r.value("message", "").find("NUL"), std::string::npos) << r.dump();
    // An empty message.
    c.send("");
    r = c.receive_json();
    EXPECT_EQ(r.value("code", ""), "bad_json") << r.dump();
    // An empty criterion: named, with the accepted list.
    r = commit_one(c, 2, plane({0, 0, 1}, 0.0, json{{"criterion", ""}}));
    EXPECT_EQ(r.value("code", ""), "bad_message") << r.dump();
    EXPECT_NE(r.value("message", "").find("criterion"), std::string::npos) << r.dump();
    EXPECT_NE(r.value("message", "").find("CE2"), std::string::npos) << r.dump();
    // A number beyond a double: the field is named.
    c.send(
        R"({"type":"commit","id":3,"ops":[{"op":"add","object":{"kind":"plane","normal":[0,0,1],"offset":1e400,"gains":{"K":10,"B":1}}}]})");
    r = c.receive_json();
    EXPECT_EQ(r.value("code", ""), "bad_json") << r.dump();
    EXPECT_NE(r.value("message", "").find("\"offset\""), std::string::npos) << r.dump();
    expect_alive(c, 4);
}

// Deep nesting cannot overflow the server thread's stack: nlohmann's parser keeps its nesting on the heap
// (json_sax_dom_callback_parser's stacks, not recursion) and destroys a value iteratively (3.11), and the
// size limit bounds the depth to 65536. Each message is answered and the session goes on.
TEST_F(HostileClient, DeepNestingIsAnsweredNotFatal) {
    RawConnection c(n_->socket);
    c.hello();
    c.send(std::string(65536, '['));  // at the size limit, never closed
    json r = c.receive_json();
    EXPECT_EQ(r.value("code", ""), "bad_json") << r.dump();
    c.send(std::string(32768, '[') + std::string(32768, ']'));  // complete, 32768 deep: not an object
    r = c.receive_json();
    EXPECT_EQ(r.value("code", ""), "bad_json") << r.dump();
    std::string deep;
    for (int i = 0; i < 10000; ++i) deep += R"({"a":)";
    deep += "1" + std::string(10000, '}');  // a valid object 10000 deep (60001 bytes): no id
    c.send(deep);
    r = c.receive_json();
    EXPECT_EQ(r.value("code", ""), "bad_message") << r.dump();
    c.send(R"({"type":"commit","id":1,"ops":)" + std::string(30000, '[') + std::string(30000, ']') + "}");
    r = c.receive_json();
    EXPECT_EQ(r.value("code", ""), "bad_message") << r.dump();
    EXPECT_EQ(r.value("id", 0), 1) << r.dump();
    expect_alive(c, 2);
    // Beyond the limit (100 000 deep): oversized, that session closed; the daemon serves the next.
    RawConnection big(n_->socket);
    big.hello();
    big.send(std::string(100000, '['));
    r = big.receive_json();
    EXPECT_EQ(r.value("code", ""), "oversized") << r.dump();
    expect_alive(c, 3);
}

TEST_F(HostileClient, AClientNameCannotForgeALogLine) {
    RawConnection c(n_->socket);
    c.send(R"({"type":"hello","protocol":1,"client":"x\nhapticd: server: forged line\u001b[2J"})");
    EXPECT_EQ(c.receive_json().value("type", ""), "welcome");
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
    const std::string log = daemon_->err();
    EXPECT_EQ(log.find("\nhapticd: server: forged line"), std::string::npos) << log;
    EXPECT_EQ(log.find('\x1b'), std::string::npos);
    EXPECT_NE(log.find("x\\x0ahapticd: server: forged line\\x1b[2J"), std::string::npos) << log;
    expect_alive(c, 1);
}

}  // namespace
}  // namespace hapticd::server_test
