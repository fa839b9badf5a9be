// SPDX-License-Identifier: Apache-2.0
// libFuzzer target: the server's message decoder (src/server/message_decoder.*, nlohmann-json underneath)
// on arbitrary bytes, both before the handshake (only hello accepted) and after it. Invariants: no crash
// and no exception (decode_message is noexcept: anything escaping aborts); an error carries one of the
// protocol's codes and a message naming the function; a decoded hello speaks protocol 1 with a lease of 0 or
// 0.01 .. 60 s; a decoded request after the handshake has an id <= 2^53; a commit has 1 .. 64 operations,
// adds and modifies carry an object, modifies and removes an id >= 1; every decoded object re-encodes
// (object_to_json) and decodes again to the same kind.
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <set>
#include <string>
#include <string_view>

#include "client/object_json.hpp"
#include "server/message_decoder.hpp"

namespace {

void check(bool ok) {
    if (!ok) std::abort();
}

void check_result(const hapticd::server::DecodeResult& r, bool expect_hello) {
    using namespace hapticd::server;
    static const std::set<std::string> codes{"bad_json", "bad_message", "bad_hello", "protocol_version", "oversized"};
    if (const auto* e = std::get_if<DecodeError>(&r)) {
        check(codes.count(e->code) == 1);
        check(!e->message.empty());
        check(e->message.rfind("decode_message", 0) == 0 || e->message.rfind("hello:", 0) == 0);
        if (expect_hello) check(e->code != "bad_message" && e->code != "bad_json");
        return;
    }
    const auto& req = std::get<Request>(r);
    if (expect_hello) {
        const auto* h = std::get_if<HelloRequest>(&req.body);
        check(h != nullptr);
        check(h->protocol == kServerProtocol);
        check(h->lease_s == 0.0 || (h->lease_s >= 0.01 && h->lease_s <= 60.0));
        check(h->client.size() <= 64);
        return;
    }
    check(req.id.has_value() && *req.id <= (std::uint64_t{1} << 53));
    check(!std::holds_alternative<HelloRequest>(req.body));
    if (const auto* s = std::get_if<SubscribeRequest>(&req.body)) check(s->rate_hz >= 0.1 && s->rate_hz <= 1000.0);
    if (const auto* c = std::get_if<CommitRequest>(&req.body)) {
        check(!c->ops.empty() && c->ops.size() <= kMaxOpsPerCommit);
        for (const auto& op : c->ops) {
            const bool needs_object = op.kind == CommitOperation::Kind::Add || op.kind == CommitOperation::Kind::Modify;
            check(op.object.has_value() == needs_object);
            if (op.kind == CommitOperation::Kind::Modify || op.kind == CommitOperation::Kind::Remove) check(op.object_id >= 1);
            if (op.object) {
                std::string why;
                const auto again = hapticd::client::object_from_json(hapticd::client::object_to_json(*op.object), why);
                check(again.has_value() && again->index() == op.object->index());
            }
        }
    }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    const std::string_view bytes(reinterpret_cast<const char*>(data), size);
    check_result(hapticd::server::decode_message(bytes, true), true);
    check_result(hapticd::server::decode_message(bytes, false), false);
    return 0;
}
