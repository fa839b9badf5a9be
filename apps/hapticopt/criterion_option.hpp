// SPDX-License-Identifier: Apache-2.0
// The criterion options of the hapticopt subcommands (--criterion, --criteria): each name is parsed once, by its
// option while CLI11 parses the command line, into the library's enum (criterion.hpp); the commands use the typed
// value and print its canonical name (to_string). A name outside the accepted set is refused by CLI11 at parse time
// (exit 2) as "--criterion: <name> not in {amax,OV,...}", CLI11's wording for a set of choices, which hapticd's
// --criterion also uses (src/config/options.cpp); help shows "TEXT:{amax,OV,...}".
#pragma once

#include <CLI/CLI.hpp>
#include <span>
#include <string>
#include <variant>
#include <vector>

#include <hapticopt/criterion.hpp>

namespace hapticopt::cli {

/// The criterion of `hapticopt optimum`: a step criterion of Tables III and IV or a collision criterion C_I0..2.
using StepOrCollisionCriterion = std::variant<Criterion, ImpulseCriterion>;

/// The canonical name of `c` (to_string of the criterion held): the name --criterion accepted for it.
std::string criterion_name(const StepOrCollisionCriterion& c);

/// Adds the option `flags` (long name first, e.g. "--criterion,-c"): one of the names of `accepted`, exact and
/// case-sensitive as parse_criterion, stored in `target` (which keeps its value when the option is not given; help
/// shows that value's name as the default).
CLI::Option* add_criterion_option(CLI::App& app, const std::string& flags, Criterion& target,
                                  std::span<const Criterion> accepted, const std::string& description);

/// The same for a list (repeated or comma-separated names, each one of `accepted`); `target` is replaced by the
/// names given, in order.
CLI::Option* add_criteria_option(CLI::App& app, const std::string& flags, std::vector<Criterion>& target,
                                 std::span<const Criterion> accepted, const std::string& description);

/// The same for one of the eight step criteria (kAllCriteria) or the collision criteria (kAllImpulseCriteria).
CLI::Option* add_criterion_option(CLI::App& app, const std::string& flags, StepOrCollisionCriterion& target,
                                  const std::string& description);

}  // namespace hapticopt::cli
