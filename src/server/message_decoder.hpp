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
// Mesh uploads (docs/protocol.md, section 4a). The decoder checks types and the per-message ranges; the counts'
// limits, the order of chunks and the mesh's validity are the mesh store's (server/mesh_store.hpp).
inline constexpr double kMaxMeshCoordinate = 10.0;  // m, |x|, |y|, |z| of a vertex in the mesh's frame
struct MeshBeginRequest {
    std::uint64_t vertices = 0;
    std::uint64_t triangles = 0;
    bool solid = false;  // mode: "solid" (closed, edge-manifold) or "surface" (one-sided)
};
struct MeshChunkRequest {
    std::uint32_t mesh = 0;
    std::uint64_t first = 0;             // index of the chunk's first vertex (or triangle)
    bool triangles = false;              // which array the chunk carries
    std::vector<double> vertices;        // x y z per vertex, m
    std::vector<std::uint32_t> indices;  // a b c per triangle
};
struct MeshEndRequest {
    std::uint32_t mesh = 0;
};
struct MeshStatusRequest {
    std::uint32_t mesh = 0;
};
struct MeshDeleteRequest {
    std::uint32_t mesh = 0;
};

using RequestBody =
    std::variant<HelloRequest, HeartbeatRequest, CommitRequest, ListRequest, StatusRequest, SubscribeRequest,
                 UnsubscribeRequest, SubscribeContactsRequest, UnsubscribeContactsRequest, ByeRequest, MeshBeginRequest,
                 MeshChunkRequest, MeshEndRequest, MeshStatusRequest, MeshDeleteRequest>;

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
