// SPDX-License-Identifier: Apache-2.0
#include "node_access.hpp"

#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <filesystem>

namespace hapticd::test {

namespace fs = std::filesystem;

NodeAccess::NodeAccess(const std::string& testbed_root, const std::string& device_path)
    : node_(testbed_root + device_path) {
    struct stat st {};
    if (testbed_root.empty() || ::stat(node_.c_str(), &st) != 0) {  // stat follows the hidraw symlink to its pty
        error_ = "NodeAccess: no node " + node_ + ": " + std::strerror(errno);
        return;
    }
    saved_mode_ = st.st_mode & 07777;
    drop_ = ::geteuid() == 0;
    if (drop_) {
        as_ = unprivileged_user();
        std::error_code ec;
        constexpr fs::perms kDir = fs::perms::others_read | fs::perms::others_exec;
        constexpr fs::perms kSocket = fs::perms::others_read | fs::perms::others_write;
        // The root also o+w, with the sticky bit as /tmp: the preload library binds a netlink stand-in socket
        // <root>/event<fd> for a udev monitor (libusb_init() starts one), and fails it without write access.
        fs::permissions(testbed_root, kDir | fs::perms::others_write | fs::perms::sticky_bit, fs::perm_options::add,
                        ec);
        for (auto it = fs::recursive_directory_iterator(testbed_root, ec);
             !ec && it != fs::recursive_directory_iterator(); it.increment(ec)) {
            const fs::file_status s = it->symlink_status(ec);  // symlinks (sysfs has many) are left alone
            if (!ec && fs::is_directory(s)) fs::permissions(it->path(), kDir, fs::perm_options::add, ec);
            if (!ec && fs::is_socket(s)) fs::permissions(it->path(), kSocket, fs::perm_options::add, ec);
            if (ec) break;
        }
        if (ec) {
            error_ = "NodeAccess: cannot open the testbed " + testbed_root + " to uid " + std::to_string(as_.uid) +
                     ": " + ec.message();
            return;
        }
    }
    ok_ = true;
}

NodeAccess::~NodeAccess() {
    if (ok_) ::chmod(node_.c_str(), saved_mode_);
}

bool NodeAccess::set_mode(mode_t mode) {
    if (!ok_) return false;
    if (::chmod(node_.c_str(), mode) != 0) {
        error_ = "NodeAccess: chmod " + node_ + ": " + std::strerror(errno);
        return false;
    }
    return true;
}

}  // namespace hapticd::test
