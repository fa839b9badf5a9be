// SPDX-License-Identifier: Apache-2.0
#include "common/run_child.hpp"

#include <fcntl.h>
#include <grp.h>
#include <poll.h>
#include <pwd.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>

namespace hapticd::test {

namespace {

// Between fork() and exec() in a multi-threaded parent only async-signal-safe calls are allowed: no
// allocation, so the messages are literals written with write(2).
void say(const char* text) { [[maybe_unused]] const ssize_t n = ::write(STDERR_FILENO, text, std::strlen(text)); }

[[noreturn]] void drop_failed(const char* what) {
    say("run_child: cannot drop privileges: ");
    say(what);
    say(" failed\n");
    _exit(kDropFailed);
}

}  // namespace

Credentials unprivileged_user() {
    if (const passwd* pw = getpwnam("nobody"); pw != nullptr) return {pw->pw_uid, pw->pw_gid};
    return {65534, 65534};
}

ChildResult run_child(const std::vector<std::string>& argv, std::chrono::milliseconds limit, const Credentials* as) {
    ChildResult result;
    std::vector<char*> args;
    for (const auto& a : argv) args.push_back(const_cast<char*>(a.c_str()));
    args.push_back(nullptr);
    int fds[2];
    if (argv.empty() || ::pipe2(fds, O_CLOEXEC) != 0) {
        result.output = "run_child: no program or pipe2 failed";
        return result;
    }
    const auto start = std::chrono::steady_clock::now();
    const pid_t pid = ::fork();
    if (pid < 0) {
        ::close(fds[0]);
        ::close(fds[1]);
        result.output = std::string("run_child: fork failed: ") + std::strerror(errno);
        return result;
    }
    if (pid == 0) {
        ::dup2(fds[1], STDOUT_FILENO);  // dup2 clears O_CLOEXEC on the copies
        ::dup2(fds[1], STDERR_FILENO);
        if (as != nullptr) {
            // Groups first (they need the privilege that setresuid gives up), then the gid, then the uid.
            if (::setgroups(0, nullptr) != 0) drop_failed("setgroups");
            if (::setresgid(as->gid, as->gid, as->gid) != 0) drop_failed("setresgid");
            if (::setresuid(as->uid, as->uid, as->uid) != 0) drop_failed("setresuid");
            uid_t r = 0, e = 0, s = 0;
            gid_t rg = 0, eg = 0, sg = 0;
            if (::getresuid(&r, &e, &s) != 0 || r != as->uid || e != as->uid || s != as->uid) drop_failed("uid check");
            if (::getresgid(&rg, &eg, &sg) != 0 || rg != as->gid || eg != as->gid || sg != as->gid)
                drop_failed("gid check");
            if (as->uid != 0 && ::setresuid(0, 0, 0) == 0) drop_failed("irreversibility check");
        }
        ::execv(args[0], args.data());
        say(errno == EACCES ? "run_child: exec failed: permission denied (with dropped privileges: are the binary and "
                              "every directory above it readable and searchable by that user?)\n"
                            : "run_child: exec failed\n");
        _exit(127);
    }
    ::close(fds[1]);
    const auto deadline = start + limit;
    char buf[4096];
    while (true) {
        const auto left =
            std::chrono::duration_cast<std::chrono::milliseconds>(deadline - std::chrono::steady_clock::now());
        if (left.count() <= 0) {
            ::kill(pid, SIGKILL);
            result.timed_out = true;
            break;
        }
        pollfd p{fds[0], POLLIN, 0};
        if (::poll(&p, 1, static_cast<int>(left.count())) < 0 && errno != EINTR) break;
        if ((p.revents & (POLLIN | POLLHUP | POLLERR)) == 0) continue;
        const ssize_t n = ::read(fds[0], buf, sizeof buf);
        if (n > 0) {
            result.output.append(buf, static_cast<std::size_t>(n));
        } else if (n == 0 || errno != EINTR) {
            break;  // EOF: the child closed its ends (it exited)
        }
    }
    ::close(fds[0]);
    int status = 0;
    while (::waitpid(pid, &status, 0) < 0 && errno == EINTR) {
    }
    result.took = std::chrono::steady_clock::now() - start;
    result.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
    return result;
}

}  // namespace hapticd::test
