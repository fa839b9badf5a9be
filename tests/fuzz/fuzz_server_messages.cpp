// SPDX-License-Identifier: Apache-2.0
// libFuzzer target: the server's message decoder (src/server/message_decoder.*, nlohmann-json underneath)
// on arbitrary bytes, both before the handshake (only hello accepted) and after it. Invariants: no crash
// and no exception (decode_message is noexcept: anything escaping aborts); an error carries one of the
// protocol's codes and a message naming the function; a decoded hello speaks protocol 1 with a lease of 0 or
// 0.01 .. 60 s; a decoded request after the handshake has an id <= 2^53; a commit has 1 .. 64 operations,
// adds and modifies carry an object, modifies and removes an id >= 1; a subscribe_contacts filter has 1 .. 64 ids >= 1;
// mesh requests carry a mesh id >= 1 and chunks a non-empty flat array of 3k finite coordinates (|x| <= 10 m) or
// indices; every decoded object re-encodes (object_to_json) and decodes again to the same kind. Then the server's range
// checks (src/server/object_limits.*, on the 3-axis test profile's +-0.06 m workspace: an accepted plane meets it, an
// accepted point lies in it, accepted explicit gains are within the plausibility bounds) and the reply path
// (src/server/reply_text.*): the error reply for a decode error or a refusal, and an ok reply echoing every decoded
// object, are encoded without an exception, at most 65536 bytes, valid UTF-8 JSON that parses back. (The stability
// verdicts need the gain checker and are tested in tests/server/.)
#include <cstddef>
#include <cstdint>
#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <optional>
#include <set>
#include <string>
#include <string_view>

#include <nlohmann/json.hpp>

#include "client/object_json.hpp"
#include "hapticd/client.hpp"
#include "server/message_decoder.hpp"
#include "server/object_limits.hpp"
#include "server/reply_text.hpp"

namespace {

void check(bool ok) {
    if (!ok) std::abort();
}

// The bytes the server would send for `reply`: within the limit and parsing back (the strict parse
// rejects invalid UTF-8).
void check_reply(const nlohmann::json& reply) {
    const std::string text = hapticd::server::reply_text(reply);
    check(text.size() <= hapticd::client::kMaxMessageBytes);
    const nlohmann::json back = nlohmann::json::parse(text, nullptr, false);
    check(!back.is_discarded() && back.is_object());
}

// The range checks of one decoded object; a refusal goes through the reply path, an acceptance is checked.
void check_limits(const hapticd::client::ObjectDescription& object, std::uint64_t id) {
    using namespace hapticd::server;
    namespace cl = hapticd::client;
    const WorkspaceBox box{3, {-0.06, -0.06, -0.06}, {0.06, 0.06, 0.06}};
    std::optional<LimitRefusal> refusal;
    const cl::Gains* gains = nullptr;
    if (const auto* p = std::get_if<cl::Plane>(&object)) {
        refusal = check_plane_in_workspace(p->normal, p->offset, box);
        if (!refusal) {
            double n_lo = 0.0;  // the plane meets the box: some corner on each side (or on it)
            double n_hi = 0.0;
            for (std::size_t a = 0; a < 3; ++a) {
                n_lo += std::min(p->normal[a] * box.min[a], p->normal[a] * box.max[a]);
                n_hi += std::max(p->normal[a] * box.min[a], p->normal[a] * box.max[a]);
            }
            check(p->offset >= n_lo && p->offset <= n_hi);
        }
        gains = &p->gains;
    } else if (const auto* s = std::get_if<cl::Spring>(&object)) {
        refusal = check_in_workspace(s->point, "spring.point", box);
        if (!refusal) {
            for (std::size_t a = 0; a < 3; ++a) check(s->point[a] >= -0.06 && s->point[a] <= 0.06);
        }
        gains = &s->gains;
    } else if (const auto* m = std::get_if<cl::Mesh>(&object)) {
        refusal = check_in_workspace(m->position, "mesh.position", box);
        if (!refusal) {
            for (std::size_t a = 0; a < 3; ++a) check(m->position[a] >= -0.06 && m->position[a] <= 0.06);
        }
        check(m->mesh >= 1);
        gains = &m->gains;
    } else {
        const auto& f = std::get<cl::Field>(object);
        refusal = check_in_workspace(f.center, "field.center", box);
        if (!refusal) refusal = check_field_damping(f.damping);
        if (!refusal) check(f.damping >= 0.0 && f.damping <= kMaxGainB);
    }
    if (!refusal && gains != nullptr && gains->criterion.empty()) {
        refusal = check_explicit_gains(gains->K.value_or(0.0), gains->B.value_or(0.0), cl::kind_name(object));
        if (!refusal) check(*gains->K <= kMaxGainK && *gains->B <= kMaxGainB && *gains->K >= 0.0 && *gains->B >= 0.0);
    }
    if (refusal) {
        check(refusal->code == cl::ErrorCode::BeyondDeviceLimits || refusal->code == cl::ErrorCode::BadMessage);
        check_reply(nlohmann::json{{"type", "error"},
                                   {"id", id},
                                   {"code", cl::to_string(refusal->code)},
                                   {"message", "commit: ops[0]: " + refusal->message},
                                   {"op_index", 0}});
    }
}

void check_result(const hapticd::server::DecodeResult& r, bool expect_hello) {
    using namespace hapticd::server;
    using hapticd::client::ErrorCode;
    static const std::set<ErrorCode> codes{ErrorCode::BadJson, ErrorCode::BadMessage, ErrorCode::BadHello,
                                           ErrorCode::ProtocolVersion, ErrorCode::Oversized};
    if (const auto* e = std::get_if<DecodeError>(&r)) {
        nlohmann::json reply{{"type", "error"},
                             {"code", hapticd::client::to_string(e->code)},
                             {"message", e->message},
                             {"op_index", e->op_index}};
        reply["id"] = e->id ? nlohmann::json(*e->id) : nlohmann::json(nullptr);
        check_reply(reply);
        check(codes.count(e->code) == 1);
        check(!e->message.empty());
        check(e->message.rfind("decode_message", 0) == 0 || e->message.rfind("hello:", 0) == 0);
        if (expect_hello) check(e->code != ErrorCode::BadMessage && e->code != ErrorCode::BadJson);
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
    if (const auto* s = std::get_if<SubscribeContactsRequest>(&req.body); s != nullptr && s->object_ids) {
        check(!s->object_ids->empty() && s->object_ids->size() <= kMaxContactFilterIds);
        for (const std::uint32_t oid : *s->object_ids) check(oid >= 1);
    }
    if (const auto* m = std::get_if<MeshBeginRequest>(&req.body)) {
        check(m->vertices <= 0xffffffffULL && m->triangles <= 0xffffffffULL);
    }
    if (const auto* m = std::get_if<MeshChunkRequest>(&req.body)) {
        check(m->mesh >= 1 && m->first <= 0xffffffffULL);
        const std::size_t n = m->triangles ? m->indices.size() : m->vertices.size();
        check(n >= 3 && n % 3 == 0 && (m->triangles ? m->vertices.empty() : m->indices.empty()));
        for (const double x : m->vertices) check(std::isfinite(x) && std::fabs(x) <= kMaxMeshCoordinate);
    }
    if (const auto* m = std::get_if<MeshEndRequest>(&req.body)) check(m->mesh >= 1);
    if (const auto* m = std::get_if<MeshStatusRequest>(&req.body)) check(m->mesh >= 1);
    if (const auto* m = std::get_if<MeshDeleteRequest>(&req.body)) check(m->mesh >= 1);
    if (const auto* c = std::get_if<CommitRequest>(&req.body)) {
        check(!c->ops.empty() && c->ops.size() <= kMaxOpsPerCommit);
        for (const auto& op : c->ops) {
            const bool needs_object = op.kind == CommitOperation::Kind::Add || op.kind == CommitOperation::Kind::Modify;
            check(op.object.has_value() == needs_object);
            if (op.kind == CommitOperation::Kind::Modify || op.kind == CommitOperation::Kind::Remove)
                check(op.object_id >= 1);
            if (op.object) {
                std::string why;
                const auto again = hapticd::client::object_from_json(hapticd::client::object_to_json(*op.object), why);
                check(again.has_value() && again->index() == op.object->index());
                check_limits(*op.object, *req.id);
                // A list reply quotes the object back (criterion names are client text).
                check_reply(
                    nlohmann::json{{"type", "ok"},
                                   {"id", *req.id},
                                   {"objects", nlohmann::json::array({hapticd::client::object_to_json(*op.object)})}});
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
