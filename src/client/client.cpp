// SPDX-License-Identifier: Apache-2.0
// Client side of protocol version 1 (docs/protocol.md): SOCK_SEQPACKET, one JSON object per message.
// Here: the socket path, connect and the handshake, sending and receiving (both transports), one request
// and its reply, bye; the requests in client_requests.cpp, the subscriptions in client_subscriptions.cpp, the
// server's messages read in message_json.cpp.
#include "hapticd/client.hpp"

#include <poll.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <cstdlib>
#include <cstring>
#include <stdexcept>

#include <nlohmann/json.hpp>

#include "client/message_json.hpp"
#include "hapticd/instance.hpp"

namespace hapticd::client {

namespace {

using nlohmann::json;

Error transport_error(const std::string& function, const std::string& what) {
    return Error(ErrorCode::Transport, function + ": " + what);
}

}  // namespace

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