// SPDX-License-Identifier: Apache-2.0
// The protocol's error codes (docs/protocol.md, section 8) and their wire strings: the one table the
// server, the client library, hapticctl and the fuzz target read them from.
#include "hapticd/client.hpp"

namespace hapticd::client {

namespace {

struct CodeName {
    ErrorCode code;
    const char* name;
};
constexpr CodeName kCodeNames[] = {
    {ErrorCode::ProtocolVersion, "protocol_version"},
    {ErrorCode::BadHello, "bad_hello"},
    {ErrorCode::Oversized, "oversized"},
    {ErrorCode::BadJson, "bad_json"},
    {ErrorCode::BadMessage, "bad_message"},
    {ErrorCode::UnstableGains, "unstable_gains"},
    {ErrorCode::UnstableSum, "unstable_sum"},
    {ErrorCode::BeyondDeviceLimits, "beyond_device_limits"},
    {ErrorCode::UnknownCriterion, "unknown_criterion"},
    {ErrorCode::UnknownObject, "unknown_object"},
    {ErrorCode::NotOwner, "not_owner"},
    {ErrorCode::Capacity, "capacity"},
    {ErrorCode::Busy, "busy"},
    {ErrorCode::LeaseLost, "lease_lost"},
    {ErrorCode::SlowConsumer, "slow_consumer"},
    {ErrorCode::Transport, "transport"},
    {ErrorCode::SessionLimit, "session_limit"},
    {ErrorCode::Internal, "internal"},
    {ErrorCode::Unknown, "unknown"},
};

}  // namespace

const char* to_string(ErrorCode code) noexcept {
    for (const auto& c : kCodeNames) {
        if (c.code == code) return c.name;
    }
    return "unknown";
}

ErrorCode error_code_from_string(const std::string& code) noexcept {
    for (const auto& c : kCodeNames) {
        if (code == c.name) return c.code;
    }
    return ErrorCode::Unknown;
}

}  // namespace hapticd::client
