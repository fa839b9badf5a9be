// SPDX-License-Identifier: Apache-2.0
// The criterion options of the hapticopt CLI (apps/hapticopt/criterion_option.cpp): each name is parsed once by its
// option into the library's enum; a name outside the accepted set is refused by CLI11 at parse time naming the
// option and every accepted name (exit 2); the JSON "criterion" field is the canonical name, equal to the name given.
#include <gtest/gtest.h>

#include <sys/wait.h>

#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <iostream>
#include <sstream>
#include <string>
#include <vector>

#include "cli_output.hpp"
#include "commands.hpp"
#include "common/test_paths.hpp"
#include "criterion_option.hpp"

namespace hapticopt::cli {
namespace criterion_cli_test {

/// Parses `args` (after the program name) with `app`; the CLI11 parse error's message, "" when it parsed.
std::string parse_error(CLI::App& app, std::vector<std::string> args) {
    std::vector<const char*> argv{"hapticopt"};
    for (const std::string& a : args) argv.push_back(a.c_str());
    try {
        app.parse(static_cast<int>(argv.size()), argv.data());
    } catch (const CLI::ParseError& e) {
        return e.what();
    }
    return "";
}

/// Every name of `names` appears in `text`, in the set CLI11 prints: "{a,b,c}".
void expect_lists(const std::string& text, const std::vector<std::string>& names) {
    std::string set;
    for (const std::string& n : names) set += (set.empty() ? "{" : ",") + n;
    EXPECT_NE(text.find(set + "}"), std::string::npos) << text;
}

std::vector<std::string> step_and_collision_names() {
    std::vector<std::string> names = criterion_names(kAllCriteria);
    for (const std::string& n : criterion_names(kAllImpulseCriteria)) names.push_back(n);
    return names;
}

TEST(CriterionCli, EveryAcceptedNameParsesToTheCriterionWhoseCanonicalNameItIs) {
    for (const std::string& name : step_and_collision_names()) {
        CLI::App app;
        StepOrCollisionCriterion c;
        add_criterion_option(app, "--criterion", c, "criterion");
        ASSERT_EQ(parse_error(app, {"--criterion", name}), "") << name;
        EXPECT_EQ(criterion_name(c), name);
        EXPECT_EQ(std::holds_alternative<ImpulseCriterion>(c), parse_impulse_criterion(name).has_value()) << name;
    }
    for (const Criterion expected : kEnergyCriteria) {
        CLI::App app;
        Criterion c = Criterion::AlphaMax;
        add_criterion_option(app, "--criterion,-c", c, kEnergyCriteria, "CE0, CE1 or CE2");
        ASSERT_EQ(parse_error(app, {"-c", std::string(to_string(expected))}), "");
        EXPECT_EQ(c, expected);
    }
}

TEST(CriterionCli, AnUnknownNameIsRefusedAtParseTimeNamingTheOptionAndTheAcceptedNames) {
    for (const std::string bad : {"CE9", "ce2", "CE2 ", "CI3", "amax+OV"}) {
        CLI::App app;
        StepOrCollisionCriterion c;
        add_criterion_option(app, "--criterion", c, "criterion");
        const std::string message = parse_error(app, {"--criterion=" + bad});
        EXPECT_EQ(message.rfind("--criterion: " + bad + " not in ", 0), 0u) << message;
        expect_lists(message, step_and_collision_names());
    }
    // A step criterion outside a subcommand's set (plot costs, plot noise-pareto: CE0..2) is refused the same way,
    // and the default is kept when the option is absent.
    CLI::App app;
    Criterion c = Criterion::CE2;
    add_criterion_option(app, "--criterion,-c", c, kEnergyCriteria, "CE0, CE1 or CE2");
    const std::string message = parse_error(app, {"-c", "CE0+OV"});
    EXPECT_EQ(message, "--criterion: CE0+OV not in {CE0,CE1,CE2}");
    CLI::App defaulted;
    add_criterion_option(defaulted, "--criterion,-c", c, kEnergyCriteria, "CE0, CE1 or CE2");
    ASSERT_EQ(parse_error(defaulted, {}), "");
    EXPECT_EQ(c, Criterion::CE2);
    EXPECT_NE(defaulted.help().find("-c,--criterion TEXT:{CE0,CE1,CE2}=CE2"), std::string::npos) << defaulted.help();
}

TEST(CriterionCli, AListKeepsItsOrderAndRefusesAnUnknownNameNamingTheOption) {
    CLI::App app;
    std::vector<Criterion> list{Criterion::CE0, Criterion::CE1, Criterion::CE2};
    add_criteria_option(app, "--criteria,-c", list, kAllCriteria, "criteria");
    EXPECT_NE(app.help().find("=[CE0,CE1,CE2]"), std::string::npos) << app.help();
    ASSERT_EQ(parse_error(app, {"-c", "amax,CE2+OV", "-c", "OV"}), "");
    EXPECT_EQ(list, (std::vector<Criterion>{Criterion::AlphaMax, Criterion::CE2_OV, Criterion::Overshoot}));
    CLI::App refusing;
    add_criteria_option(refusing, "--criteria,-c", list, kAllCriteria, "criteria");
    const std::string message = parse_error(refusing, {"-c", "CE0,CI0"});
    EXPECT_EQ(message.rfind("--criteria: CI0 not in ", 0), 0u) << message;
    expect_lists(message, criterion_names(kAllCriteria));
}

/// Runs `hapticopt optimum ...` in-process; its stdout parsed as JSON.
nlohmann::json optimum_json(std::vector<std::string> args) {
    CLI::App app;
    const CommandRunner run = add_optimum_command(app);
    args.insert(args.begin(), "optimum");
    EXPECT_EQ(parse_error(app, args), "");
    std::ostringstream captured;
    struct Restore {
        std::streambuf* old;
        ~Restore() { std::cout.rdbuf(old); }
    } restore{std::cout.rdbuf(captured.rdbuf())};
    EXPECT_EQ(run(), int{kOk});
    return nlohmann::json::parse(captured.str());
}

TEST(CriterionCli, TheJsonCriterionFieldIsTheNameGiven) {
    for (const std::string& name : step_and_collision_names()) {
        const nlohmann::json out = optimum_json({"--criterion", name, "--delay", "1", "--delta", "0.02", "--json"});
        EXPECT_EQ(out.at("criterion"), name);
    }
    EXPECT_EQ(
        optimum_json({"--criterion", "CI1", "--velocity", "window:15", "--delay", "1", "--delta", "0.02", "--json"})
            .at("criterion"),
        "CI1");
    EXPECT_EQ(optimum_json({"--criterion", "CE1", "--noise-budget", "5", "--delay", "1", "--json"}).at("criterion"),
              "CE1");
}

#ifdef HAPTICOPT_CLI
TEST(CriterionCli, TheProgramExitsWithTheUsageCodeAndPrintsTheRefusal) {
    const std::string log = "criterion_cli_refusal.txt";
    const int status =
        std::system((std::string(HAPTICOPT_CLI) + " optimum --criterion CE9 --delay 1 > " + log + " 2>&1").c_str());
    ASSERT_TRUE(WIFEXITED(status));
    EXPECT_EQ(WEXITSTATUS(status), int{kUsage});
    std::ifstream in(log);
    std::stringstream text;
    text << in.rdbuf();
    EXPECT_EQ(text.str().rfind("--criterion: CE9 not in {amax,OV,CE0,CE1,CE2,CE0+OV,CE1+OV,CE2+OV,CI0,CI1,CI2}\n", 0),
              0u)
        << text.str();
}
#endif

}  // namespace criterion_cli_test
}  // namespace hapticopt::cli
