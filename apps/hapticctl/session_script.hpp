// SPDX-License-Identifier: Apache-2.0
// `hapticctl session [FILE]`: one client session driven by commands, one per line ('#' starts a comment):
//   add SPEC                 add an object (object_spec.hpp); prints "added ID"
//   modify ID SPEC           replace one of this session's objects
//   remove ID | clear        remove one / all of this session's objects
//   begin ... commit         the operations in between form one batch, applied at one tick boundary
//   list | status | state    the scene, the daemon's status, one line of the shared-memory state
//   sleep SECONDS            wait, sending heartbeats so that the lease holds
//   bye                      end the session (also at the end of the input): the objects ramp out
// The first failing command ends the script with its exit code (exit_codes.hpp); the message names the
// source and line.
#pragma once

#include <iosfwd>
#include <string>
#include <vector>

#include "hapticd/client.hpp"

namespace hapticctl {

// Writes the scene as a table (id, owner, kind, K, B, description) or as JSON.
void print_objects(std::ostream& out, const std::vector<hapticd::client::ObjectInfo>& objects, bool json);

// Sleeps `seconds`, heartbeating at a third of the lease (when there is one); returns early (false) when
// SIGINT/SIGTERM arrived (stop_requested()).
bool sleep_with_heartbeats(hapticd::client::Client& client, double seconds);

// SIGINT/SIGTERM set a flag (no other action): hapticctl then ends its session in order.
void install_stop_signal_handlers();
bool stop_requested() noexcept;

int run_session_script(hapticd::client::Client& client, std::istream& in, const std::string& source, std::ostream& out,
                       std::ostream& err);

}  // namespace hapticctl
