// SPDX-License-Identifier: Apache-2.0
// The server's messages as JSON (docs/protocol.md, sections 4 to 8): replies (ok, error, refused, welcome),
// the lease's expiry, events, the state and contact messages, and the device and scene descriptions they
// carry. Pure functions of their arguments; the bytes are made by reply_text (server/reply_text.hpp) or dump().
#pragma once

#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

#include "hapticd/client.hpp"
#include "hapticd/state_layout.hpp"
#include "server/contact_events.hpp"
#include "server/object_resolution.hpp"

namespace hapticd::server {

// {"type": "ok", "id": id}; the caller adds the request's fields.
[[nodiscard]] nlohmann::json ok_reply(std::uint64_t id);

// {"type": "error", "code", "message", "id" (null without one), "op_index" (not for bad_json; -1: the
// scene checks or not a commit), "largest_stable_K" and "damping_needed" for unstable_gains when known}.
[[nodiscard]] nlohmann::json error_reply(std::optional<std::uint64_t> id, client::ErrorCode code,
                                         const std::string& message, int op_index = -1,
                                         std::optional<double> largest_stable_K = std::nullopt,
                                         std::optional<std::pair<double, double>> damping_needed = std::nullopt);

// {"type": "refused", "code", "message"}: a connection refused before any hello (capacity).
[[nodiscard]] nlohmann::json refused_reply(client::ErrorCode code, const std::string& message);

// A refused hello: refused_reply with "server_protocol", and "client_protocol" when the client named one.
[[nodiscard]] nlohmann::json refused_hello_reply(client::ErrorCode code, const std::string& message,
                                                 std::optional<int> client_protocol = std::nullopt);

// {"type": "expired", "code": "lease_lost", "message"}.
[[nodiscard]] nlohmann::json lease_expired_message(const std::string& message);

// {"type": "event", "code": "objects_removed", "object_ids", "message"}: objects of this session ramped out
// because another session left.
[[nodiscard]] nlohmann::json objects_removed_event(const std::vector<std::uint32_t>& object_ids,
                                                   const std::string& message);

// The welcome's "device": name, axes, period_s, mass per axis (1 / (M^-1)_aa; axes beyond the device's:
// axis 0's), mass_matrix (M on the device's axes, row by row), delay_s, max_force, max_stiffness (null: none).
[[nodiscard]] nlohmann::json device_json(const ServerConfig& config, const GainChecker& checker);

// The welcome to session `session` after its hello.
[[nodiscard]] nlohmann::json welcome_reply(const ServerConfig& config, const GainChecker& checker,
                                           std::uint64_t session, double lease_s, const std::string& state_shm);

// `list`'s objects: the config walls (ids 1 .. n, owner 0, as planes) and every slot's object (ramping_out
// while it drains).
[[nodiscard]] nlohmann::json list_json(const std::vector<ConfigWallInfo>& config_walls, const SlotTable& slots);

// `status`'s reply from one state snapshot.
[[nodiscard]] nlohmann::json status_reply(std::uint64_t id, const StateLayout& snapshot, std::size_t sessions,
                                          std::size_t objects);

// A subscription's state message: the snapshot and the states this session has missed so far.
[[nodiscard]] nlohmann::json state_message(const StateLayout& snapshot, std::uint64_t dropped);

// A contact event (begin or end) of one record; the caller sets "dropped" per session.
[[nodiscard]] nlohmann::json contact_message(const ContactRecord& record);

}  // namespace hapticd::server
