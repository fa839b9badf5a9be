// SPDX-License-Identifier: Apache-2.0
// The range errors of option and device-profile values (option_ranges.hpp).
#include "config/option_ranges.hpp"

#include <charconv>
#include <cmath>

#include "common/startup_error.hpp"

namespace hapticd {

std::string shortest_text(double v) {
    char buf[64];
    const auto r = std::to_chars(buf, buf + sizeof buf, v);
    return std::string(buf, r.ptr);
}

[[noreturn]] void invalid(const KeyLocations& where, const std::string& name, const std::string& value,
                          const std::string& range) {
    throw StartupError(ErrorKind::InvalidParameter,
                       where.prefix(name) + name + " = " + value + " is invalid; accepted range: " + range);
}

void check_range(const KeyLocations& where, const std::string& name, double v, double lo, double hi, bool lo_open,
                 const std::string& range) {
    if (!std::isfinite(v) || v < lo || v > hi || (lo_open && v == lo)) invalid(where, name, shortest_text(v), range);
}

}  // namespace hapticd
