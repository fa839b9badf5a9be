// SPDX-License-Identifier: Apache-2.0
// Process exit codes of hapticd (documented in docs/hapticd.md and in the --help footer).
#pragma once

#include "common/startup_error.hpp"

namespace hapticd {

enum ExitCode : int {
    kExitOk = 0,                // normal end, including SIGINT/SIGTERM
    kExitInternal = 1,          // unexpected internal error (a bug)
    kExitUsage = 2,             // bad command line: unknown option, wrong type, bad choice
    kExitBadConfig = 3,         // bad config or device profile file: missing, malformed, unknown key, wrong type
    kExitInvalidParameter = 4,  // a physical or numeric parameter outside its accepted range (incl. NaN/inf)
    kExitUnstableGains = 5,     // explicit --stiffness/--damping outside the stability region
    kExitDeviceError = 6,       // the device could not be opened/homed or failed during the run
    kExitRunFault = 7,          // fault during the run: watchdog or non-finite value
    kExitServerError = 8,       // --serve: the control socket or the state's shared memory could not be created
    kExitSocketPathInUse = 9,   // --serve: the socket path holds a file that is not a stale hapticd socket (left alone)
    // --replay: the recording is unreadable, truncated, corrupt, incomplete or cannot be rebuilt
    kExitBadRecording = 10,
    kExitReplayMismatch = 11,  // --replay: a replayed force differs from the recorded one (or the batches or ticks do)
};

inline constexpr const char* kExitCodeHelp =
    "Exit codes: 0 ok (also after SIGINT/SIGTERM), 1 internal error, 2 usage error, 3 bad config/profile file,\n"
    "4 invalid physical parameter, 5 unstable explicit gains, 6 device error, 7 fault during run\n"
    "(watchdog or non-finite value), 8 --serve: control socket or shared memory could not be created,\n"
    "9 --serve: the socket path holds a file that is not a stale hapticd socket (left alone),\n"
    "10 --replay: bad recording (unreadable, truncated, corrupt, incomplete, or its configuration changed),\n"
    "11 --replay: a replayed force differs from the recorded one.";

// The exit code of an error of this kind (what hapticd, `hapticd experiment` and `hapticd check-device` return).
[[nodiscard]] constexpr int exit_code(ErrorKind kind) noexcept {
    switch (kind) {
        case ErrorKind::Ok:
            return kExitOk;
        case ErrorKind::Internal:
            return kExitInternal;
        case ErrorKind::Usage:
            return kExitUsage;
        case ErrorKind::BadConfig:
            return kExitBadConfig;
        case ErrorKind::InvalidParameter:
            return kExitInvalidParameter;
        case ErrorKind::UnstableGains:
            return kExitUnstableGains;
        case ErrorKind::Device:
            return kExitDeviceError;
        case ErrorKind::RunFault:
            return kExitRunFault;
        case ErrorKind::Server:
            return kExitServerError;
        case ErrorKind::SocketPathInUse:
            return kExitSocketPathInUse;
        case ErrorKind::BadRecording:
            return kExitBadRecording;
        case ErrorKind::ReplayMismatch:
            return kExitReplayMismatch;
    }
    return kExitInternal;
}

}  // namespace hapticd
