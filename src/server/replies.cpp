// SPDX-License-Identifier: Apache-2.0
#include "server/replies.hpp"

#include "client/object_json.hpp"
#include "server/message_decoder.hpp"

namespace hapticd::server {

namespace {

using nlohmann::json;
namespace cl = hapticd::client;

json vector_json(const double (&v)[3]) { return json::array({v[0], v[1], v[2]}); }
json vector_json(const AxisVector& v) { return json::array({v[0], v[1], v[2]}); }

}  // namespace

json ok_reply(std::uint64_t id) { return json{{"type", "ok"}, {"id", id}}; }

json error_reply(std::optional<std::uint64_t> id, cl::ErrorCode code, const std::string& message, int op_index,
                 std::optional<double> largest_stable_K, std::optional<std::pair<double, double>> damping_needed) {
    json e{{"type", "error"}, {"code", cl::to_string(code)}, {"message", message}};
    e["id"] = id ? json(*id) : json(nullptr);
    if (op_index >= -1 && code != cl::ErrorCode::BadJson) e["op_index"] = op_index;
    if (largest_stable_K) e["largest_stable_K"] = *largest_stable_K;
    if (damping_needed) e["damping_needed"] = json::array({damping_needed->first, damping_needed->second});
    return e;
}

json refused_reply(cl::ErrorCode code, const std::string& message) {
    return json{{"type", "refused"}, {"code", cl::to_string(code)}, {"message", message}};
}

json refused_hello_reply(cl::ErrorCode code, const std::string& message, std::optional<int> client_protocol) {
    json r = refused_reply(code, message);
    r["server_protocol"] = kServerProtocol;
    if (client_protocol) r["client_protocol"] = *client_protocol;
    return r;
}

json lease_expired_message(const std::string& message) {
    return json{{"type", "expired"}, {"code", cl::to_string(cl::ErrorCode::LeaseLost)}, {"message", message}};
}

json objects_removed_event(const std::vector<std::uint32_t>& object_ids, const std::string& message) {
    return json{{"type", "event"}, {"code", "objects_removed"}, {"object_ids", object_ids}, {"message", message}};
}

json device_json(const ServerConfig& config, const GainChecker& checker) {
    const DeviceMass& M = checker.mass();
    json mass = json::array(), matrix = json::array();
    for (std::size_t a = 0; a < 3; ++a) mass.push_back(M.of_axis(a < config.axes ? a : 0));
    for (std::size_t i = 0; i < config.axes; ++i) {
        json row = json::array();
        for (std::size_t j = 0; j < config.axes; ++j)
            row.push_back(M.isotropic ? (i == j ? M.matrix[0][0] : 0.0) : M.matrix[i][j]);
        matrix.push_back(row);
    }
    const std::optional<double> limit = checker.max_stiffness();
    return json{{"name", config.device_name},
                {"axes", config.axes},
                {"period_s", config.period},
                {"mass", mass},
                {"mass_matrix", matrix},
                {"delay_s", config.delay},
                {"max_force", config.max_force},
                {"max_stiffness", limit ? json(*limit) : json(nullptr)},
                {"velocity_estimator", to_string(checker.plant().velocity)},
                {"plant_set",
                 {{"mass_scale", {checker.mass_scales().first, checker.mass_scales().second}},
                  {"arm_stiffness_per_mass", checker.plant().arm_stiffness_per_mass},
                  {"arm_damping_per_mass", checker.plant().arm_damping_per_mass},
                  {"delay_s", {checker.delay_range().first, checker.delay_range().second}},
                  {"delay_exact", checker.delay_certified()},
                  {"exact", checker.certified()}}}};
}

json welcome_reply(const ServerConfig& config, const GainChecker& checker, std::uint64_t session, double lease_s,
                   const std::string& state_shm) {
    return json{{"type", "welcome"},
                {"protocol", kServerProtocol},
                {"session", session},
                {"lease_s", lease_s},
                {"max_message_bytes", cl::kMaxMessageBytes},
                {"capacity", kSceneObjectCapacity},
                {"state_shm", state_shm},
                {"ramp_s", config.ramp_time},
                {"max_force_rate", config.max_force_rate},
                {"device", device_json(config, checker)}};
}

json list_json(const std::vector<ConfigWallInfo>& config_walls, const SlotTable& slots) {
    json objects = json::array();
    std::uint32_t wall_id = 1;
    for (const auto& w : config_walls) {
        cl::Plane p;
        p.normal = {0.0, 0.0, 0.0};
        p.normal[w.axis] = -w.direction;
        p.offset = -w.direction * w.position;
        p.bilateral = w.bilateral;
        p.gains = cl::Gains::explicit_gains(w.K, w.B);
        objects.push_back({{"id", wall_id++},
                           {"owner", 0},
                           {"kind", "plane"},
                           {"K", w.K},
                           {"B", w.B},
                           {"object", cl::object_to_json(p)},
                           {"ramping_out", false}});
    }
    for (const auto& slot : slots) {
        if (slot.state == ServerSlot::State::Free || !slot.description) continue;
        objects.push_back({{"id", slot.id},
                           {"owner", slot.owner},
                           {"kind", cl::kind_name(*slot.description)},
                           {"K", slot.resolved.params.K},
                           {"B", slot.resolved.params.B},
                           {"object", cl::object_to_json(*slot.description)},
                           {"ramping_out", slot.state == ServerSlot::State::Draining}});
    }
    return objects;
}

json status_reply(std::uint64_t id, const StateLayout& snapshot, std::size_t sessions, std::size_t objects) {
    json r = ok_reply(id);
    r["tick"] = snapshot.tick;
    r["sessions"] = sessions;
    r["objects"] = objects;
    r["overruns"] = snapshot.overruns;
    r["fault"] = to_string(static_cast<StateFault>(snapshot.fault));
    r["commits_applied"] = snapshot.last_commit_seq;
    return r;
}

json state_message(const StateLayout& snapshot, std::uint64_t dropped) {
    json contact = json::array();
    for (std::uint32_t i = 0; i < 64; ++i) {
        if ((snapshot.config_contact_mask >> i) & 1U) contact.push_back(i + 1);  // config wall ids 1 .. n
    }
    for (std::size_t i = 0; i < kSceneObjectCapacity; ++i) {
        if (((snapshot.contact_mask >> i) & 1U) != 0U && snapshot.slot_object_id[i] != 0)
            contact.push_back(snapshot.slot_object_id[i]);
    }
    // The mesh proxies (section 6): the normals of the active constraints only; "triangle" null when free.
    json proxies = json::array();
    for (std::uint32_t i = 0; i < snapshot.mesh_proxies && i < kStateMeshProxyCapacity; ++i) {
        const StateMeshProxy& e = snapshot.mesh_proxy[i];
        json normals = json::array();
        for (std::uint32_t k = 0; k < e.constraints && k < 3; ++k) {
            normals.push_back({static_cast<double>(e.normal[k][0]), static_cast<double>(e.normal[k][1]),
                               static_cast<double>(e.normal[k][2])});
        }
        proxies.push_back({{"object_id", e.object_id},
                           {"slot", e.slot},
                           {"proxy", vector_json(e.proxy)},
                           {"constraints", e.constraints},
                           {"normals", normals},
                           {"triangle", e.constraints > 0 ? json(e.triangle) : json(nullptr)},
                           {"sliding", (e.flags & kMeshProxySliding) != 0U},
                           {"converged", (e.flags & kMeshProxyUnconverged) == 0U}});
    }
    return json{{"type", "state"},
                {"tick", snapshot.tick},
                {"time_s", snapshot.time_s},
                {"position", vector_json(snapshot.position)},
                {"velocity", vector_json(snapshot.velocity)},
                {"force", vector_json(snapshot.force)},
                {"contact", contact},
                {"contact_mask", snapshot.contact_mask},
                {"config_contact_mask", snapshot.config_contact_mask},
                {"overruns", snapshot.overruns},
                {"wake_latency_ns", snapshot.wake_latency_ns},
                {"last_commit_seq", snapshot.last_commit_seq},
                {"objects", snapshot.objects},
                {"mesh_slot_mask", snapshot.mesh_slot_mask},
                {"mesh_proxies", proxies},
                {"fault", to_string(static_cast<StateFault>(snapshot.fault))},
                {"dropped", dropped}};
}

json contact_message(const ContactRecord& record) {
    return json{{"type", "contact"},
                {"event", record.begin ? "begin" : "end"},
                {"object_id", record.object_id},
                {"tick", record.tick},
                {"time_s", record.time_s},
                {"position", vector_json(record.position)},
                {"force", vector_json(record.force)}};
}

}  // namespace hapticd::server
