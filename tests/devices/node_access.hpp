// SPDX-License-Identifier: Apache-2.0
// Sets who may open an emulated device node (in a umockdev testbed), so that the REAL open() in a child
// process fails with EACCES as on a machine without hapticd's udev rule, or succeeds as with it.
//
// File modes do not bind root (CAP_DAC_OVERRIDE), and the tests run as root in CI. So:
// - as root: the child runs as an unprivileged user (child_credentials(): "nobody"), which has no
//   capabilities after setresuid. That user must still reach the rest of the testbed: every directory
//   gets o+rx, umockdev's mkdtemp() root (0700) 1777 as /tmp (the preload library creates the socket
//   that stands in for a udev monitor's netlink socket there), and the ioctl sockets o+rw, because the
//   preload library connects to a socket on every /dev open (a failed one too) and exits the process
//   when that connect fails; the sysfs files are created 0644 and stay so;
// - not root (a developer's machine): mode 000 refuses the owner as well, so child_credentials() is null
//   and the child runs as the test's user.
// refuse() gives the node mode 000, grant() 0666 (what the udev rule's 0660 + plugdev gives the user).
// The node is umockdev's file for a usbfs node, or the pty that its hidraw symlink points to (chmod
// follows the symlink). The destructor restores the node's mode.
#pragma once

#include <string>
#include <sys/types.h>

#include "common/run_child.hpp"

namespace hapticd::test {

class NodeAccess {
  public:
    NodeAccess(const std::string& testbed_root, const std::string& device_path);
    ~NodeAccess();
    NodeAccess(const NodeAccess&) = delete;
    NodeAccess& operator=(const NodeAccess&) = delete;

    [[nodiscard]] bool ok() const { return ok_; }
    [[nodiscard]] const std::string& error() const { return error_; }
    bool refuse() { return set_mode(0); }
    bool grant() { return set_mode(0666); }
    // Whom to run the child as: the unprivileged user when the test runs as root, else null (as is).
    [[nodiscard]] const Credentials* child_credentials() const { return drop_ ? &as_ : nullptr; }
    [[nodiscard]] const std::string& node() const { return node_; }

  private:
    bool set_mode(mode_t mode);

    std::string node_;
    mode_t saved_mode_ = 0;
    bool ok_ = false;
    bool drop_ = false;
    Credentials as_{};
    std::string error_;
};

}  // namespace hapticd::test
