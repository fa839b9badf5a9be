// SPDX-License-Identifier: Apache-2.0
// The process-wide stop request from SIGINT/SIGTERM: an async-signal-safe atomic flag set by a sigaction handler,
// read by the loop, the start-up procedures and the server.
#pragma once

namespace hapticd {

// Installs handlers for SIGINT and SIGTERM that only set the stop flag (no SA_RESTART, so blocking calls
// outside the loop return EINTR; the loop's sleep resumes on its own).
void install_stop_signal_handlers();
[[nodiscard]] bool stop_requested() noexcept;
[[nodiscard]] int stop_signal() noexcept;  // the signal that requested the stop, 0 if none
void request_stop(int signal_number = 0) noexcept;
void clear_stop_request() noexcept;  // for tests

}  // namespace hapticd
