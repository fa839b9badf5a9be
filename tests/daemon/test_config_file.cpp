// The strict syntax check of config/profile files.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include "config/config_file.hpp"

namespace hapticd {
namespace {

std::vector<ConfigFileIssue> check(const std::string& text) {
    const auto path = std::filesystem::temp_directory_path() / ("hapticd_lint_" + std::to_string(::getpid()) + ".toml");
    std::ofstream(path) << text;
    auto issues = check_config_file(path.string());
    std::filesystem::remove(path);
    return issues;
}

TEST(ConfigFile, AcceptsTheShippedFiles) {
    for (const auto& entry : std::filesystem::recursive_directory_iterator(HAPTICD_SOURCE_CONFIG_DIR)) {
        if (entry.path().extension() != ".toml") continue;
        const auto issues = check_config_file(entry.path().string());
        EXPECT_TRUE(issues.empty()) << entry.path() << ": line " << issues.front().line << " " << issues.front().message;
    }
}

TEST(ConfigFile, AcceptsTomlValues) {
    EXPECT_TRUE(check("a = 1\nb = -2.5e-3 # c\nc = \"x # y\"\nd = true\ne = [1, 2,\n 3]\nf = 'lit'\ng = 1_000\n").empty());
}

TEST(ConfigFile, RejectsMalformedLinesWithLineNumbers) {
    auto i = check("a = 1\nmass = 0.3.2\n");
    ASSERT_EQ(i.size(), 1U);
    EXPECT_EQ(i[0].line, 2);
    EXPECT_NE(i[0].message.find("mass"), std::string::npos);
    EXPECT_EQ(check("just words\n").size(), 1U);
    EXPECT_EQ(check("a = \"unterminated\n").size(), 1U);
    EXPECT_EQ(check("a = [1, 2\n").size(), 1U);
    EXPECT_EQ(check("[section]\na = 1\n").size(), 1U);
    EXPECT_EQ(check("a = 1, 2\n").size(), 1U);
    EXPECT_EQ(check("a =\n").size(), 1U);
    EXPECT_EQ(check("a = 1\na = 2\n").size(), 1U);  // duplicate
    EXPECT_EQ(check("a = fast\n").size(), 1U);      // bare word
}

}  // namespace
}  // namespace hapticd
