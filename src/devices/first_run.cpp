// SPDX-License-Identifier: Apache-2.0
#include "devices/first_run.hpp"

#include <cctype>
#include <cstdlib>
#include <fstream>
#include <system_error>

namespace hapticd {

std::filesystem::path hapticd_state_directory() {
    if (const char* d = std::getenv("HAPTICD_STATE_DIR"); d != nullptr && *d != '\0') return d;
    if (const char* x = std::getenv("XDG_STATE_HOME"); x != nullptr && *x != '\0')
        return std::filesystem::path(x) / "hapticd";
    if (const char* h = std::getenv("HOME"); h != nullptr && *h != '\0')
        return std::filesystem::path(h) / ".local/state/hapticd";
    return std::filesystem::path("/var/lib/hapticd");
}

std::filesystem::path force_sign_confirmation_file(const std::string& profile_name) {
    std::string safe;
    for (char c : profile_name)
        safe += (std::isalnum(static_cast<unsigned char>(c)) != 0 || c == '-' || c == '_') ? c : '_';
    return hapticd_state_directory() / ("force-sign-confirmed-" + safe);
}

bool force_sign_confirmed(const std::string& profile_name) {
    std::error_code ec;
    return std::filesystem::is_regular_file(force_sign_confirmation_file(profile_name), ec);
}

bool record_force_sign_confirmed(const std::string& profile_name, const std::string& details, std::string& error) {
    const std::filesystem::path file = force_sign_confirmation_file(profile_name);
    std::error_code ec;
    std::filesystem::create_directories(file.parent_path(), ec);
    std::ofstream out(file);
    out << details << "\n";
    if (!out) {
        error =
            "record_force_sign_confirmed: cannot write " + file.string() + (ec ? ": " + ec.message() : std::string());
        return false;
    }
    return true;
}

}  // namespace hapticd
