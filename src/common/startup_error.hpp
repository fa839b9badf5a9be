// SPDX-License-Identifier: Apache-2.0
// The error start-up code throws: what() is the message the user sees, kind() what went wrong. daemon/exit_codes.hpp
// maps each kind to hapticd's exit code; no folder below daemon/ knows the exit codes.
#pragma once

#include <cstdint>
#include <stdexcept>
#include <string>

namespace hapticd {

enum class ErrorKind : std::uint8_t {
    Ok,                // not an error: --help or --version printed, or a stop by SIGINT/SIGTERM (message may be empty)
    Internal,          // unexpected internal error (a bug)
    Usage,             // bad command line: unknown option, wrong type, bad choice
    BadConfig,         // bad config or device profile file: missing, malformed, unknown key, wrong type
    InvalidParameter,  // a physical or numeric parameter outside its accepted range (incl. NaN/inf)
    UnstableGains,     // explicit gains outside the stability region
    Device,            // the device could not be opened/homed or failed during the run
    RunFault,          // fault during the run: watchdog or non-finite value
    Server,            // --serve: the control socket or the state's shared memory could not be created
    SocketPathInUse,   // --serve: the socket path holds a file that is not a stale hapticd socket
    BadRecording,      // --replay: the recording is unreadable, truncated, corrupt, incomplete or cannot be rebuilt
    ReplayMismatch,    // --replay: a replayed force differs from the recorded one
};

// An error that ends the program (with the exit code of `kind`) after printing what().
class StartupError : public std::runtime_error {
  public:
    StartupError(ErrorKind kind, const std::string& message) : std::runtime_error(message), kind_(kind) {}
    [[nodiscard]] ErrorKind kind() const noexcept { return kind_; }

  private:
    ErrorKind kind_;
};

}  // namespace hapticd
