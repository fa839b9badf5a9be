// SPDX-License-Identifier: Apache-2.0
#include "config/config_locations.hpp"

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <system_error>

#include "hapticd/instance.hpp"

// Set by src/CMakeLists.txt from GNUInstallDirs, relative so that the same binary works under any prefix.
#if !defined(HAPTICD_BINDIR_TO_DATA_DIR) || !defined(HAPTICD_BINDIR_TO_PREFIX) || !defined(HAPTICD_SYSCONFDIR)
#error "HAPTICD_BINDIR_TO_DATA_DIR, HAPTICD_BINDIR_TO_PREFIX and HAPTICD_SYSCONFDIR must be defined"
#endif

namespace hapticd {

namespace fs = std::filesystem;

namespace {

constexpr const char* kBuildTreeMarker = "hapticd-build-tree.txt";
constexpr const char* kUnknownDataDir = "<unknown data dir: /proc/self/exe unreadable>";

bool directory_exists(const fs::path& p) {
    std::error_code ec;
    return fs::is_directory(p, ec);
}

// The repository's config/ named by the first line of the nearest hapticd-build-tree.txt in `exe_dir` or one of
// its ancestors; "" when there is none.
std::string build_tree_config_dir(const fs::path& exe_dir) {
    for (fs::path dir = exe_dir;; dir = dir.parent_path()) {
        std::error_code ec;
        const fs::path marker = dir / kBuildTreeMarker;
        if (fs::is_regular_file(marker, ec)) {
            std::ifstream in(marker);
            std::string line;
            std::getline(in, line);
            return line;
        }
        if (dir == dir.root_path() || dir.empty()) return "";
    }
}

std::string system_dir_for_prefix(const fs::path& prefix) {
    const fs::path sysconfdir{HAPTICD_SYSCONFDIR};
    if (sysconfdir.is_absolute()) return (sysconfdir / "hapticd").string();
    if (prefix == "/usr") return "/etc/hapticd";  // GNUInstallDirs: the /usr prefix keeps its config in /etc
    return (prefix / sysconfdir / "hapticd").string();
}

ConfigDirectories locate() {
    ConfigDirectories dirs;
    std::error_code ec;
    const fs::path exe = fs::read_symlink("/proc/self/exe", ec);
    if (ec || exe.empty()) {
        dirs.data = kUnknownDataDir;
        return dirs;
    }
    const fs::path exe_dir = exe.parent_path();
    const fs::path installed_data = (exe_dir / HAPTICD_BINDIR_TO_DATA_DIR).lexically_normal();
    if (!directory_exists(installed_data)) {
        const std::string repo_config = build_tree_config_dir(exe_dir);
        if (!repo_config.empty()) {
            dirs.data = repo_config;
            dirs.build_tree = true;
            return dirs;
        }
    }
    dirs.data = installed_data.string();
    fs::path prefix = (exe_dir / HAPTICD_BINDIR_TO_PREFIX).lexically_normal();
    if (!prefix.has_filename() && prefix != prefix.root_path()) prefix = prefix.parent_path();  // "/usr/" -> "/usr"
    dirs.system = system_dir_for_prefix(prefix);
    return dirs;
}

}  // namespace

const ConfigDirectories& config_directories() {
    static const ConfigDirectories dirs = locate();
    return dirs;
}

std::vector<std::string> config_search_dirs() {
    const ConfigDirectories& d = config_directories();
    std::vector<std::string> out;
    if (!d.system.empty()) out.push_back(d.system);
    out.push_back(d.data);
    return out;
}

std::string default_config_file(bool& from_environment, const std::string& instance) {
    const char* env = std::getenv("HAPTICD_CONFIG");
    from_environment = env != nullptr && *env != '\0';
    if (from_environment) return env;
    return find_config_file(config_search_dirs(), instance);
}

std::string find_config_file(const std::vector<std::string>& dirs, const std::string& instance) {
    std::vector<std::string> names;
    if (!instance.empty()) names.push_back(instance_config_file(instance));
    names.push_back(instance_config_file(""));
    for (const auto& name : names) {
        for (const auto& dir : dirs) {
            const fs::path candidate = fs::path(dir) / name;
            std::error_code ec;
            if (fs::exists(candidate, ec)) return candidate.string();
        }
    }
    return "";
}

std::string config_search_help() {
    const ConfigDirectories& d = config_directories();
    std::string s = "Config file, first match: --config FILE (\"\": none); $HAPTICD_CONFIG; ";
    s += "with --instance NAME: NAME.toml in";
    for (const auto& dir : config_search_dirs()) s += " " + dir;
    s += "; ";
    if (!d.system.empty()) s += d.system + "/hapticd.toml; ";
    s += d.data + "/hapticd.toml";
    s += d.build_tree ? " (the repository's, found through the build tree's hapticd-build-tree.txt)" : "";
    s += "; else the built-in defaults.\nDevice profiles by name: devices/NAME.toml next to the config file, then";
    for (const auto& dir : config_search_dirs()) s += " " + dir + "/devices";
    s += ".";
    return s;
}

}  // namespace hapticd
