// SPDX-License-Identifier: Apache-2.0
#include "devices/transport_scripted.hpp"

#include <algorithm>

namespace hapticd {

TransportStatus ScriptedTransport::control(std::uint8_t request, std::uint16_t value, std::uint16_t index) noexcept {
    if (disconnected) {
        error_ = "scripted: disconnected";
        return TransportStatus::Disconnected;
    }
    controls.push_back({request, value, index});
    if (fail_control_at >= 0 && controls.size() == static_cast<std::size_t>(fail_control_at) + 1) {
        error_ = "scripted: control request failed";
        return TransportStatus::Error;
    }
    return TransportStatus::Ok;
}

TransportResult ScriptedTransport::write(std::span<const std::uint8_t> data, int /*timeout_ms*/) noexcept {
    if (disconnected) {
        error_ = "scripted: disconnected";
        return {TransportStatus::Disconnected, 0};
    }
    writes.emplace_back(data.begin(), data.end());
    if (on_write) on_write(*this, data);
    return {TransportStatus::Ok, data.size()};
}

TransportResult ScriptedTransport::read(std::span<std::uint8_t> buffer, int /*timeout_ms*/) noexcept {
    if (disconnected) {
        error_ = "scripted: disconnected";
        return {TransportStatus::Disconnected, 0};
    }
    if (on_read) on_read(*this);
    const std::size_t n = std::min({buffer.size(), rx.size(), max_read_chunk});
    for (std::size_t i = 0; i < n; ++i) {
        buffer[i] = rx.front();
        rx.pop_front();
    }
    return {TransportStatus::Ok, n};
}

}  // namespace hapticd
