// SPDX-License-Identifier: Apache-2.0
// Reads hapticd's TOML files (the config file and the device profiles) with toml++ (Debian's
// libtomlplusplus-dev, TOML v1.0.0: multi-line arrays, 1_000.0, triple-quoted strings, hex integers...).
// hapticd's files are flat: every key at the top level, each value a string, an integer, a float, a
// boolean or an array of those. A syntax error, a table ([section], a.b = ..., {inline}), a date/time or a
// nested array is an issue with its line and column; duplicate keys are syntax errors of TOML itself.
// What the keys mean, their types and ranges are the readers' (config/apply_config_file.hpp, options.cpp).
#pragma once

#include <optional>
#include <string>
#include <vector>

namespace hapticd {

struct FilePosition {
    int line = 0;    // 1-based; 0: the file as a whole (could not be read)
    int column = 0;  // 1-based; 0 with line 0
};

enum class ConfigValueType { String, Integer, Float, Boolean };

struct ConfigValue {
    ConfigValueType type = ConfigValueType::String;
    std::string text;  // as the option parser reads it: the string itself, "1000", "-0.3", "inf", "true"
};

// One `key = value` of the file.
struct ConfigEntry {
    std::string key;
    FilePosition at;  // where the key is written
    bool is_array = false;
    std::vector<ConfigValue> values;  // one for a scalar; the elements of an array (possibly none)
    std::string written;              // the value for messages: "\"fast\"", "1.5", "[0.22, 0.3]"
};

struct ConfigFileIssue {
    FilePosition at;
    std::string message;  // what is wrong; for a syntax error followed by the line and a caret under the column
};

struct ConfigFileContents {
    std::vector<ConfigEntry> entries;      // in the order they are written
    std::optional<ConfigFileIssue> issue;  // set: the file is unusable (entries then empty)
};

// Reads and parses `path`. Never throws (except std::bad_alloc).
[[nodiscard]] ConfigFileContents read_config_file(const std::string& path);

// The same for text already in memory; `source_name` is what messages call it.
[[nodiscard]] ConfigFileContents parse_config_text(const std::string& text, const std::string& source_name);

[[nodiscard]] const char* config_value_type_name(ConfigValueType type);

}  // namespace hapticd
