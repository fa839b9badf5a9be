// SPDX-License-Identifier: Apache-2.0
// Applies a hapticd TOML file (read by config/config_file.hpp) to the CLI11 options that define its
// keys: the options are the single list of keys (a key is a long option name without "--"), so an option
// added to the command line is a key of the file with the same type. Per key: unknown keys, wrong types
// (a string for a number, a float for an integer, 1 for true, an array for one value) and values the
// option rejects are errors naming file, line, column, key, value and what is accepted.
#pragma once

#include <string>

#include "config/key_locations.hpp"

namespace CLI {
class App;
}

namespace hapticd {

// Reads `path` and gives each entry to app's option "--<key>" as if on the command line. `file` is what
// messages call the file ("config file 'P'"). Returns where each key is written (for later range errors).
// Throws StartupError(ErrorKind::BadConfig) on a syntax error, an unknown key, a wrong type or a rejected value.
KeyLocations apply_config_file(CLI::App& app, const std::string& file, const std::string& path, bool name_file_always);

}  // namespace hapticd
