// SPDX-License-Identifier: Apache-2.0
// The range errors of option and device-profile values: StartupError(InvalidParameter) naming the key, the
// value, the accepted range and, for a value from a file, the file, line and column (key_locations.hpp).
#pragma once

#include <string>

#include "config/key_locations.hpp"

namespace hapticd {

// Shortest text that reads back as the same double ("-0.3", not "-0.29999999999999999").
std::string shortest_text(double v);

// `where` names the file and line of the key when the value came from a file.
[[noreturn]] void invalid(const KeyLocations& where, const std::string& name, const std::string& value,
                          const std::string& range);

// invalid() unless v is finite and lo <= v <= hi (lo < v when lo_open).
void check_range(const KeyLocations& where, const std::string& name, double v, double lo, double hi, bool lo_open,
                 const std::string& range);

}  // namespace hapticd
