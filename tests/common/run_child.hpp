// SPDX-License-Identifier: Apache-2.0
// Runs a program (hapticd) as a child process of a test, with its stdout and stderr captured, a hard time
// limit (the child is killed with SIGKILL when it runs out, so a hanging child fails the test instead of
// hanging it), and optionally with the privileges of an unprivileged user: the child drops to that uid/gid
// and an empty supplementary group list (setgroups, setresgid, setresuid) before exec, and checks with
// getresuid/getresgid that the drop took (exit code kDropFailed otherwise, with the reason in the output).
// The child inherits the environment, so under umockdev it sees the test's testbed (UMOCKDEV_DIR and
// LD_PRELOAD) and talks to the test's ioctl handlers.
#pragma once

#include <chrono>
#include <string>
#include <sys/types.h>
#include <vector>

namespace hapticd::test {

struct ChildResult {
    int exit_code = -1;      // the child's exit status, -1 when killed by a signal
    bool timed_out = false;  // killed after the time limit
    std::string output;      // stdout and stderr, interleaved as written
    std::chrono::steady_clock::duration took{};
};

struct Credentials {
    uid_t uid = 0;
    gid_t gid = 0;
};

inline constexpr int kDropFailed = 125;  // the child could not drop its privileges (before exec)

// The "nobody" user (getpwnam), else 65534:65534, the uid/gid Debian gives it.
Credentials unprivileged_user();

// argv[0] is the program's path. `as` set: run with those credentials (needs root).
ChildResult run_child(const std::vector<std::string>& argv, std::chrono::milliseconds limit,
                      const Credentials* as = nullptr);

}  // namespace hapticd::test
