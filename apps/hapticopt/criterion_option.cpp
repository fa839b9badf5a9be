// SPDX-License-Identifier: Apache-2.0
#include "criterion_option.hpp"

#include <optional>

namespace hapticopt::cli {

namespace criterion_option_detail {

/// "a,b,c": names as CLI11 lists them (a set of choices, a vector's default).
std::string comma_list(const std::vector<std::string>& names) {
    std::string out;
    for (const std::string& n : names) out += (out.empty() ? "" : ",") + n;
    return out;
}

/// "{a,b,c}": the accepted names as CLI11 lists a set of choices (CLI::IsMember).
std::string choice_set(const std::vector<std::string>& names) { return "{" + comma_list(names) + "}"; }

/// The option's long name ("--criterion" of "--criterion,-c"), which the refusal names.
std::string long_name(const std::string& flags) { return flags.substr(0, flags.find(',')); }

/// The step criterion named `name` if it is one of `accepted`.
std::optional<Criterion> accepted_criterion(const std::string& name, std::span<const Criterion> accepted) {
    const std::optional<Criterion> c = parse_criterion(name);
    if (!c) return std::nullopt;
    for (const Criterion a : accepted) {
        if (a == *c) return c;
    }
    return std::nullopt;
}

}  // namespace criterion_option_detail

std::string criterion_name(const StepOrCollisionCriterion& c) {
    return std::visit([](auto criterion) { return std::string(to_string(criterion)); }, c);
}

CLI::Option* add_criterion_option(CLI::App& app, const std::string& flags, Criterion& target,
                                  std::span<const Criterion> accepted, const std::string& description) {
    namespace d = criterion_option_detail;
    const std::vector<Criterion> set(accepted.begin(), accepted.end());
    const std::string choices = d::choice_set(criterion_names(set)), name = d::long_name(flags);
    return app
        .add_option_function<std::string>(
            flags,
            [&target, set, choices, name](const std::string& text) {
                const std::optional<Criterion> c = d::accepted_criterion(text, set);
                if (!c) throw CLI::ValidationError(name, text + " not in " + choices);
                target = *c;
            },
            description)
        ->type_name("TEXT:" + choices)
        ->default_str(std::string(to_string(target)));
}

CLI::Option* add_criteria_option(CLI::App& app, const std::string& flags, std::vector<Criterion>& target,
                                 std::span<const Criterion> accepted, const std::string& description) {
    namespace d = criterion_option_detail;
    const std::vector<Criterion> set(accepted.begin(), accepted.end());
    const std::string choices = d::choice_set(criterion_names(set)), name = d::long_name(flags);
    return app
        .add_option_function<std::vector<std::string>>(
            flags,
            [&target, set, choices, name](const std::vector<std::string>& texts) {
                std::vector<Criterion> parsed;
                for (const std::string& text : texts) {
                    const std::optional<Criterion> c = d::accepted_criterion(text, set);
                    if (!c) throw CLI::ValidationError(name, text + " not in " + choices);
                    parsed.push_back(*c);
                }
                target = std::move(parsed);
            },
            description)
        ->delimiter(',')
        ->type_name("TEXT:" + choices)
        ->default_str("[" + d::comma_list(criterion_names(target)) + "]");
}

CLI::Option* add_criterion_option(CLI::App& app, const std::string& flags, StepOrCollisionCriterion& target,
                                  const std::string& description) {
    namespace d = criterion_option_detail;
    std::vector<std::string> names = criterion_names(kAllCriteria);
    for (const std::string& n : criterion_names(kAllImpulseCriteria)) names.push_back(n);
    const std::string choices = d::choice_set(names), name = d::long_name(flags);
    return app
        .add_option_function<std::string>(
            flags,
            [&target, choices, name](const std::string& text) {
                if (const std::optional<Criterion> step = parse_criterion(text)) {
                    target = *step;
                } else if (const std::optional<ImpulseCriterion> collision = parse_impulse_criterion(text)) {
                    target = *collision;
                } else {
                    throw CLI::ValidationError(name, text + " not in " + choices);
                }
            },
            description)
        ->type_name("TEXT:" + choices);
}

}  // namespace hapticopt::cli
