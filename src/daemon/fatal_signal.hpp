// SPDX-License-Identifier: Apache-2.0
// The daemon's last act when it dies anyway (docs/protocol.md, section 6; docs/hapticd.md): on SIGSEGV,
// SIGBUS, SIGFPE, SIGILL, SIGABRT or std::terminate, zero force on the device where its driver can do it
// async-signal-safely (Device::zero_force_from_signal_handler: the simulated device; HID through write(2) of
// pre-built reports on its own hidraw descriptor; the Falcon through its transport's event thread, the handler
// touching only atomics, an eventfd and nanosleep, confirmed within 50 ms), then fault 4 (fatal signal) or
// 5 (std::terminate) and the signal in the shared-memory state, a line on stderr, and the signal's default
// action (the process ends with it).
#pragma once

namespace hapticd {

class Device;
class StatePublisher;

// Installs the handlers (process-wide; on an alternate stack for the calling thread, so its stack overflow
// is handled too) and std::set_terminate.
// device and state may be null; both must outlive the handlers or be replaced with
// clear_fatal_signal_targets() before they are destroyed. Throws std::system_error when sigaction fails.
void install_fatal_signal_handlers(Device* device, StatePublisher* state);
void clear_fatal_signal_targets() noexcept;

}  // namespace hapticd
