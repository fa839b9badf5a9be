// SPDX-License-Identifier: Apache-2.0
#include "server/message_decoder.hpp"

#include <cmath>

#include <nlohmann/json.hpp>

#include "client/object_json.hpp"
#include "client/text_limits.hpp"

namespace hapticd::server {

namespace {

using client::ErrorCode;
using nlohmann::json;

DecodeError error(ErrorCode code, std::string message, std::optional<std::uint64_t> id = std::nullopt) {
    DecodeError e;
    e.code = code;
    e.message = std::move(message);
    e.id = id;
    return e;
}

constexpr std::uint64_t kMaxId = (std::uint64_t{1} << 53);

DecodeResult decode_hello(const json& j) {
    if (!j.contains("type") || !j["type"].is_string() || j["type"].get<std::string>() != "hello") {
        return error(ErrorCode::BadHello,
                     "decode_message: the first message must be {\"type\": \"hello\", \"protocol\": 1, ...}");
    }
    const auto p = j.find("protocol");
    if (p == j.end() || !p->is_number_integer()) {
        return error(ErrorCode::BadHello,
                     "decode_message: hello.protocol: missing or not an integer; this server speaks protocol 1");
    }
    HelloRequest h;
    const auto v = p->get<std::int64_t>();
    if (v != kServerProtocol) {
        DecodeError e = error(ErrorCode::ProtocolVersion, "hello: protocol = " + std::to_string(v) +
                                                              " is not supported; this server speaks protocol " +
                                                              std::to_string(kServerProtocol));
        e.client_protocol = v > 1000000 || v < -1000000 ? -1 : static_cast<int>(v);
        return e;
    }
    h.protocol = static_cast<int>(v);
    if (const auto c = j.find("client"); c != j.end()) {
        if (!c->is_string() || c->get_ref<const std::string&>().size() > 64) {
            return error(ErrorCode::BadHello, "decode_message: hello.client: expected a string of at most 64 bytes");
        }
        h.client = c->get<std::string>();
    }
    if (const auto l = j.find("lease_s"); l != j.end() && !l->is_null()) {
        if (!l->is_number() || !std::isfinite(l->get<double>())) {
            return error(
                ErrorCode::BadHello,
                "decode_message: hello.lease_s: expected a number; accepted range: 0 (no lease) or 0.01 .. 60 s");
        }
        h.lease_s = l->get<double>();
        if (!(h.lease_s == 0.0 || (h.lease_s >= 0.01 && h.lease_s <= 60.0))) {
            return error(ErrorCode::BadHello, "decode_message: hello.lease_s = " + std::to_string(h.lease_s) +
                                                  " is invalid; accepted range: 0 (no lease) or 0.01 .. 60 s");
        }
    }
    return Request{std::nullopt, h};
}

DecodeResult decode_commit(const json& j, std::uint64_t id) {
    const auto ops = j.find("ops");
    if (ops == j.end() || !ops->is_array()) {
        return error(ErrorCode::BadMessage,
                     "decode_message: commit.ops: missing or not an array; expected 1 .. 64 operations", id);
    }
    if (ops->empty() || ops->size() > kMaxOpsPerCommit) {
        return error(
            ErrorCode::BadMessage,
            "decode_message: commit.ops: " + std::to_string(ops->size()) + " operations; accepted range: 1 .. 64", id);
    }
    CommitRequest c;
    int index = 0;
    for (const json& op : *ops) {
        auto fail = [&](const std::string& what) {
            DecodeError e =
                error(ErrorCode::BadMessage, "decode_message: commit.ops[" + std::to_string(index) + "]" + what, id);
            e.op_index = index;
            return e;
        };
        if (!op.is_object() || !op.contains("op") || !op["op"].is_string()) {
            return fail(": expected an object with \"op\": add | modify | remove | clear");
        }
        const std::string kind = op["op"].get<std::string>();
        CommitOperation o;
        if (kind == "add") {
            o.kind = CommitOperation::Kind::Add;
        } else if (kind == "modify") {
            o.kind = CommitOperation::Kind::Modify;
        } else if (kind == "remove") {
            o.kind = CommitOperation::Kind::Remove;
        } else if (kind == "clear") {
            o.kind = CommitOperation::Kind::Clear;
        } else {
            return fail(".op: \"" + client::truncate_utf8(kind, 40) +
                        "\" is invalid; accepted: add, modify, remove, clear");
        }
        if (o.kind == CommitOperation::Kind::Modify || o.kind == CommitOperation::Kind::Remove) {
            const auto oid = op.find("object_id");
            if (oid == op.end() || !oid->is_number_unsigned() || oid->get<std::uint64_t>() == 0 ||
                oid->get<std::uint64_t>() > 0xffffffffULL) {
                return fail(".object_id: missing or invalid; accepted range: an object id 1 .. 2^32-1");
            }
            o.object_id = static_cast<std::uint32_t>(oid->get<std::uint64_t>());
        }
        if (o.kind == CommitOperation::Kind::Add || o.kind == CommitOperation::Kind::Modify) {
            const auto obj = op.find("object");
            if (obj == op.end()) return fail(".object: missing; expected an object description");
            std::string why;
            o.object = client::object_from_json(*obj, why);
            if (!o.object) return fail("." + why);
        }
        c.ops.push_back(std::move(o));
        ++index;
    }
    return Request{id, std::move(c)};
}

DecodeResult decode_subscribe_contacts(const json& j, std::uint64_t id) {
    SubscribeContactsRequest r;
    const auto ids = j.find("object_ids");
    if (ids == j.end() || ids->is_null()) return Request{id, r};
    const std::string accepted =
        "; accepted: an array of 1 .. 64 object ids, each 1 .. 2^32-1 (absent or null: every object)";
    if (!ids->is_array() || ids->empty() || ids->size() > kMaxContactFilterIds) {
        return error(ErrorCode::BadMessage,
                     "decode_message: subscribe_contacts.object_ids: " +
                         (ids->is_array() ? std::to_string(ids->size()) + " ids" : std::string("not an array")) +
                         accepted,
                     id);
    }
    std::vector<std::uint32_t> out;
    for (std::size_t i = 0; i < ids->size(); ++i) {
        const json& v = (*ids)[i];
        if (!v.is_number_unsigned() || v.get<std::uint64_t>() == 0 || v.get<std::uint64_t>() > 0xffffffffULL) {
            return error(ErrorCode::BadMessage,
                         "decode_message: subscribe_contacts.object_ids[" + std::to_string(i) + "] = " +
                             client::truncate_utf8(v.dump(-1, ' ', false, json::error_handler_t::replace), 40) +
                             " is invalid" + accepted,
                         id);
        }
        out.push_back(static_cast<std::uint32_t>(v.get<std::uint64_t>()));
    }
    r.object_ids = std::move(out);
    return Request{id, r};
}

// `field` of a mesh request: a mesh id 1 .. 2^32-1.
std::optional<std::uint32_t> mesh_id(const json& j, const char* field) {
    const auto m = j.find(field);
    if (m == j.end() || !m->is_number_unsigned() || m->get<std::uint64_t>() == 0 ||
        m->get<std::uint64_t>() > 0xffffffffULL) {
        return std::nullopt;
    }
    return static_cast<std::uint32_t>(m->get<std::uint64_t>());
}

DecodeResult decode_mesh_begin(const json& j, std::uint64_t id) {
    MeshBeginRequest r;
    for (const char* field : {"vertices", "triangles"}) {
        const auto v = j.find(field);
        if (v == j.end() || !v->is_number_unsigned() || v->get<std::uint64_t>() > 0xffffffffULL) {
            return error(ErrorCode::BadMessage,
                         std::string("decode_message: mesh_begin.") + field +
                             ": missing or not an integer 0 .. 2^32-1 (the mesh's count; docs/protocol.md, section 4a)",
                         id);
        }
        (std::string(field) == "vertices" ? r.vertices : r.triangles) = v->get<std::uint64_t>();
    }
    const auto mode = j.find("mode");
    if (mode == j.end() || !mode->is_string() ||
        (mode->get_ref<const std::string&>() != "surface" && mode->get_ref<const std::string&>() != "solid")) {
        return error(ErrorCode::BadMessage,
                     "decode_message: mesh_begin.mode: missing or invalid; accepted: \"surface\" "
                     "(one-sided) or \"solid\" (closed, edge-manifold)",
                     id);
    }
    r.solid = mode->get_ref<const std::string&>() == "solid";
    return Request{id, r};
}

DecodeResult decode_mesh_chunk(const json& j, std::uint64_t id) {
    MeshChunkRequest r;
    const auto mesh = mesh_id(j, "mesh");
    if (!mesh)
        return error(ErrorCode::BadMessage,
                     "decode_message: mesh_chunk.mesh: missing or invalid; accepted: a mesh id 1 .. 2^32-1", id);
    r.mesh = *mesh;
    const auto first = j.find("first");
    if (first == j.end() || !first->is_number_unsigned() || first->get<std::uint64_t>() > 0xffffffffULL) {
        return error(ErrorCode::BadMessage,
                     "decode_message: mesh_chunk.first: missing or invalid; accepted: an index 0 .. 2^32-1", id);
    }
    r.first = first->get<std::uint64_t>();
    const auto v = j.find("vertices");
    const auto t = j.find("triangles");
    if ((v == j.end()) == (t == j.end())) {
        return error(ErrorCode::BadMessage,
                     "decode_message: mesh_chunk: expected exactly one of \"vertices\" (a flat array of 3k numbers) "
                     "and \"triangles\" (a flat array of 3k indices)",
                     id);
    }
    r.triangles = t != j.end();
    const json& a = r.triangles ? *t : *v;
    const char* name = r.triangles ? "triangles" : "vertices";
    if (!a.is_array() || a.empty() || a.size() % 3 != 0) {
        return error(ErrorCode::BadMessage,
                     std::string("decode_message: mesh_chunk.") + name + ": " +
                         (a.is_array() ? std::to_string(a.size()) + " values" : std::string("not an array")) +
                         "; expected a flat array of 3k values, k >= 1",
                     id);
    }
    if (r.triangles) {
        r.indices.reserve(a.size());
    } else {
        r.vertices.reserve(a.size());
    }
    for (std::size_t i = 0; i < a.size(); ++i) {
        const json& x = a[i];
        if (r.triangles) {
            if (!x.is_number_unsigned() || x.get<std::uint64_t>() > 0xffffffffULL) {
                return error(ErrorCode::BadMessage,
                             "decode_message: mesh_chunk.triangles[" + std::to_string(i) +
                                 "]: not a vertex index; accepted: an integer 0 .. 2^32-1",
                             id);
            }
            r.indices.push_back(static_cast<std::uint32_t>(x.get<std::uint64_t>()));
        } else {
            if (!x.is_number() || !std::isfinite(x.get<double>()) || std::fabs(x.get<double>()) > kMaxMeshCoordinate) {
                return error(ErrorCode::BadMessage,
                             "decode_message: mesh_chunk.vertices[" + std::to_string(i) +
                                 "]: not a coordinate; accepted: a finite number of metres, |x| <= 10",
                             id);
            }
            r.vertices.push_back(x.get<double>());
        }
    }
    return Request{id, std::move(r)};
}

template <class T>
DecodeResult decode_mesh_ref(const json& j, std::uint64_t id, const char* type) {
    const auto mesh = mesh_id(j, "mesh");
    if (!mesh) {
        return error(
            ErrorCode::BadMessage,
            std::string("decode_message: ") + type + ".mesh: missing or invalid; accepted: a mesh id 1 .. 2^32-1", id);
    }
    T r;
    r.mesh = *mesh;
    return Request{id, r};
}

}  // namespace

DecodeResult decode_message(std::string_view bytes, bool expect_hello) noexcept {
    try {
        if (bytes.size() > client::kMaxMessageBytes) {
            return error(ErrorCode::Oversized, "decode_message: message of " + std::to_string(bytes.size()) +
                                                   " bytes; accepted: at most 65536 bytes");
        }
        const ErrorCode bad = expect_hello ? ErrorCode::BadHello : ErrorCode::BadJson;
        if (bytes.empty()) return error(bad, "decode_message: an empty message; expected one JSON object per message");
        // nlohmann's lexer reads a NUL byte as the end of the input: a message with one would be cut there.
        if (const auto nul = bytes.find('\0'); nul != std::string_view::npos) {
            return error(bad, "decode_message: a NUL byte at byte " + std::to_string(nul) +
                                  "; expected one UTF-8 JSON object without NUL bytes");
        }
        json j;
        std::string last_key;  // the key whose value was being read when the parse failed
        const json::parser_callback_t track_keys = [&last_key](int, json::parse_event_t event, json& parsed) {
            if (event == json::parse_event_t::key && parsed.is_string())
                last_key = client::truncate_utf8(parsed.get_ref<const std::string&>(), 40);
            return true;
        };
        try {
            j = json::parse(bytes.begin(), bytes.end(), track_keys, true);
        } catch (const json::out_of_range&) {  // 406: a number beyond the range of a double (1e400)
            return error(
                bad, "decode_message: " +
                         (last_key.empty() ? std::string("a number") : "the value of \"" + last_key + "\"") +
                         " is beyond the range of a double; accepted: finite numbers, |x| <= 1.7976931348623157e308");
        } catch (const json::parse_error& e) {
            return error(bad, "decode_message: not valid UTF-8 JSON at byte " + std::to_string(e.byte) +
                                  (last_key.empty() ? std::string() : " (after the key \"" + last_key + "\")") +
                                  "; expected one JSON object per message");
        }
        if (!j.is_object()) {
            return error(expect_hello ? ErrorCode::BadHello : ErrorCode::BadJson,
                         "decode_message: expected a JSON object, got " + std::string(j.type_name()));
        }
        if (expect_hello) return decode_hello(j);
        const auto idit = j.find("id");
        if (idit == j.end() || !idit->is_number_unsigned() || idit->get<std::uint64_t>() > kMaxId) {
            return error(ErrorCode::BadMessage,
                         "decode_message: id: missing or invalid; accepted range: an integer 0 .. 2^53");
        }
        const std::uint64_t id = idit->get<std::uint64_t>();
        const auto type = j.find("type");
        if (type == j.end() || !type->is_string()) {
            return error(ErrorCode::BadMessage, "decode_message: type: missing or not a string", id);
        }
        const std::string& t = type->get_ref<const std::string&>();
        if (t == "heartbeat") return Request{id, HeartbeatRequest{}};
        if (t == "commit") return decode_commit(j, id);
        if (t == "list") return Request{id, ListRequest{}};
        if (t == "status") return Request{id, StatusRequest{}};
        if (t == "unsubscribe") return Request{id, UnsubscribeRequest{}};
        if (t == "bye") return Request{id, ByeRequest{}};
        if (t == "subscribe_contacts") return decode_subscribe_contacts(j, id);
        if (t == "unsubscribe_contacts") return Request{id, UnsubscribeContactsRequest{}};
        if (t == "mesh_begin") return decode_mesh_begin(j, id);
        if (t == "mesh_chunk") return decode_mesh_chunk(j, id);
        if (t == "mesh_end") return decode_mesh_ref<MeshEndRequest>(j, id, "mesh_end");
        if (t == "mesh_status") return decode_mesh_ref<MeshStatusRequest>(j, id, "mesh_status");
        if (t == "mesh_delete") return decode_mesh_ref<MeshDeleteRequest>(j, id, "mesh_delete");
        if (t == "subscribe") {
            const auto r = j.find("rate_hz");
            if (r == j.end() || !r->is_number() || !(r->get<double>() >= 0.1 && r->get<double>() <= 1000.0)) {
                return error(
                    ErrorCode::BadMessage,
                    "decode_message: subscribe.rate_hz: missing or out of range; accepted range: 0.1 .. 1000 Hz", id);
            }
            return Request{id, SubscribeRequest{r->get<double>()}};
        }
        if (t == "hello")
            return error(ErrorCode::BadMessage, "decode_message: hello: already welcomed (hello only once)", id);
        return error(
            ErrorCode::BadMessage,
            "decode_message: type = \"" + client::truncate_utf8(t, 40) +
                "\" is invalid; accepted: heartbeat, commit, list, status, subscribe, unsubscribe, "
                "subscribe_contacts, unsubscribe_contacts, bye, mesh_begin, mesh_chunk, mesh_end, mesh_status, "
                "mesh_delete",
            id);
    } catch (const std::exception& e) {
        return error(ErrorCode::BadMessage, std::string("decode_message: ") + e.what());
    } catch (...) {
        return error(ErrorCode::BadMessage, "decode_message: unreadable message");
    }
}

}  // namespace hapticd::server
