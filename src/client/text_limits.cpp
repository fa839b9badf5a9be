// SPDX-License-Identifier: Apache-2.0
#include "client/text_limits.hpp"

namespace hapticd::client {

std::string truncate_utf8(std::string_view text, std::size_t max_bytes) {
    if (text.size() <= max_bytes) return std::string(text);
    std::size_t cut = max_bytes;
    // Step back over continuation bytes (10xxxxxx) so the cut lands before a lead byte.
    while (cut > 0 && (static_cast<unsigned char>(text[cut]) & 0xC0U) == 0x80U) --cut;
    return std::string(text.substr(0, cut)) + "...";
}

std::string escape_for_log(std::string_view text, std::size_t max_bytes) {
    const std::string cut = truncate_utf8(text, max_bytes);
    static constexpr char kHex[] = "0123456789abcdef";
    std::string out;
    out.reserve(cut.size());
    for (const char ch : cut) {
        const auto c = static_cast<unsigned char>(ch);
        if (c < 0x20U || c == 0x7fU || c == '\\') {
            out += "\\x";
            out += kHex[c >> 4U];
            out += kHex[c & 0xFU];
        } else {
            out += ch;
        }
    }
    return out;
}

}  // namespace hapticd::client
