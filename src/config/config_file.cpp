// SPDX-License-Identifier: Apache-2.0
#include "config/config_file.hpp"

#include <algorithm>
#include <charconv>
#include <climits>
#include <cmath>
#include <fstream>
#include <sstream>

#include <toml++/toml.h>

namespace hapticd {

namespace {

int clamp_to_int(toml::source_index v) {
    return v > static_cast<toml::source_index>(INT_MAX) ? INT_MAX : static_cast<int>(v);
}

FilePosition position_of(const toml::source_position& p) { return {clamp_to_int(p.line), clamp_to_int(p.column)}; }

bool earlier(const FilePosition& a, const FilePosition& b) {
    return a.line != b.line ? a.line < b.line : a.column < b.column;
}

// Shortest text that reads back as the same double ("-0.3", not "-0.29999999999999999"); every NaN is "nan".
std::string float_text(double v) {
    if (std::isnan(v)) return "nan";
    char buf[64];
    const auto r = std::to_chars(buf, buf + sizeof buf, v);
    return std::string(buf, r.ptr);
}

// A scalar node as hapticd reads it; nullopt for the node types hapticd does not use.
std::optional<ConfigValue> scalar_of(const toml::node& node) {
    if (const auto* s = node.as_string()) return ConfigValue{ConfigValueType::String, s->get()};
    if (const auto* i = node.as_integer()) return ConfigValue{ConfigValueType::Integer, std::to_string(i->get())};
    if (const auto* f = node.as_floating_point()) return ConfigValue{ConfigValueType::Float, float_text(f->get())};
    if (const auto* b = node.as_boolean()) return ConfigValue{ConfigValueType::Boolean, b->get() ? "true" : "false"};
    return std::nullopt;
}

std::string written_scalar(const ConfigValue& v) {
    return v.type == ConfigValueType::String ? "\"" + v.text + "\"" : v.text;
}

std::string unused_type_message(const std::string& key, const toml::node& node) {
    if (node.is_table()) {
        return "'" + key + "' is a table ([" + key + "], " + key + ".name = ... or " + key +
               " = {...}); hapticd files write every key at the top level";
    }
    if (node.is_array()) return "key '" + key + "': arrays of arrays are not used by hapticd (one level: [1, 2])";
    if (node.is_date() || node.is_time() || node.is_date_time()) {
        return "key '" + key + "': dates and times are not used by hapticd";
    }
    return "key '" + key + "': unsupported value";
}

// The line `line` (1-based) of `text` and a caret under `column`, for a syntax error.
std::string excerpt(const std::string& text, const FilePosition& at) {
    if (at.line < 1) return "";
    std::istringstream in(text);
    std::string line;
    for (int i = 0; i < at.line; ++i) {
        if (!std::getline(in, line)) return "";
    }
    if (!line.empty() && line.back() == '\r') line.pop_back();
    constexpr std::size_t kMaxShown = 160;
    if (line.size() > kMaxShown) line = line.substr(0, kMaxShown) + " ...";
    std::string caret;
    if (at.column >= 1 && static_cast<std::size_t>(at.column) <= kMaxShown + 1) {
        for (std::size_t i = 0; i + 1 < static_cast<std::size_t>(at.column) && i < line.size(); ++i) {
            caret += line[i] == '\t' ? '\t' : ' ';
        }
        caret += '^';
    }
    return "\n    " + line + (caret.empty() ? "" : "\n    " + caret);
}

}  // namespace

const char* config_value_type_name(ConfigValueType type) {
    switch (type) {
        case ConfigValueType::String:
            return "a string";
        case ConfigValueType::Integer:
            return "an integer";
        case ConfigValueType::Float:
            return "a float";
        case ConfigValueType::Boolean:
            return "a boolean";
    }
    return "a value";
}

ConfigFileContents parse_config_text(const std::string& text, const std::string& source_name) {
    ConfigFileContents out;
    toml::table table;
    try {
        table = toml::parse(std::string_view{text}, std::string_view{source_name});
    } catch (const toml::parse_error& e) {
        const FilePosition at = position_of(e.source().begin);
        out.issue = ConfigFileIssue{at, std::string(e.description()) + excerpt(text, at)};
        return out;
    }
    std::optional<ConfigFileIssue> first_issue;
    auto note_issue = [&first_issue](FilePosition at, std::string message) {
        if (!first_issue || earlier(at, first_issue->at)) first_issue = ConfigFileIssue{at, std::move(message)};
    };
    for (auto&& [toml_key, node] : table) {
        ConfigEntry entry;
        entry.key = std::string(toml_key.str());
        entry.at = position_of(toml_key.source().begin);
        if (const auto* array = node.as_array()) {
            entry.is_array = true;
            std::string written;
            for (const toml::node& element : *array) {
                const auto value = scalar_of(element);
                if (!value) {
                    note_issue(position_of(element.source().begin), unused_type_message(entry.key, element));
                    break;
                }
                written += (written.empty() ? "" : ", ") + written_scalar(*value);
                entry.values.push_back(*value);
            }
            entry.written = "[" + written + "]";
        } else if (const auto value = scalar_of(node)) {
            entry.values.push_back(*value);
            entry.written = written_scalar(*value);
        } else {
            note_issue(node.is_table() ? position_of(node.source().begin) : entry.at,
                       unused_type_message(entry.key, node));
            continue;
        }
        out.entries.push_back(std::move(entry));
    }
    if (first_issue) {
        out.entries.clear();
        out.issue = std::move(first_issue);
        return out;
    }
    std::stable_sort(out.entries.begin(), out.entries.end(),
                     [](const ConfigEntry& a, const ConfigEntry& b) { return earlier(a.at, b.at); });
    return out;
}

ConfigFileContents read_config_file(const std::string& path) {
    std::ifstream in(path, std::ios::binary);
    std::ostringstream text;
    if (in) text << in.rdbuf();
    if (!in || in.bad()) {
        ConfigFileContents out;
        out.issue = ConfigFileIssue{{0, 0}, "cannot read the file"};
        return out;
    }
    return parse_config_text(text.str(), path);
}

}  // namespace hapticd
