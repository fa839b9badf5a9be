// SPDX-License-Identifier: Apache-2.0
// Numbers as they appear in start-up messages: six significant digits, and a list of them as "[a, b, c]".
#pragma once

#include <sstream>
#include <string>
#include <vector>

namespace hapticd {

inline std::string short_number(double v) {
    std::ostringstream s;
    s.precision(6);
    s << v;
    return s.str();
}

inline std::string number_list(const std::vector<double>& v) {
    std::string out = "[";
    for (std::size_t i = 0; i < v.size(); ++i) out += (i ? ", " : "") + short_number(v[i]);
    return out + "]";
}

}  // namespace hapticd
