// SPDX-License-Identifier: Apache-2.0
// hapticctl's exit codes (docs/clients.md): one per kind of failure, so that scripts can tell a daemon
// that is not running from an object the daemon refused.
#pragma once

#include "hapticd/client.hpp"

namespace hapticctl {

enum ExitCode : int {
    kExitOk = 0,
    kExitInternal = 1,       // a bug
    kExitUsage = 2,          // bad command line or script line (the message names the word and the accepted form)
    kExitNoDaemon = 3,       // cannot connect: no socket, no daemon, or the socket's mode refuses this user
    kExitRefused = 4,        // the handshake was refused (protocol version) or the answer was not the protocol
    kExitObjectRefused = 5,  // an object or batch was refused: bad field, unstable gains or sum, beyond device limits
    kExitNotOwner = 6,       // the object belongs to another session or the daemon, or does not exist
    kExitBusy = 7,           // the scene is full or the hand-over queue is busy: retry later
    kExitSessionLost = 8,    // the session ended: lease lost, slow consumer, daemon gone
    kExitNoState = 9,        // the state stream cannot be read, or the loop stopped advancing / faulted
};

inline constexpr const char* kExitCodeHelp =
    "Exit codes: 0 ok, 1 internal error, 2 usage, 3 cannot connect (no daemon, no socket, or not permitted),\n"
    "4 handshake refused (protocol version), 5 object refused (bad field, unstable gains/sum, device limits),\n"
    "6 not the owner / unknown object, 7 scene full or busy (retry), 8 session lost (lease, daemon gone),\n"
    "9 state stream unavailable or the loop stopped.";

// The exit code of a client-library error (the protocol's error codes, docs/protocol.md section 8).
inline int exit_code_for(const hapticd::client::Error& e, bool connected) noexcept {
    using hapticd::client::ErrorCode;
    switch (e.code()) {
        case ErrorCode::ProtocolVersion:
        case ErrorCode::BadHello:
        case ErrorCode::BadJson:
        case ErrorCode::Oversized:
            return kExitRefused;
        case ErrorCode::BadMessage:
        case ErrorCode::UnstableGains:
        case ErrorCode::UnstableSum:
        case ErrorCode::BeyondDeviceLimits:
        case ErrorCode::UnknownCriterion:
            return kExitObjectRefused;
        case ErrorCode::UnknownObject:
        case ErrorCode::NotOwner:
            return kExitNotOwner;
        case ErrorCode::Capacity:
        case ErrorCode::SessionLimit:
        case ErrorCode::Busy:
            return kExitBusy;
        case ErrorCode::Internal:
            return kExitInternal;
        case ErrorCode::LeaseLost:
        case ErrorCode::SlowConsumer:
            return kExitSessionLost;
        case ErrorCode::Transport:
            return connected ? kExitSessionLost : kExitNoDaemon;
        case ErrorCode::Unknown:
            return kExitRefused;
    }
    return kExitInternal;
}

}  // namespace hapticctl
