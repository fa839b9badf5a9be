// SPDX-License-Identifier: Apache-2.0
// The server's messages read into the client library's types (docs/protocol.md): an error or refusal as
// Error, the welcome's mass matrix, a state message, a contact event.
#pragma once

#include <array>
#include <cstddef>
#include <string>

#include <nlohmann/json.hpp>

#include "hapticd/client.hpp"

namespace hapticd::client {

// The Error of an error, refused or expired message: its code, message, op_index, largest_stable_K and
// damping_needed, the message prefixed with `function`.
Error error_from_reply(const std::string& function, const nlohmann::json& reply);

// An array of 3 numbers; zeros where it is not one (a non-number entry: 0).
Vec3 vec3(const nlohmann::json& j);

// The welcome's device.mass_matrix: `axes` rows of `axes` numbers (docs/protocol.md, section 2). A welcome
// without it or of another shape is not protocol 1: Error(BadMessage) naming the field and the shape.
std::array<Vec3, 3> mass_matrix_from_welcome(const nlohmann::json& device, std::size_t axes);

// A state message (docs/protocol.md, section 6); absent fields 0.
StateSample state_from_json(const nlohmann::json& j);

// A contact message (docs/protocol.md, section 6, "Contact events"): Begin for event "begin", else End;
// absent fields 0.
ContactEvent contact_from_json(const nlohmann::json& j);

}  // namespace hapticd::client
