// SPDX-License-Identifier: Apache-2.0
// Decodes one client message of protocol version 1 (docs/protocol.md) into a typed request, checking
// structure, types and ranges (the physics of objects is checked by the server afterwards). Never throws:
// bad input gives a DecodeError with the protocol's error code and a message naming the field and the
// accepted range. The libFuzzer target tests/fuzz/fuzz_server_messages.cpp runs it on arbitrary bytes.
#pragma once

#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <variant>
#include <vector>

#include "hapticd/client.hpp"

namespace hapticd::server {

inline constexpr int kServerProtocol = 1;
inline constexpr std::size_t kMaxOpsPerCommit = 64;

struct HelloRequest {
    int protocol = 0;
    std::string client;
    double lease_s = 0.0;
};
struct HeartbeatRequest {};
struct CommitOperation {
    enum class Kind { Add, Modify, Remove, Clear } kind = Kind::Add;
    std::uint32_t object_id = 0;
    std::optional<client::ObjectDescription> object;
};
struct CommitRequest {
    std::vector<CommitOperation> ops;
};
struct ListRequest {};
struct StatusRequest {};
struct SubscribeRequest {
    double rate_hz = 0.0;
};
struct UnsubscribeRequest {};
inline constexpr std::size_t kMaxContactFilterIds = 64;
// subscribe_contacts: every object's contact events, or (object_ids given) only those objects' (1 .. 64 ids,
// each 1 .. 2^32-1, duplicates allowed).
struct SubscribeContactsRequest {
    std::optional<std::vector<std::uint32_t>> object_ids;
};
struct UnsubscribeContactsRequest {};
struct ByeRequest {};

using RequestBody =
    std::variant<HelloRequest, HeartbeatRequest, CommitRequest, ListRequest, StatusRequest, SubscribeRequest,
                 UnsubscribeRequest, SubscribeContactsRequest, UnsubscribeContactsRequest, ByeRequest>;

struct Request {
    std::optional<std::uint64_t> id;  // absent for hello
    RequestBody body;
};

struct DecodeError {
    client::ErrorCode code =
        client::ErrorCode::BadMessage;  // BadJson, BadMessage, BadHello, ProtocolVersion, Oversized
    std::string message;                // names the field and the accepted range
    std::optional<std::uint64_t> id;    // when the message had a readable id
    int client_protocol = 0;            // protocol_version: what the client asked for
    int op_index = -1;
};

using DecodeResult = std::variant<Request, DecodeError>;

// `expect_hello`: the session has not been welcomed yet (only hello is accepted).
DecodeResult decode_message(std::string_view bytes, bool expect_hello) noexcept;

}  // namespace hapticd::server
