// SPDX-License-Identifier: Apache-2.0
// libFuzzer target: hapticd's TOML reader (src/config/config_file.*, toml++ underneath), fed the input
// as text in memory (the same path as read_config_file after reading the file). Invariants: no crash and
// no exception (none is documented: any exception aborts); an issue has a message and a position inside
// the text (line in [1, lines], column >= 1) or none at all (line 0, column 0); entries only without an
// issue, each at a position inside the text, in file order, keys distinct, a scalar
// with exactly one value, and every number's text reads back exactly (integers; floats round-trip through
// from_chars, NaN as "nan"), a boolean's text is "true" or "false".
#include <charconv>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <set>
#include <string>

#include "config/config_file.hpp"

namespace {

void check(bool ok) {
    if (!ok) std::abort();
}

bool inside(const hapticd::FilePosition& at, long lines) { return at.line >= 1 && at.line <= lines && at.column >= 1; }

void check_value(const hapticd::ConfigValue& v) {
    using hapticd::ConfigValueType;
    const char* first = v.text.data();
    const char* last = first + v.text.size();
    if (v.type == ConfigValueType::Integer) {
        long long parsed = 0;
        const auto r = std::from_chars(first, last, parsed);
        check(r.ec == std::errc() && r.ptr == last && std::to_string(parsed) == v.text);
    } else if (v.type == ConfigValueType::Float) {
        if (v.text == "nan") return;
        double parsed = 0.0;
        const auto r = std::from_chars(first, last, parsed);
        check(r.ec == std::errc() && r.ptr == last && !std::isnan(parsed));
        char buf[64];
        const auto back = std::to_chars(buf, buf + sizeof buf, parsed);
        check(std::string(buf, back.ptr) == v.text);
    } else if (v.type == ConfigValueType::Boolean) {
        check(v.text == "true" || v.text == "false");
    }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    const std::string text(reinterpret_cast<const char*>(data), size);
    long lines = 1;
    for (char c : text) lines += c == '\n' ? 1 : 0;
    const hapticd::ConfigFileContents contents = hapticd::parse_config_text(text, "fuzz.toml");
    if (contents.issue) {
        const auto& issue = *contents.issue;
        check(!issue.message.empty());
        check(inside(issue.at, lines) || (issue.at.line == 0 && issue.at.column == 0));
        check(contents.entries.empty());
        return 0;
    }
    std::set<std::string> keys;
    hapticd::FilePosition previous{0, 0};
    for (const auto& entry : contents.entries) {
        check(inside(entry.at, lines));
        check(entry.at.line > previous.line || (entry.at.line == previous.line && entry.at.column > previous.column));
        previous = entry.at;
        check(keys.insert(entry.key).second);
        check(entry.is_array || entry.values.size() == 1);
        check(!entry.written.empty());
        for (const auto& v : entry.values) check_value(v);
    }
    return 0;
}
