// SPDX-License-Identifier: Apache-2.0
#pragma once
// Where hapticd finds hapticd.toml and the device profiles devices/<name>.toml when the command line does not
// name them. The search order, first match wins (docs/hapticd.md, "Where the config comes from"):
//   1. --config FILE
//   2. $HAPTICD_CONFIG, a file, with the same meaning as --config (unset or empty: skipped)
//   3. with --instance NAME: <system dir>/NAME.toml, then <data dir>/NAME.toml (include/hapticd/instance.hpp)
//   4. <system dir>/hapticd.toml, the administrator's: <sysconfdir>/hapticd, /etc/hapticd for the /usr prefix
//   5. <data dir>/hapticd.toml, what the installation ships: <datadir>/hapticd, /usr/share/hapticd for /usr
// and without any of them the built-in defaults. Device profiles by name: devices/<name>.toml next to the config
// file in use, then in the system dir, then in the data dir.
//
// Both directories are found from the running executable (/proc/self/exe), so one binary works under any
// install prefix: <exe dir>/<BINDIR to DATADIR>/hapticd is the data dir; the system dir is /etc/hapticd when
// the prefix is /usr, else <prefix>/<SYSCONFDIR>/hapticd (the GNUInstallDirs rule), or SYSCONFDIR/hapticd when
// SYSCONFDIR was configured absolute. A build-tree executable (no installed data dir beside it, and the
// executable's directory or one of its ancestors holds hapticd-build-tree.txt, which CMake writes at the top
// of the build tree) reads the repository's config/ named in that file as its data dir and has no system dir,
// so an installed /etc/hapticd never changes what the build tree's tests see.

#include <string>
#include <vector>

namespace hapticd {

struct ConfigDirectories {
    std::string system;       // the administrator's directory ("" in a build tree)
    std::string data;         // the shipped directory, or the repository's config/ in a build tree
    bool build_tree = false;  // found through hapticd-build-tree.txt
};

// Computed once per process. When the executable cannot be located, data is "<unknown data dir>" (a path that
// does not exist, so the error message that follows names it).
const ConfigDirectories& config_directories();

// The directories searched for hapticd.toml and devices/, most important first (empty entries left out).
std::vector<std::string> config_search_dirs();

// The config file selected by steps 2-5 above, given that --config was not: $HAPTICD_CONFIG when set and not
// empty (whether or not it exists: the caller reports a missing one), else the first existing NAME.toml of
// config_search_dirs() for an `instance` NAME (a valid name: instance.hpp), else the first existing hapticd.toml,
// else "" (built-in defaults). `from_environment` tells which case it was.
std::string default_config_file(bool& from_environment, const std::string& instance = "");

// The first existing <dir>/NAME.toml of `dirs` for an `instance` NAME, else the first existing <dir>/hapticd.toml,
// else "" (steps 3-5 above over the directories given).
std::string find_config_file(const std::vector<std::string>& dirs, const std::string& instance);

// One line per step of the search, for --help.
std::string config_search_help();

}  // namespace hapticd
