// SPDX-License-Identifier: Apache-2.0
// The scene-object descriptions of include/hapticd/client.hpp to and from the protocol's JSON
// (docs/protocol.md, section 4). Shared by the client library and the server's decoder: the decoder checks
// structure and types (every field named in the error with its accepted form); the server checks the
// physics (unit normals, stability, device limits) afterwards.
#pragma once

#include <optional>
#include <string>

#include <nlohmann/json.hpp>

#include "hapticd/client.hpp"

namespace hapticd::client {

nlohmann::json object_to_json(const ObjectDescription& object);

// std::nullopt and `error` set ("object.normal: expected an array of 3 finite numbers", ...) on failure.
std::optional<ObjectDescription> object_from_json(const nlohmann::json& j, std::string& error);

const char* kind_name(const ObjectDescription& object) noexcept;

}  // namespace hapticd::client
