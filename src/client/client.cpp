// SPDX-License-Identifier: Apache-2.0
// Client side of protocol version 1 (docs/protocol.md): SOCK_SEQPACKET, one JSON object per message.
#include "hapticd/client.hpp"

#include <poll.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <stdexcept>
#include <thread>

#include <nlohmann/json.hpp>

#include "client/object_json.hpp"
#include "hapticd/instance.hpp"

namespace hapticd::client {

namespace {

using nlohmann::json;

Error transport_error(const std::string& function, const std::string& what) {
    return Error(ErrorCode::Transport, function + ": " + what);
}

Error error_from_reply(const std::string& function, const json& reply) {
    const std::string code = reply.value("code", std::string(to_string(ErrorCode::Unknown)));
    const std::string message = reply.value("message", std::string("(no message)"));
    const int op_index =
        reply.contains("op_index") && reply["op_index"].is_number_integer() ? reply["op_index"].get<int>() : -1;
    std::optional<double> largest;
    if (reply.contains("largest_stable_K") && reply["largest_stable_K"].is_number()) {
        largest = reply["largest_stable_K"].get<double>();
    }
    std::optional<std::pair<double, double>> damping;
    const auto d = reply.find("damping_needed");
    if (d != reply.end() && d->is_array() && d->size() == 2 && (*d)[0].is_number() && (*d)[1].is_number()) {
        damping = std::make_pair((*d)[0].get<double>(), (*d)[1].get<double>());
    }
    return Error(error_code_from_string(code), function + ": " + code + ": " + message, op_index, largest, damping);
}

Vec3 vec3(const json& j) {
    Vec3 v{};
    if (j.is_array() && j.size() == 3) {
        for (std::size_t i = 0; i < 3; ++i) v[i] = j[i].is_number() ? j[i].get<double>() : 0.0;
    }
    return v;
}

// The welcome's device.mass_matrix: `axes` rows of `axes` numbers (docs/protocol.md, section 2). A welcome
// without it or of another shape is not protocol 1: Error(BadMessage) naming the field and the shape.
std::array<Vec3, 3> mass_matrix_from_welcome(const json& device, std::size_t axes) {
    const json m = device.value("mass_matrix", json());
    auto shape_error = [&]() {
        return Error(ErrorCode::BadMessage, "Client::connect: the welcome's device.mass_matrix = " + m.dump() +
                                                " is not " + std::to_string(axes) + " rows of " + std::to_string(axes) +
                                                " numbers (device.axes = " + std::to_string(axes) +
                                                ", accepted 1 .. 3; docs/protocol.md, section 2)");
    };
    if (axes < 1 || axes > 3 || !m.is_array() || m.size() != axes) throw shape_error();
    std::array<Vec3, 3> out{};
    for (std::size_t i = 0; i < axes; ++i) {
        if (!m[i].is_array() || m[i].size() != axes) throw shape_error();
        for (std::size_t j = 0; j < axes; ++j) {
            if (!m[i][j].is_number()) throw shape_error();
            out[i][j] = m[i][j].get<double>();
        }
    }
    return out;
}

StateSample state_from_json(const json& j) {
    StateSample s;
    s.tick = j.value("tick", std::uint64_t{0});
    s.time_s = j.value("time_s", 0.0);
    s.position = vec3(j.value("position", json::array()));
    s.velocity = vec3(j.value("velocity", json::array()));
    s.force = vec3(j.value("force", json::array()));
    s.overruns = j.value("overruns", std::uint64_t{0});
    s.wake_latency_ns = j.value("wake_latency_ns", std::int64_t{0});
    s.last_commit_seq = j.value("last_commit_seq", std::uint64_t{0});
    s.objects = j.value("objects", std::uint32_t{0});
    s.dropped = j.value("dropped", std::uint64_t{0});
    s.contact_mask = j.value("contact_mask", std::uint64_t{0});
    s.config_contact_mask = j.value("config_contact_mask", std::uint64_t{0});
    // `contact` lists the config walls in contact, then the slots' objects in slot order (docs/protocol.md,
    // section 6): the latter are the ids of contact_mask's set bits, in order.
    const json contact = j.value("contact", json::array());
    std::size_t k = static_cast<std::size_t>(__builtin_popcountll(s.config_contact_mask));
    for (std::size_t slot = 0; slot < kStateObjectCapacity && contact.is_array(); ++slot) {
        if ((s.contact_mask >> slot & 1U) == 0U) continue;
        if (k >= contact.size() || !contact[k].is_number_unsigned()) break;
        s.slot_object_id[slot] = contact[k].get<std::uint32_t>();
        ++k;
    }
    return s;
}

ContactEvent contact_from_json(const json& j) {
    ContactEvent e;
    e.kind = j.value("event", std::string()) == "begin" ? ContactEvent::Kind::Begin : ContactEvent::Kind::End;
    e.object_id = j.value("object_id", std::uint32_t{0});
    e.tick = j.value("tick", std::uint64_t{0});
    e.time_s = j.value("time_s", 0.0);
    e.position = vec3(j.value("position", json::array()));
    e.force = vec3(j.value("force", json::array()));
    e.dropped = j.value("dropped", std::uint64_t{0});
    return e;
}

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

std::string default_socket_path() {
    if (const char* s = std::getenv("HAPTICD_SOCKET"); s != nullptr && *s != '\0') return s;
    if (const char* s = std::getenv("HAPTICD_INSTANCE"); s != nullptr && *s != '\0') {
        if (!valid_instance_name(s)) {
            throw std::invalid_argument(std::string("$HAPTICD_INSTANCE = '") + s +
                                        "' is invalid; accepted: " + kInstanceNameForm);
        }
        return instance_socket_path(s);
    }
    return instance_socket_path("");
}

std::string default_socket_path(const std::string& instance) {
    if (instance.empty()) return default_socket_path();
    if (!valid_instance_name(instance)) {
        throw std::invalid_argument("instance = '" + instance + "' is invalid; accepted: " + kInstanceNameForm);
    }
    return instance_socket_path(instance);
}

Client Client::connect(const ConnectOptions& options) {
    if (!options.socket_path.empty() && !options.instance.empty()) {
        throw std::invalid_argument("ConnectOptions: socket_path = '" + options.socket_path + "' and instance = '" +
                                    options.instance + "' both given; accepted: one of them");
    }
    const std::string path = options.socket_path.empty() ? default_socket_path(options.instance) : options.socket_path;
    sockaddr_un addr{};
    addr.sun_family = AF_UNIX;
    if (path.size() >= sizeof(addr.sun_path)) {
        throw transport_error("Client::connect", "socket path '" + path + "' is longer than " +
                                                     std::to_string(sizeof(addr.sun_path) - 1) + " bytes");
    }
    std::memcpy(addr.sun_path, path.c_str(), path.size() + 1);
    int fd = -1;
    bool stream = options.transport == Transport::Stream;
    for (;;) {
        fd = ::socket(AF_UNIX, (stream ? SOCK_STREAM : SOCK_SEQPACKET) | SOCK_CLOEXEC, 0);
        if (fd < 0) throw transport_error("Client::connect", std::string("socket: ") + std::strerror(errno));
        if (::connect(fd, reinterpret_cast<const sockaddr*>(&addr), sizeof(addr)) == 0) break;
        const int e = errno;
        ::close(fd);
        if (e == EPROTOTYPE && !stream && options.transport == Transport::Auto) {
            stream = true;  // a stream socket: the daemon's .stream socket or an ssh -L forward
            continue;
        }
        throw transport_error(
            "Client::connect",
            "connect to '" + path + "': " + std::strerror(e) +
                (e == EPROTOTYPE ? " (a socket of the other type: use Transport::Auto)"
                                 : " (is hapticd running with --serve? may this user open the socket?)"));
    }
    Client c(fd, options.timeout_s);
    c.stream_ = stream;
    c.event_capacity_ = options.event_queue_capacity;
    c.contact_capacity_ = options.contact_queue_capacity;
    c.set_busy_retry(options.busy_retry);
    json hello{{"type", "hello"},
               {"protocol", options.protocol},
               {"client", options.client_name},
               {"lease_s", options.lease_s}};
    c.send_raw(hello.dump());
    const auto raw = c.receive_raw(options.timeout_s);
    if (!raw)
        throw transport_error("Client::connect",
                              "no answer to hello within " + std::to_string(options.timeout_s) + " s");
    json w = json::parse(*raw, nullptr, false);
    if (w.is_discarded() || !w.is_object())
        throw Error(ErrorCode::BadJson, "Client::connect: the server's answer is not JSON");
    if (w.value("type", std::string()) != "welcome") throw error_from_reply("Client::connect", w);
    Welcome& we = c.welcome_;
    we.protocol = w.value("protocol", 0);
    we.session = w.value("session", std::uint64_t{0});
    we.lease_s = w.value("lease_s", 0.0);
    we.max_message_bytes = w.value("max_message_bytes", std::size_t{0});
    we.capacity = w.value("capacity", std::size_t{0});
    we.state_shm = w.value("state_shm", std::string());
    we.ramp_s = w.value("ramp_s", 0.0);
    we.max_force_rate = w.value("max_force_rate", 0.0);
    const json d = w.value("device", json::object());
    we.device.name = d.value("name", std::string());
    we.device.axes = d.value("axes", std::size_t{0});
    we.device.period_s = d.value("period_s", 0.0);
    we.device.mass = vec3(d.value("mass", json::array()));
    we.device.mass_matrix = mass_matrix_from_welcome(d, we.device.axes);
    we.device.delay_s = d.value("delay_s", 0.0);
    we.device.max_force = d.value("max_force", 0.0);
    if (d.contains("max_stiffness") && d["max_stiffness"].is_number())
        we.device.max_stiffness = d["max_stiffness"].get<double>();
    we.device.velocity_estimator = d.value("velocity_estimator", std::string("backward"));
    const json set = d.value("plant_set", json::object());
    const json scale = set.value("mass_scale", json::array());
    if (scale.is_array() && scale.size() == 2 && scale[0].is_number() && scale[1].is_number()) {
        we.device.mass_scale = {scale[0].get<double>(), scale[1].get<double>()};
    }
    we.device.plant_set_exact = set.value("exact", true);
    const json arm_k = set.value("arm_stiffness_per_mass", json(0.0)),
               arm_b = set.value("arm_damping_per_mass", json(0.0));
    if (arm_k.is_number()) we.device.arm_stiffness_per_mass = arm_k.get<double>();
    if (arm_b.is_number()) we.device.arm_damping_per_mass = arm_b.get<double>();
    return c;
}

Client::Client(Client&& other) noexcept
    : fd_(other.fd_),
      timeout_s_(other.timeout_s_),
      next_id_(other.next_id_),
      welcome_(std::move(other.welcome_)),
      pending_states_(std::move(other.pending_states_)),
      events_(std::move(other.events_)),
      event_capacity_(other.event_capacity_),
      events_dropped_(other.events_dropped_),
      contacts_(std::move(other.contacts_)),
      contact_capacity_(other.contact_capacity_),
      contacts_dropped_(other.contacts_dropped_),
      busy_retry_(other.busy_retry_) {
    stream_ = other.stream_;
    rx_ = std::move(other.rx_);
    other.fd_ = -1;
}

Client& Client::operator=(Client&& other) noexcept {
    if (this != &other) {
        if (fd_ >= 0) ::close(fd_);
        fd_ = other.fd_;
        timeout_s_ = other.timeout_s_;
        next_id_ = other.next_id_;
        welcome_ = std::move(other.welcome_);
        pending_states_ = std::move(other.pending_states_);
        events_ = std::move(other.events_);
        event_capacity_ = other.event_capacity_;
        events_dropped_ = other.events_dropped_;
        contacts_ = std::move(other.contacts_);
        contact_capacity_ = other.contact_capacity_;
        contacts_dropped_ = other.contacts_dropped_;
        busy_retry_ = other.busy_retry_;
        stream_ = other.stream_;
        rx_ = std::move(other.rx_);
        other.fd_ = -1;
    }
    return *this;
}

Client::~Client() {
    if (fd_ >= 0) ::close(fd_);
}

void Client::send_raw(const std::string& message) {
    if (fd_ < 0) throw transport_error("Client::send_raw", "not connected");
    if (stream_) {  // one line: the message and '\n', sent whole (send may take part of it)
        const std::string line = message + "\n";
        std::size_t sent = 0;
        while (sent < line.size()) {
            const ssize_t n = ::send(fd_, line.data() + sent, line.size() - sent, MSG_NOSIGNAL);
            if (n < 0 && errno == EINTR) continue;
            if (n < 0) throw transport_error("Client::send_raw", std::string("send: ") + std::strerror(errno));
            sent += static_cast<std::size_t>(n);
        }
        return;
    }
    for (;;) {
        const ssize_t n = ::send(fd_, message.data(), message.size(), MSG_NOSIGNAL);
        if (n >= 0) return;
        if (errno == EINTR) continue;
        throw transport_error("Client::send_raw", std::string("send: ") + std::strerror(errno));
    }
}

std::optional<std::string> Client::receive_raw(double timeout_s) {
    if (fd_ < 0) throw transport_error("Client::receive_raw", "not connected");
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout_s);
    std::string buffer(kMaxMessageBytes + 1, '\0');
    for (;;) {
        if (stream_) {  // a complete line already received
            const std::size_t end = rx_.find('\n');
            if (end != std::string::npos) {
                std::string line = rx_.substr(0, end);
                rx_.erase(0, end + 1);
                if (!line.empty() && line.back() == '\r') line.pop_back();
                if (line.empty()) continue;
                return line;
            }
            if (rx_.size() > kMaxMessageBytes + 1) {
                throw transport_error("Client::receive_raw", "a line of more than " + std::to_string(kMaxMessageBytes) +
                                                                 " bytes from the server");
            }
        }
        const auto left =
            std::chrono::duration_cast<std::chrono::milliseconds>(deadline - std::chrono::steady_clock::now()).count();
        pollfd p{fd_, POLLIN, 0};
        const int r = ::poll(&p, 1, left > 0 ? static_cast<int>(left) : 0);
        if (r < 0 && errno == EINTR) continue;
        if (r < 0) throw transport_error("Client::receive_raw", std::string("poll: ") + std::strerror(errno));
        if (r == 0) return std::nullopt;
        const ssize_t n = ::recv(fd_, buffer.data(), buffer.size(), 0);
        if (n < 0 && errno == EINTR) continue;
        if (n < 0) throw transport_error("Client::receive_raw", std::string("recv: ") + std::strerror(errno));
        if (n == 0) throw transport_error("Client::receive_raw", "the server closed the connection");
        if (stream_) {
            rx_.append(buffer.data(), static_cast<std::size_t>(n));
            continue;
        }
        buffer.resize(static_cast<std::size_t>(n));
        return buffer;
    }
}

std::string Client::request(const std::string& type, const std::string& body_json) {
    const std::uint64_t id = next_id_++;
    json body = body_json.empty() ? json::object() : json::parse(body_json);
    body["type"] = type;
    body["id"] = id;
    send_raw(body.dump());
    const std::string function = "Client::" + type;
    for (;;) {
        const auto raw = receive_raw(timeout_s_);
        if (!raw) throw transport_error(function, "no reply within " + std::to_string(timeout_s_) + " s");
        json reply = json::parse(*raw, nullptr, false);
        if (reply.is_discarded() || !reply.is_object())
            throw Error(ErrorCode::BadJson, function + ": the reply is not JSON");
        const std::string t = reply.value("type", std::string());
        if (t == "state" || t == "event" || t == "expired" || t == "contact") {
            keep_unsolicited(*raw, function);
            continue;
        }
        if (!reply.contains("id") || !reply["id"].is_number_unsigned() || reply["id"].get<std::uint64_t>() != id) {
            if (t == "error") throw error_from_reply(function, reply);  // an error about an earlier message
            continue;
        }
        if (t == "error") throw error_from_reply(function, reply);
        return *raw;
    }
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
    return s;
}

void Client::subscribe(double rate_hz) { request("subscribe", json{{"rate_hz", rate_hz}}.dump()); }

void Client::unsubscribe() {
    request("unsubscribe", "");
    pending_states_.clear();
}

std::optional<StateSample> Client::next_state(double timeout_s) {
    if (!pending_states_.empty()) {
        const json j = json::parse(pending_states_.front());
        pending_states_.erase(pending_states_.begin());
        return state_from_json(j);
    }
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout_s);
    for (;;) {
        const double left = std::chrono::duration<double>(deadline - std::chrono::steady_clock::now()).count();
        if (left <= 0.0) return std::nullopt;
        const auto raw = receive_raw(left);
        if (!raw) return std::nullopt;
        const json j = json::parse(*raw, nullptr, false);
        if (j.is_object() && j.value("type", std::string()) == "state") return state_from_json(j);
        keep_unsolicited(*raw, "Client::next_state");
    }
}

std::optional<StateSample> Client::latest_state(double timeout_s) {
    while (const auto raw = receive_raw(0.0)) keep_unsolicited(*raw, "Client::latest_state");
    if (!pending_states_.empty()) {
        const json j = json::parse(pending_states_.back());
        pending_states_.clear();
        return state_from_json(j);
    }
    return next_state(timeout_s);
}

bool Client::keep_unsolicited(const std::string& raw, const std::string& function) {
    const json j = json::parse(raw, nullptr, false);
    if (!j.is_object()) return false;
    const std::string t = j.value("type", std::string());
    if (t == "state") {
        pending_states_.push_back(raw);
        return false;
    }
    if (t == "expired") throw error_from_reply(function, j);
    if (t == "contact") {
        if (contacts_.size() >= contact_capacity_) {
            ++contacts_dropped_;
        } else {
            contacts_.push_back(contact_from_json(j));
        }
        return false;
    }
    if (t != "event") return false;
    if (events_.size() >= event_capacity_) {
        ++events_dropped_;
        return true;
    }
    Event e;
    e.code = j.value("code", std::string());
    e.message = j.value("message", std::string());
    if (const auto ids = j.find("object_ids"); ids != j.end() && ids->is_array()) {
        for (const auto& id : *ids) {
            if (id.is_number_unsigned() && id.get<std::uint64_t>() <= 0xffffffffULL)
                e.object_ids.push_back(id.get<std::uint32_t>());
        }
    }
    e.json = raw;
    events_.push_back(std::move(e));
    return true;
}

std::optional<Event> Client::poll_event() {
    while (events_.empty()) {
        const auto raw = receive_raw(0.0);
        if (!raw) break;
        keep_unsolicited(*raw, "Client::poll_event");
    }
    if (events_.empty()) return std::nullopt;
    Event e = std::move(events_.front());
    events_.pop_front();
    return e;
}

std::optional<Event> Client::next_event(double timeout_s) {
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout_s);
    for (;;) {
        if (auto e = poll_event()) return e;
        const double left = std::chrono::duration<double>(deadline - std::chrono::steady_clock::now()).count();
        if (left <= 0.0) return std::nullopt;
        const auto raw = receive_raw(left);
        if (!raw) return std::nullopt;
        keep_unsolicited(*raw, "Client::next_event");
    }
}

std::vector<std::uint32_t> Client::subscribe_contacts(const std::vector<std::uint32_t>& object_ids) {
    json body = json::object();
    if (!object_ids.empty()) body["object_ids"] = object_ids;
    const json r = json::parse(request("subscribe_contacts", body.dump()));
    contacts_.clear();  // the reply's contacts are where the events that follow continue from
    std::vector<std::uint32_t> in_contact;
    for (const auto& id : r.value("contacts", json::array())) {
        if (id.is_number_unsigned() && id.get<std::uint64_t>() <= 0xffffffffULL)
            in_contact.push_back(id.get<std::uint32_t>());
    }
    return in_contact;
}

void Client::unsubscribe_contacts() {
    request("unsubscribe_contacts", "");
    contacts_.clear();
}

std::optional<ContactEvent> Client::poll_contact() {
    while (contacts_.empty()) {
        const auto raw = receive_raw(0.0);
        if (!raw) break;
        keep_unsolicited(*raw, "Client::poll_contact");
    }
    if (contacts_.empty()) return std::nullopt;
    ContactEvent e = contacts_.front();
    contacts_.pop_front();
    return e;
}

std::optional<ContactEvent> Client::next_contact(double timeout_s) {
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout_s);
    for (;;) {
        if (auto e = poll_contact()) return e;
        const double left = std::chrono::duration<double>(deadline - std::chrono::steady_clock::now()).count();
        if (left <= 0.0) return std::nullopt;
        const auto raw = receive_raw(left);
        if (!raw) return std::nullopt;
        keep_unsolicited(*raw, "Client::next_contact");
    }
}

void Client::bye() {
    try {
        request("bye", "");
    } catch (const Error& e) {
        if (e.code() != ErrorCode::Transport) throw;  // the server may close before we read the reply
    }
    ::close(fd_);
    fd_ = -1;
}

}  // namespace hapticd::client
