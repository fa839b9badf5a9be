// SPDX-License-Identifier: Apache-2.0
// An in-memory FtdiTransport for tests: records every control request and write, and serves reads from
// a byte queue that a reply generator (on_write) fills in response to what the host wrote.
#pragma once

#include <cstdint>
#include <deque>
#include <functional>
#include <span>
#include <string>
#include <vector>

#include "devices/transport.hpp"

namespace hapticd {

class ScriptedTransport final : public FtdiTransport {
  public:
    struct Control {
        std::uint8_t request = 0;
        std::uint16_t value = 0;
        std::uint16_t index = 0;
    };
    using Responder = std::function<void(ScriptedTransport&, std::span<const std::uint8_t>)>;

    TransportStatus control(std::uint8_t request, std::uint16_t value, std::uint16_t index) noexcept override;
    TransportResult write(std::span<const std::uint8_t> data, int timeout_ms) noexcept override;
    TransportResult read(std::span<std::uint8_t> buffer, int timeout_ms) noexcept override;
    [[nodiscard]] std::string last_error() const override { return error_; }

    void push_rx(std::span<const std::uint8_t> bytes) { rx.insert(rx.end(), bytes.begin(), bytes.end()); }

    std::vector<Control> controls;                    // every control request, in order
    std::vector<std::vector<std::uint8_t>> writes;    // every write, in order
    std::deque<std::uint8_t> rx;                      // payload bytes the next reads return
    Responder on_write;                               // called after each write
    std::function<void(ScriptedTransport&)> on_read;  // called before each read (e.g. a slow device)
    std::size_t max_read_chunk = 62;                  // payload bytes per read (one FTDI packet)
    bool disconnected = false;                        // every call fails with Disconnected
    long fail_control_at = -1;                        // the control request with this index fails (Error)

  private:
    std::string error_;
};

}  // namespace hapticd
