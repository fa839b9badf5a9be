// SPDX-License-Identifier: Apache-2.0
// The client's requests (docs/protocol.md, sections 3, 4 and 4a): batches and commit (with the busy retry),
// mesh uploads, heartbeat, list and status. Sent and answered by Client::request (client.cpp).
#include "hapticd/client.hpp"

#include <algorithm>
#include <chrono>
#include <stdexcept>
#include <thread>

#include <nlohmann/json.hpp>

#include "client/object_json.hpp"

namespace hapticd::client {

namespace {

using nlohmann::json;

}  // namespace

Batch& Batch::add(const ObjectDescription& object) {
    operations_.push_back({Operation::Kind::Add, 0, object});
    return *this;
}
Batch& Batch::modify(std::uint32_t object_id, const ObjectDescription& object) {
    operations_.push_back({Operation::Kind::Modify, object_id, object});
    return *this;
}
Batch& Batch::remove(std::uint32_t object_id) {
    operations_.push_back({Operation::Kind::Remove, object_id, std::nullopt});
    return *this;
}
Batch& Batch::clear() {
    operations_.push_back({Operation::Kind::Clear, 0, std::nullopt});
    return *this;
}

std::uint32_t Client::upload_mesh(const std::vector<Vec3>& vertices,
                                  const std::vector<std::array<std::uint32_t, 3>>& triangles, bool solid,
                                  double build_timeout_s) {
    constexpr std::size_t kVerticesPerChunk = 500, kTrianglesPerChunk = 1000;
    const json begun = json::parse(request(
        "mesh_begin",
        json{{"vertices", vertices.size()}, {"triangles", triangles.size()}, {"mode", solid ? "solid" : "surface"}}
            .dump()));
    const auto id = begun.at("mesh").get<std::uint32_t>();
    for (std::size_t at = 0; at < vertices.size(); at += kVerticesPerChunk) {
        json values = json::array();
        for (std::size_t i = at; i < std::min(vertices.size(), at + kVerticesPerChunk); ++i) {
            for (const double c : vertices[i]) values.push_back(c);
        }
        (void)request("mesh_chunk", json{{"mesh", id}, {"first", at}, {"vertices", std::move(values)}}.dump());
    }
    for (std::size_t at = 0; at < triangles.size(); at += kTrianglesPerChunk) {
        json values = json::array();
        for (std::size_t i = at; i < std::min(triangles.size(), at + kTrianglesPerChunk); ++i) {
            for (const std::uint32_t v : triangles[i]) values.push_back(v);
        }
        (void)request("mesh_chunk", json{{"mesh", id}, {"first", at}, {"triangles", std::move(values)}}.dump());
    }
    (void)request("mesh_end", json{{"mesh", id}}.dump());
    const auto until = std::chrono::steady_clock::now() + std::chrono::duration<double>(build_timeout_s);
    for (;;) {
        const json st = json::parse(request("mesh_status", json{{"mesh", id}}.dump()));
        const std::string state = st.value("state", std::string());
        if (state == "ready") return id;
        if (state == "failed") {
            throw Error(ErrorCode::BadMessage, "Client::upload_mesh: mesh " + std::to_string(id) +
                                                   " failed: " + st.value("message", std::string()));
        }
        if (std::chrono::steady_clock::now() > until) {
            throw Error(ErrorCode::Busy, "Client::upload_mesh: mesh " + std::to_string(id) + " still " + state +
                                             " after " + std::to_string(build_timeout_s) + " s");
        }
        std::this_thread::sleep_for(std::chrono::milliseconds(5));
    }
}

void Client::delete_mesh(std::uint32_t mesh) { (void)request("mesh_delete", json{{"mesh", mesh}}.dump()); }

std::uint64_t Client::heartbeat() {
    const json r = json::parse(request("heartbeat", ""));
    return r.value("tick", std::uint64_t{0});
}

CommitResult Client::commit(const Batch& batch) {
    json ops = json::array();
    for (const auto& op : batch.operations()) {
        switch (op.kind) {
            case Batch::Operation::Kind::Add:
                ops.push_back({{"op", "add"}, {"object", object_to_json(*op.object)}});
                break;
            case Batch::Operation::Kind::Modify:
                ops.push_back({{"op", "modify"}, {"object_id", op.object_id}, {"object", object_to_json(*op.object)}});
                break;
            case Batch::Operation::Kind::Remove:
                ops.push_back({{"op", "remove"}, {"object_id", op.object_id}});
                break;
            case Batch::Operation::Kind::Clear:
                ops.push_back({{"op", "clear"}});
                break;
        }
    }
    const std::string body = json{{"ops", ops}}.dump();
    json r;
    double delay = busy_retry_.initial_delay_s;
    const auto start = std::chrono::steady_clock::now();
    for (int attempt = 1;; ++attempt) {
        try {
            r = json::parse(request("commit", body));
            break;
        } catch (const Error& e) {
            if (e.code() != ErrorCode::Busy) throw;
            if (attempt >= busy_retry_.tries) {
                const double waited = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
                throw Error(ErrorCode::Busy,
                            std::string(e.what()) + " (busy after " + std::to_string(attempt) + " tries over " +
                                std::to_string(waited) + " s; ConnectOptions::busy_retry)",
                            e.op_index());
            }
            std::this_thread::sleep_for(std::chrono::duration<double>(delay));
            delay = std::min(2.0 * delay, busy_retry_.max_delay_s);
        }
    }
    CommitResult result;
    result.commit_seq = r.value("commit_seq", std::uint64_t{0});
    for (const auto& id : r.value("object_ids", json::array())) result.object_ids.push_back(id.get<std::uint32_t>());
    result.scenes_checked = r.value("scenes_checked", std::size_t{0});
    result.scenes_sampled = r.value("scenes_sampled", std::size_t{0});
    return result;
}

void Client::set_busy_retry(const BusyRetry& retry) {
    if (retry.tries < 1 || retry.tries > 1000) {
        throw std::invalid_argument("Client: busy_retry.tries = " + std::to_string(retry.tries) +
                                    " is invalid; accepted range: 1 .. 1000");
    }
    if (!(retry.initial_delay_s >= 0.0 && retry.initial_delay_s <= 10.0)) {
        throw std::invalid_argument("Client: busy_retry.initial_delay_s = " + std::to_string(retry.initial_delay_s) +
                                    " is invalid; accepted range: 0 .. 10 s");
    }
    if (!(retry.max_delay_s >= retry.initial_delay_s && retry.max_delay_s <= 10.0)) {
        throw std::invalid_argument("Client: busy_retry.max_delay_s = " + std::to_string(retry.max_delay_s) +
                                    " is invalid; accepted range: initial_delay_s .. 10 s");
    }
    busy_retry_ = retry;
}

std::vector<ObjectInfo> Client::list() {
    const json r = json::parse(request("list", ""));
    std::vector<ObjectInfo> out;
    for (const auto& o : r.value("objects", json::array())) {
        ObjectInfo info;
        info.id = o.value("id", std::uint32_t{0});
        info.owner = o.value("owner", std::uint64_t{0});
        info.kind = o.value("kind", std::string());
        info.K = o.value("K", 0.0);
        info.B = o.value("B", 0.0);
        info.description_json = o.value("object", json::object()).dump();
        out.push_back(std::move(info));
    }
    return out;
}

Status Client::status() {
    const json r = json::parse(request("status", ""));
    Status s;
    s.tick = r.value("tick", std::uint64_t{0});
    s.sessions = r.value("sessions", std::uint64_t{0});
    s.objects = r.value("objects", std::uint64_t{0});
    s.overruns = r.value("overruns", std::uint64_t{0});
    s.commits_applied = r.value("commits_applied", std::uint64_t{0});
    s.fault = r.value("fault", std::string());
    s.meshes = r.value("meshes", std::uint64_t{0});
    s.mesh_bytes = r.value("mesh_bytes", std::uint64_t{0});
    if (const auto c = r.find("commit_check"); c != r.end() && c->is_object()) {
        s.commit_check_session = c->value("session", std::uint64_t{0});
        s.commit_check_running_s = c->value("running_s", 0.0);
    }
    s.commits_waiting = r.value("commits_waiting", std::uint64_t{0});
    s.departures_waiting = r.value("departures_waiting", std::uint64_t{0});
    return s;
}

}  // namespace hapticd::client
