// SPDX-License-Identifier: Apache-2.0
// hapticd instances: several daemons on one machine, one per device, told apart by a name (docs/hapticd.md,
// "Instances"). An instance NAME has its own control socket hapticd-NAME.sock, state segment /hapticd-NAME-state
// and config file NAME.toml; no name (the default instance) keeps hapticd.sock, /hapticd-state and hapticd.toml.
// The daemon (src/config), the C++ client and hapticctl derive the names here, the Python client
// (hapticd_client.instance) the same way.
#pragma once

#include <cstdlib>
#include <initializer_list>
#include <string>

namespace hapticd {

// The accepted form of an instance name, for error messages.
inline constexpr const char* kInstanceNameForm =
    "1 to 32 characters of a-z, 0-9, '_' and '-', starting with a letter or a digit (e.g. left)";

// NAME matches [a-z0-9][a-z0-9_-]{0,31}: safe in a file name, a shared-memory name and a systemd instance (%i)
// without escaping.
[[nodiscard]] inline bool valid_instance_name(const std::string& name) noexcept {
    if (name.empty() || name.size() > 32) return false;
    for (std::size_t i = 0; i < name.size(); ++i) {
        const char c = name[i];
        const bool alnum = (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9');
        if (!alnum && (i == 0 || (c != '_' && c != '-'))) return false;
    }
    return true;
}

// "hapticd.sock" for the default instance (""), else "hapticd-NAME.sock".
[[nodiscard]] inline std::string instance_socket_file(const std::string& instance) {
    return instance.empty() ? std::string("hapticd.sock") : "hapticd-" + instance + ".sock";
}

// "/hapticd-state" for the default instance, else "/hapticd-NAME-state".
[[nodiscard]] inline std::string instance_state_shm(const std::string& instance) {
    return instance.empty() ? std::string("/hapticd-state") : "/hapticd-" + instance + "-state";
}

// "hapticd.toml" for the default instance, else "NAME.toml".
[[nodiscard]] inline std::string instance_config_file(const std::string& instance) {
    return instance.empty() ? std::string("hapticd.toml") : instance + ".toml";
}

// The directory of the control sockets: $RUNTIME_DIRECTORY (systemd's RuntimeDirectory=), else $XDG_RUNTIME_DIR,
// else /run/hapticd (unset or empty variables are skipped).
[[nodiscard]] inline std::string runtime_socket_directory() {
    for (const char* var : {"RUNTIME_DIRECTORY", "XDG_RUNTIME_DIR"}) {
        if (const char* s = std::getenv(var); s != nullptr && *s != '\0') return s;
    }
    return "/run/hapticd";
}

// The control socket of an instance in runtime_socket_directory().
[[nodiscard]] inline std::string instance_socket_path(const std::string& instance) {
    return runtime_socket_directory() + "/" + instance_socket_file(instance);
}

}  // namespace hapticd
