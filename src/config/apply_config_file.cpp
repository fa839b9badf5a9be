// SPDX-License-Identifier: Apache-2.0
#include "config/apply_config_file.hpp"

#include <CLI/CLI.hpp>

#include "config/config_file.hpp"
#include "config/options.hpp"

namespace hapticd {

namespace {

// What an option takes, from CLI11's type name of it ("FLOAT", "INT", "TEXT:{CE0,...}", "BOOLEAN") or
// from its being a flag. Anything else (a type name set by hand) is left to the option's own conversion.
enum class Takes { Number, Integer, String, Boolean, AsText };

Takes takes_of(const CLI::Option& option) {
    if (option.get_expected_min() == 0) return Takes::Boolean;  // a flag: true or false in a file
    const std::string type = option.get_type_name();
    const std::string base = type.substr(0, type.find(':'));
    if (base == "FLOAT") return Takes::Number;
    if (base == "INT" || base == "UINT") return Takes::Integer;
    if (base == "TEXT") return Takes::String;
    if (base == "BOOLEAN") return Takes::Boolean;
    return Takes::AsText;
}

bool accepts(Takes takes, ConfigValueType type) {
    switch (takes) {
        case Takes::Number:
            return type == ConfigValueType::Integer || type == ConfigValueType::Float;
        case Takes::Integer:
            return type == ConfigValueType::Integer;
        case Takes::String:
            return type == ConfigValueType::String;
        case Takes::Boolean:
            return type == ConfigValueType::Boolean;
        case Takes::AsText:
            return true;
    }
    return false;
}

std::string accepted_text(Takes takes, bool many) {
    const char* one = "a value";
    const char* several = "values";
    switch (takes) {
        case Takes::Number:
            one = "a number";
            several = "numbers";
            break;
        case Takes::Integer:
            one = "an integer";
            several = "integers";
            break;
        case Takes::String:
            one = "a string in quotes";
            several = "strings";
            break;
        case Takes::Boolean:
            one = "true or false";
            several = "true/false";
            break;
        case Takes::AsText:
            break;
    }
    return many ? std::string("an array of ") + several + " ([a, b, ...]) or " + one : std::string(one);
}

void apply_entry(CLI::App& app, const ConfigEntry& entry, const std::string& at) {
    CLI::Option* option = app.get_option_no_throw("--" + entry.key);
    if (option == nullptr) throw StartupError(ErrorKind::BadConfig, at + "unknown key '" + entry.key + "'");
    const Takes takes = takes_of(*option);
    const bool many = option->get_items_expected_max() > 1;
    const std::string assignment = entry.key + " = " + entry.written;
    if (entry.is_array && !many) {
        throw StartupError(ErrorKind::BadConfig,
                           at + assignment + " is an array; accepted: " + accepted_text(takes, false));
    }
    if (entry.values.empty() && entry.key == "wall") {  // wall = []: the scene starts empty (clients fill it)
        CLI::Option* no_walls = app.get_option("--no-walls");
        no_walls->add_result(std::string("true"));
        no_walls->run_callback();
        return;
    }
    if (entry.values.empty()) {
        throw StartupError(ErrorKind::BadConfig,
                           at + assignment + " is empty; accepted: " + accepted_text(takes, many));
    }
    for (const ConfigValue& value : entry.values) {
        if (!accepts(takes, value.type)) {
            throw StartupError(ErrorKind::BadConfig, at + assignment + " has the wrong type (" +
                                                         config_value_type_name(value.type) +
                                                         "); accepted: " + accepted_text(takes, many));
        }
    }
    try {
        if (option->get_expected_min() == 0) {  // a flag, read as CLI11 reads a flag of its own config files
            option->add_result(option->get_flag_value(entry.key, entry.values.front().text));
        } else {
            std::vector<std::string> inputs;
            for (const ConfigValue& value : entry.values) inputs.push_back(value.text);
            option->add_result(inputs);
        }
        option->run_callback();  // conversion, the option's checks (e.g. IsMember), the store
    } catch (const CLI::Error& e) {
        throw StartupError(ErrorKind::BadConfig, at + assignment + ": " + e.what());
    }
}

}  // namespace

KeyLocations apply_config_file(CLI::App& app, const std::string& file, const std::string& path, bool name_file_always) {
    const ConfigFileContents contents = read_config_file(path);
    if (contents.issue) {
        const ConfigFileIssue& issue = *contents.issue;
        if (issue.at.line == 0) throw StartupError(ErrorKind::BadConfig, file + ": " + issue.message);
        throw StartupError(ErrorKind::BadConfig, file + " is malformed: line " + std::to_string(issue.at.line) +
                                                     ", column " + std::to_string(issue.at.column) + ": " +
                                                     issue.message);
    }
    KeyLocations locations(file, name_file_always);
    for (const ConfigEntry& entry : contents.entries) locations.add(entry.key, entry.at);
    for (const ConfigEntry& entry : contents.entries) apply_entry(app, entry, locations.prefix(entry.key));
    return locations;
}

}  // namespace hapticd
