// SPDX-License-Identifier: Apache-2.0
// The tuning criterion in hapticd: one type, hapticopt::Criterion. A name is parsed into it where it enters (the
// --criterion option and the config file's criterion key in config/options.cpp, a wall's criterion= key in
// scene/scene.cpp, a client's gains.criterion in server/object_resolution.cpp); every step inside takes the typed
// value, and hapticopt::to_string names it in messages, start-up lines and JSON.
#pragma once

#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include <hapticopt/criterion.hpp>

namespace hapticd {

// The criteria hapticd accepts: every criterion hapticopt knows (hapticopt::kAllCriteria, named by
// hapticopt::to_string: amax, OV, CE0, CE1, CE2, CE0+OV, CE1+OV, CE2+OV), in that order.
inline const std::vector<std::string>& accepted_criteria() {
    static const std::vector<std::string> names = hapticopt::criterion_names(hapticopt::kAllCriteria);
    return names;
}

// "amax, OV, CE0, ...": the accepted names for an error message.
inline const std::string& accepted_criteria_text() {
    static const std::string text = hapticopt::joined_names(accepted_criteria());
    return text;
}

// "<name> is invalid; accepted: amax, OV, ...": the error of a name that is not a criterion (the caller puts the
// place before it, e.g. "--criterion: " or "wall '...': criterion = ").
inline std::string invalid_criterion_text(std::string_view name) {
    return std::string(name) + " is invalid; accepted: " + accepted_criteria_text();
}

}  // namespace hapticd
