// SPDX-License-Identifier: Apache-2.0
// What --serve attaches to the daemon's loop (daemon/daemon.hpp, Daemon::attach).
#pragma once

namespace hapticd {

class SceneObjects;
class StatePublisher;
class ContactDetector;

// With --serve (server/server.hpp): the clients' objects, rendered after the config walls (their commits
// applied at the start of a tick), the shared-memory state written at the end of every tick, and the
// contact events detected from that state (server/contact_events.hpp; only with `state`).
struct ServerHooks {
    SceneObjects* objects = nullptr;
    StatePublisher* state = nullptr;
    ContactDetector* contacts = nullptr;
};

}  // namespace hapticd
