// SPDX-License-Identifier: Apache-2.0
// Bounded, printable copies of client-supplied text for error replies and log lines (docs/protocol.md,
// section 8): a cut never splits a UTF-8 character, and a log line never carries a client's control bytes.
#pragma once

#include <cstddef>
#include <string>
#include <string_view>

namespace hapticd::client {

// `text` cut to at most `max_bytes` bytes at a UTF-8 character boundary, with "..." appended when cut
// (the result is at most max_bytes + 3 bytes). A cut of valid UTF-8 stays valid UTF-8.
[[nodiscard]] std::string truncate_utf8(std::string_view text, std::size_t max_bytes);

// `text` with every byte below 0x20, 0x7f and the backslash written as \xNN (\x5c for '\'), cut like
// truncate_utf8 to max_bytes of the input first: one line, no terminal escape sequences, nothing forged.
[[nodiscard]] std::string escape_for_log(std::string_view text, std::size_t max_bytes = 128);

}  // namespace hapticd::client
