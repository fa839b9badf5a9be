// SPDX-License-Identifier: Apache-2.0
// The reply encoder and the client-text helpers (src/server/reply_text.*, src/client/text_limits.*): a
// cut never splits a UTF-8 character, log text has no control bytes, and no reply exceeds 65536 bytes or
// fails to encode, whatever text it carries.
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>
#include <string>

#include "client/text_limits.hpp"
#include "hapticd/client.hpp"
#include "server/reply_text.hpp"

namespace hapticd {
namespace {

using nlohmann::json;

TEST(TextLimits, ACutLandsOnACharacterBoundary) {
    const std::string e_acute = "\xc3\xa9";        // 2 bytes
    const std::string euro = "\xe2\x82\xac";       // 3 bytes
    const std::string smile = "\xf0\x9f\x98\x80";  // 4 bytes
    EXPECT_EQ(client::truncate_utf8(std::string(39, 'a') + e_acute, 40), std::string(39, 'a') + "...");
    EXPECT_EQ(client::truncate_utf8(std::string(38, 'a') + e_acute, 40), std::string(38, 'a') + e_acute);
    EXPECT_EQ(client::truncate_utf8("ab" + euro + "cd", 4), "ab...");
    EXPECT_EQ(client::truncate_utf8("ab" + smile, 5), "ab...");
    EXPECT_EQ(client::truncate_utf8("ab" + smile + "c", 6), "ab" + smile + "...");
    EXPECT_EQ(client::truncate_utf8("short", 40), "short");
    // Every cut of a mixed string parses back as a JSON string (the strict dump would throw otherwise).
    const std::string mixed = "a" + e_acute + euro + smile + "z" + euro + e_acute;
    for (std::size_t n = 0; n <= mixed.size(); ++n) {
        EXPECT_NO_THROW((void)json(client::truncate_utf8(mixed, n)).dump()) << n;
    }
}

TEST(TextLimits, LogTextHasNoControlBytes) {
    EXPECT_EQ(client::escape_for_log("x\nhapticd: forged\x1b[2J\\"), "x\\x0ahapticd: forged\\x1b[2J\\x5c");
    EXPECT_EQ(client::escape_for_log(std::string(200, 'n'), 10), std::string(10, 'n') + "...");
}

TEST(ReplyText, InvalidUtf8IsReplacedAndLongMessagesAreCut) {
    json reply{{"type", "error"}, {"code", "bad_message"}, {"id", 7}, {"message", std::string("bad \xc3 byte")}};
    const std::string text = server::reply_text(reply);
    const json back = json::parse(text);
    EXPECT_EQ(back["message"], "bad \xef\xbf\xbd byte");  // U+FFFD
    reply["message"] = std::string(100000, '"');          // escaped: 200 KB
    const std::string cut = server::reply_text(reply);
    EXPECT_LE(cut.size(), client::kMaxMessageBytes);
    EXPECT_EQ(json::parse(cut)["message"].get<std::string>().size(), server::kMaxErrorMessageBytes + 3);
}

TEST(ReplyText, AReplyThatStillDoesNotFitBecomesAnInternalErrorWithItsId) {
    json objects = json::array();
    for (int i = 0; i < 2000; ++i) objects.push_back(std::string(40, 'o'));
    const std::string text = server::reply_text(json{{"type", "ok"}, {"id", 9}, {"objects", objects}});
    EXPECT_LE(text.size(), client::kMaxMessageBytes);
    const json back = json::parse(text);
    EXPECT_EQ(back["code"], "internal");
    EXPECT_EQ(back["id"], 9);
}

}  // namespace
}  // namespace hapticd
