// SPDX-License-Identifier: Apache-2.0
// Where hapticd finds its config in a build tree (config/config_locations.hpp): the repository's config/, found
// through the build tree's hapticd-build-tree.txt, no system dir; $HAPTICD_CONFIG over it, --config over both;
// device profiles by name from the config file's devices/ first. The installed layout (/etc/hapticd over
// /usr/share/hapticd, the checkout unreadable) is checked on the Debian package by
// scripts/test-debian-packages.sh and on `cmake --install` by ctest packaging.runtime_install.
#include <gtest/gtest.h>

#include <stdlib.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "common/test_paths.hpp"
#include "config/config_locations.hpp"
#include "config/options.hpp"
#include "daemon/exit_codes.hpp"

namespace hapticd {
namespace {

namespace fs = std::filesystem;

class ConfigLocationsTest : public ::testing::Test {
  protected:
    void SetUp() override { ::unsetenv("HAPTICD_CONFIG"); }
    void TearDown() override {
        ::unsetenv("HAPTICD_CONFIG");
        std::error_code ec;
        fs::remove_all(dir_, ec);
    }
    std::string write(const std::string& name, const std::string& text) {
        const fs::path path = dir_ / name;
        fs::create_directories(path.parent_path());
        std::ofstream(path) << text;
        return path.string();
    }
    static Options parse(std::vector<std::string> args) {
        args.insert(args.begin(), "hapticd");
        std::vector<const char*> argv;
        for (const auto& a : args) argv.push_back(a.c_str());
        return parse_options(static_cast<int>(argv.size()), argv.data());
    }
    const fs::path dir_ = fs::temp_directory_path() / ("hapticd_config_locations_" + std::to_string(::getpid()));
};

TEST_F(ConfigLocationsTest, BuildTreeReadsTheRepositoryConfigAndNoSystemDir) {
    const ConfigDirectories& d = config_directories();
    EXPECT_TRUE(d.build_tree);
    EXPECT_EQ(fs::canonical(d.data), fs::canonical(HAPTICD_SOURCE_CONFIG_DIR));
    EXPECT_EQ(d.system, "");
    EXPECT_EQ(config_search_dirs(), std::vector<std::string>{d.data});
    const Options o = parse({});
    EXPECT_EQ(fs::canonical(o.config_path), fs::canonical(fs::path(HAPTICD_SOURCE_CONFIG_DIR) / "hapticd.toml"));
    EXPECT_EQ(fs::canonical(resolve_device_profile_path(o)),
              fs::canonical(fs::path(HAPTICD_SOURCE_CONFIG_DIR) / "devices" / "sim.toml"));
}

TEST_F(ConfigLocationsTest, EnvironmentOverridesTheSearchAndTheCommandLineOverridesIt) {
    const std::string env_file = write("env/hapticd.toml", "rate = 250.0\n");
    const std::string cli_file = write("cli/hapticd.toml", "rate = 125.0\n");
    ::setenv("HAPTICD_CONFIG", env_file.c_str(), 1);
    const Options from_env = parse({});
    EXPECT_EQ(from_env.config_path, env_file);
    EXPECT_EQ(from_env.rate, 250.0);
    const Options from_cli = parse({"--config", cli_file});
    EXPECT_EQ(from_cli.config_path, cli_file);
    EXPECT_EQ(from_cli.rate, 125.0);
    const Options none = parse({"--config", ""});
    EXPECT_EQ(none.config_path, "");
    ::setenv("HAPTICD_CONFIG", "", 1);  // empty: skipped, the search's file
    EXPECT_EQ(fs::canonical(parse({}).config_path),
              fs::canonical(fs::path(HAPTICD_SOURCE_CONFIG_DIR) / "hapticd.toml"));
}

TEST_F(ConfigLocationsTest, MissingEnvironmentFileIsAConfigErrorNamingTheVariable) {
    const std::string missing = (dir_ / "absent.toml").string();
    ::setenv("HAPTICD_CONFIG", missing.c_str(), 1);
    try {
        (void)parse({});
        FAIL() << "no error for a missing $HAPTICD_CONFIG file";
    } catch (const StartupError& e) {
        EXPECT_EQ(exit_code(e.kind()), 3);
        EXPECT_NE(std::string(e.what()).find("'" + missing + "' (from $HAPTICD_CONFIG) does not exist"),
                  std::string::npos)
            << e.what();
    }
}

TEST_F(ConfigLocationsTest, ProfileNextToTheConfigFileComesBeforeTheSearchDirs) {
    const std::string config = write("mine/hapticd.toml", "device = \"sim\"\n");
    const std::string own_sim = write("mine/devices/sim.toml", "driver = \"sim\"\n");
    Options o = parse({"--config", config});
    EXPECT_EQ(resolve_device_profile_path(o), own_sim);
    const std::vector<std::string> dirs = device_profile_dirs(o);
    ASSERT_EQ(dirs.size(), 2U);
    EXPECT_EQ(dirs[0], (dir_ / "mine" / "devices").string());
    EXPECT_EQ(fs::canonical(dirs[1]), fs::canonical(fs::path(HAPTICD_SOURCE_CONFIG_DIR) / "devices"));
    o.device = "falcon";  // not next to the config file: the repository's
    EXPECT_EQ(fs::canonical(resolve_device_profile_path(o)),
              fs::canonical(fs::path(HAPTICD_SOURCE_CONFIG_DIR) / "devices" / "falcon.toml"));
}

// --instance NAME: NAME.toml in any search directory before hapticd.toml in any; without one, hapticd.toml.
TEST_F(ConfigLocationsTest, InstanceConfigComesBeforeTheDefaultConfig) {
    const std::string system = (dir_ / "etc").string();
    const std::string data = (dir_ / "share").string();
    const std::string shipped = write("share/hapticd.toml", "rate = 1000.0\n");
    EXPECT_EQ(find_config_file({system, data}, "left"), shipped);  // no left.toml: the default config
    EXPECT_EQ(find_config_file({system, data}, ""), shipped);
    const std::string admin = write("etc/hapticd.toml", "rate = 500.0\n");
    EXPECT_EQ(find_config_file({system, data}, "left"), admin);
    const std::string left_data = write("share/left.toml", "rate = 400.0\n");
    EXPECT_EQ(find_config_file({system, data}, "left"), left_data);  // an instance's file, even the data dir's
    const std::string left_system = write("etc/left.toml", "rate = 300.0\n");
    EXPECT_EQ(find_config_file({system, data}, "left"), left_system);
    EXPECT_EQ(find_config_file({system, data}, "right"), admin);
    EXPECT_EQ(find_config_file({system, data}, ""), admin);  // the default instance never reads left.toml
    EXPECT_EQ(find_config_file({(dir_ / "none").string()}, "left"), "");
    // In the build tree: no left.toml in the repository's config/, so its hapticd.toml.
    EXPECT_EQ(fs::canonical(parse({"--instance", "left"}).config_path),
              fs::canonical(fs::path(HAPTICD_SOURCE_CONFIG_DIR) / "hapticd.toml"));
}

TEST_F(ConfigLocationsTest, HelpStatesTheSearchOrder) {
    const std::string help = config_search_help();
    const auto at = [&](const std::string& s) { return help.find(s); };
    ASSERT_NE(at("--config FILE"), std::string::npos) << help;
    ASSERT_NE(at("$HAPTICD_CONFIG"), std::string::npos) << help;
    ASSERT_NE(at(config_directories().data + "/hapticd.toml"), std::string::npos) << help;
    EXPECT_LT(at("--config FILE"), at("$HAPTICD_CONFIG"));
    EXPECT_LT(at("$HAPTICD_CONFIG"), at(config_directories().data + "/hapticd.toml"));
    EXPECT_LT(at("$HAPTICD_CONFIG"), at("with --instance NAME: NAME.toml"));
    EXPECT_LT(at("with --instance NAME: NAME.toml"), at(config_directories().data + "/hapticd.toml"));
}

}  // namespace
}  // namespace hapticd
