// SPDX-License-Identifier: Apache-2.0
// The bytes of one server message (docs/protocol.md, section 8): a reply never exceeds the protocol's
// 65536 bytes, never carries invalid UTF-8 and its encoding never throws.
#pragma once

#include <cstddef>
#include <string>

#include <nlohmann/json.hpp>

namespace hapticd::server {

// Error messages are cut to this many bytes (at a UTF-8 character boundary) before they are sent; with
// JSON escaping (at most 6 bytes per byte) a reply stays far below the 65536-byte limit.
inline constexpr std::size_t kMaxErrorMessageBytes = 2048;

// message.dump() with invalid UTF-8 replaced by U+FFFD; a "message" field cut to kMaxErrorMessageBytes; a
// reply still above client::kMaxMessageBytes (or one that cannot be encoded at all) becomes an `internal`
// error reply carrying the same id. Never throws (std::bad_alloc included: a fixed text is returned).
std::string reply_text(nlohmann::json message) noexcept;

}  // namespace hapticd::server
