// SPDX-License-Identifier: Apache-2.0
#include "server/reply_text.hpp"

#include "client/text_limits.hpp"
#include "hapticd/client.hpp"

namespace hapticd::server {

namespace {

using nlohmann::json;

std::string dump_replacing(const json& j) { return j.dump(-1, ' ', false, json::error_handler_t::replace); }

// The reply when even the `internal` error cannot be encoded (built once, at start-up).
const std::string kUnencodable = std::string(R"({"type":"error","code":")") +
                                 client::to_string(client::ErrorCode::Internal) +
                                 R"(","id":null,"message":"reply_text: the reply could not be encoded"})";

}  // namespace

std::string reply_text(json message) noexcept {
    try {
        if (message.is_object()) {
            const auto m = message.find("message");
            if (m != message.end() && m->is_string() &&
                m->get_ref<const std::string&>().size() > kMaxErrorMessageBytes) {
                *m = client::truncate_utf8(m->get_ref<const std::string&>(), kMaxErrorMessageBytes);
            }
        }
        std::string text = dump_replacing(message);
        if (text.size() <= client::kMaxMessageBytes) return text;
        json internal{{"type", "error"},
                      {"code", client::to_string(client::ErrorCode::Internal)},
                      {"message", "reply_text: the reply of " + std::to_string(text.size()) +
                                      " bytes exceeds the protocol's limit of 65536 bytes"}};
        const bool has_id =
            message.is_object() && message.contains("id") && message["id"].is_number_integer() && message["id"] >= 0;
        internal["id"] = has_id ? message["id"] : json(nullptr);
        return dump_replacing(internal);
    } catch (...) {
        return kUnencodable;
    }
}

}  // namespace hapticd::server
