// SPDX-License-Identifier: Apache-2.0
// The server's messages read into the client library's types (message_json.hpp).
#include "client/message_json.hpp"

#include <cstdint>
#include <optional>
#include <utility>

namespace hapticd::client {

using nlohmann::json;

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
    // The mesh proxies (section 6), absent from a daemon that publishes none.
    s.mesh_slot_mask = j.value("mesh_slot_mask", std::uint64_t{0});
    const json proxies = j.value("mesh_proxies", json::array());
    for (std::size_t i = 0; proxies.is_array() && i < proxies.size() && i < kStateMeshProxyCapacity; ++i) {
        const json& e = proxies[i];
        if (!e.is_object()) break;
        MeshProxySample& o = s.mesh_proxy[i];
        o.object_id = e.value("object_id", std::uint32_t{0});
        o.slot = e.value("slot", std::uint32_t{0});
        o.proxy = vec3(e.value("proxy", json::array()));
        const json normals = e.value("normals", json::array());
        o.constraints = 0;
        for (std::size_t k = 0; normals.is_array() && k < normals.size() && k < 3; ++k) {
            o.normals[k] = vec3(normals[k]);
            o.constraints = static_cast<int>(k + 1);
        }
        o.constraints = e.value("constraints", o.constraints);
        o.triangle = e.contains("triangle") && e["triangle"].is_number_unsigned() ? e["triangle"].get<std::uint32_t>()
                                                                                  : 0xFFFFFFFFU;
        o.sliding = e.value("sliding", false);
        o.converged = e.value("converged", true);
        s.mesh_proxies = static_cast<std::uint32_t>(i + 1);
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

}  // namespace hapticd::client
