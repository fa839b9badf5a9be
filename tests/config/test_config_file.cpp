// SPDX-License-Identifier: Apache-2.0
// hapticd's TOML files: the reader (config/config_file.hpp, toml++) and the loaders that apply a file to the
// options (config/apply_config_file.hpp through parse_options and load_device_profile): TOML syntax a new
// user writes loads, errors name file, line, column, key, value and what is accepted, unknown keys and wrong
// types stay errors. Line/column references are counted by hand from the test's own text (1-based).
#include <gtest/gtest.h>

#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <iostream>
#include <iterator>
#include <map>
#include <regex>
#include <set>
#include <sstream>

#include "common/test_paths.hpp"
#include "config/config_file.hpp"
#include "config/options.hpp"
#include "daemon/exit_codes.hpp"
#include "scene/scene.hpp"

namespace hapticd {
namespace {

namespace fs = std::filesystem;

// A scratch file of this process, removed with the fixture.
class ConfigFileTest : public ::testing::Test {
  protected:
    void TearDown() override {
        std::error_code ec;
        fs::remove_all(dir_, ec);
    }
    std::string write(const std::string& name, const std::string& text) {
        fs::create_directories(dir_);
        const fs::path path = dir_ / name;
        std::ofstream(path, std::ios::binary) << text;
        return path.string();
    }
    // parse_options with --config <text>; the StartupError's code and message when it throws (code -1: none).
    struct Loaded {
        Options options;
        int code = -1;
        std::string message;
    };
    Loaded load_config(const std::string& text, std::vector<std::string> extra = {}) {
        const std::string path = write("hapticd.toml", text);
        std::vector<std::string> args{"hapticd", "--config", path};
        args.insert(args.end(), extra.begin(), extra.end());
        std::vector<const char*> argv;
        for (const auto& a : args) argv.push_back(a.c_str());
        Loaded r;
        try {
            r.options = parse_options(static_cast<int>(argv.size()), argv.data());
            validate_options(r.options);
        } catch (const StartupError& e) {
            r.code = exit_code(e.kind());
            r.message = e.what();
        }
        return r;
    }
    struct LoadedProfile {
        DeviceProfile profile;
        int code = -1;
        std::string message;
    };
    LoadedProfile load_profile(const std::string& text) {
        Options o;
        o.device = write("device.toml", text);
        LoadedProfile r;
        try {
            r.profile = load_device_profile(o);
        } catch (const StartupError& e) {
            r.code = exit_code(e.kind());
            r.message = e.what();
        }
        return r;
    }

    fs::path dir_ = fs::temp_directory_path() / ("hapticd_config_file_" + std::to_string(::getpid()));
};

#define EXPECT_CONTAINS(haystack, needle)                            \
    EXPECT_NE(std::string(haystack).find(needle), std::string::npos) \
        << "missing '" << (needle) << "' in: " << (haystack)

const std::string kMinimalProfile = "mass = 0.3\nmax_force = 10.0\n";

// ---------------------------------------------------------------------------------------------------------
// The reader.

TEST_F(ConfigFileTest, ReadsEveryShippedFile) {
    int files = 0;
    for (const auto& entry : fs::recursive_directory_iterator(HAPTICD_SOURCE_CONFIG_DIR)) {
        if (entry.path().extension() != ".toml") continue;
        ++files;
        const auto contents = read_config_file(entry.path().string());
        EXPECT_FALSE(contents.issue) << entry.path() << ": line " << contents.issue->at.line << ": "
                                     << contents.issue->message;
        EXPECT_FALSE(contents.entries.empty()) << entry.path();
    }
    EXPECT_GE(files, 2);  // hapticd.toml and at least the sim profile
}

TEST_F(ConfigFileTest, ReadsScalarsWithTheirTypesAndTextsInFileOrder) {
    const auto c = parse_config_text(
        "b = -2.5e-3 # comment\n  a = 1_000\nc = \"x # y\"\nd = true\nf = 'lit'\n"
        "h = 0x10\ni = 1_000.0\nj = -0.3\nk = inf\nl = -nan\n",
        "t.toml");
    ASSERT_FALSE(c.issue) << c.issue->message;
    // {key, line, column, type, text}: what the option parser will read.
    struct Expected {
        const char* key;
        int line;
        int column;
        ConfigValueType type;
        const char* text;
    };
    const Expected expected[] = {
        {"b", 1, 1, ConfigValueType::Float, "-0.0025"}, {"a", 2, 3, ConfigValueType::Integer, "1000"},
        {"c", 3, 1, ConfigValueType::String, "x # y"},  {"d", 4, 1, ConfigValueType::Boolean, "true"},
        {"f", 5, 1, ConfigValueType::String, "lit"},    {"h", 6, 1, ConfigValueType::Integer, "16"},
        {"i", 7, 1, ConfigValueType::Float, "1000"},    {"j", 8, 1, ConfigValueType::Float, "-0.3"},
        {"k", 9, 1, ConfigValueType::Float, "inf"},     {"l", 10, 1, ConfigValueType::Float, "nan"},
    };
    ASSERT_EQ(c.entries.size(), std::size(expected));
    for (std::size_t i = 0; i < std::size(expected); ++i) {
        const ConfigEntry& e = c.entries[i];
        SCOPED_TRACE(expected[i].key);
        EXPECT_EQ(e.key, expected[i].key);
        EXPECT_EQ(e.at.line, expected[i].line);
        EXPECT_EQ(e.at.column, expected[i].column);
        EXPECT_FALSE(e.is_array);
        ASSERT_EQ(e.values.size(), 1U);
        EXPECT_EQ(e.values[0].type, expected[i].type);
        EXPECT_EQ(e.values[0].text, expected[i].text);
    }
}

TEST_F(ConfigFileTest, ReadsMultiLineArraysAndTripleQuotedStrings) {
    const auto c = parse_config_text(
        "wall = [\n  \"axis=0 position=0.0 direction=+1\", # first\n"
        "  \"axis=0 position=0.05 direction=-1\",\n]\n"
        "d = \"\"\"\nfirst line\nsecond \"quoted\" line\"\"\"\nl = '''C:\\path'''\n",
        "t.toml");
    ASSERT_FALSE(c.issue) << c.issue->message;
    ASSERT_EQ(c.entries.size(), 3U);
    EXPECT_EQ(c.entries[0].key, "wall");
    EXPECT_TRUE(c.entries[0].is_array);
    ASSERT_EQ(c.entries[0].values.size(), 2U);
    EXPECT_EQ(c.entries[0].values[1].text, "axis=0 position=0.05 direction=-1");
    EXPECT_EQ(c.entries[1].key, "d");
    EXPECT_EQ(c.entries[1].at.line, 5);
    EXPECT_EQ(c.entries[1].values[0].text, "first line\nsecond \"quoted\" line");  // TOML drops the first newline
    EXPECT_EQ(c.entries[2].values[0].text, "C:\\path");                            // literal: no escapes
    EXPECT_EQ(c.entries[2].at.line, 8);
}

TEST_F(ConfigFileTest, SyntaxErrorsHaveLineColumnAndTheLine) {
    const auto c = parse_config_text("a = 1\nmass = 0.3.2\n", "t.toml");
    ASSERT_TRUE(c.issue);
    EXPECT_EQ(c.issue->at.line, 2);
    EXPECT_EQ(c.issue->at.column, 11);  // the second '.'
    EXPECT_CONTAINS(c.issue->message, "\n    mass = 0.3.2\n              ^");
    EXPECT_TRUE(c.entries.empty());
    // The line of the offending text and a column range on it, counted on the text: the character that
    // cannot be there; for a bare word, anywhere in it; for an unterminated array, the end of its line.
    struct Case {
        const char* text;
        int line;
        int first_column;
        int last_column;
    };
    for (const Case& k : {Case{"just words\n", 1, 6, 6},                   // 'w': '=' expected
                          Case{"a = \"unterminated\nb = 1\n", 1, 18, 18},  // the newline inside the string
                          Case{"a = 1\na = 2\n", 2, 5, 5},                 // the second value of 'a'
                          Case{"a = 1, 2\n", 1, 6, 6},                     // ','
                          Case{"a =\n", 1, 4, 4},                          // the newline: value expected
                          Case{"a = fast\n", 1, 5, 8},                     // the bare word
                          Case{"x = 1\n\n  y = [1, 2\n", 3, 12, 13}}) {    // past "  y = [1, 2" (11 characters)
        const auto r = parse_config_text(k.text, "t.toml");
        ASSERT_TRUE(r.issue) << k.text;
        EXPECT_EQ(r.issue->at.line, k.line) << k.text << r.issue->message;
        EXPECT_GE(r.issue->at.column, k.first_column) << k.text << r.issue->message;
        EXPECT_LE(r.issue->at.column, k.last_column) << k.text << r.issue->message;
    }
}

TEST_F(ConfigFileTest, RejectsWhatHapticdFilesDoNotUseWithPositions) {
    struct Case {
        const char* text;
        int line;
        int column;
        const char* says;
    };
    for (const Case& k : {Case{"rate = 1\n[loop]\nx = 1\n", 2, 1, "[loop]"}, Case{"loop.rate = 1\n", 1, 1, "table"},
                          Case{"k = {a = 1}\n", 1, 5, "table"}, Case{"k = [[1], [2]]\n", 1, 6, "arrays of arrays"},
                          Case{"t = 1979-05-27\n", 1, 1, "dates"}}) {
        const auto r = parse_config_text(k.text, "t.toml");
        ASSERT_TRUE(r.issue) << k.text;
        EXPECT_EQ(r.issue->at.line, k.line) << k.text;
        EXPECT_EQ(r.issue->at.column, k.column) << k.text;
        EXPECT_CONTAINS(r.issue->message, k.says);
        EXPECT_TRUE(r.entries.empty());
    }
    const auto missing = read_config_file((dir_ / "does-not-exist.toml").string());
    ASSERT_TRUE(missing.issue);
    EXPECT_EQ(missing.issue->at.line, 0);
}

// Inputs that reach known bugs of toml++ 3.3.0 (Debian 12's; fixed upstream after it, see
// tests/fuzz/toml_assert_policy.hpp): debug-only assertions (issue #294: the table header "[&"; a NUL in a
// time) and a __builtin_unreachable() for code points U+00A1..U+FEFF where whitespace is tested (issues
// #190, #295). The library as shipped must give the TOML answer: a parse error at the offending character;
// for #190's multi-line string, the string. The sweep covers every code point of the range in both places.
TEST_F(ConfigFileTest, KnownTomlPlusPlusBugInputsGiveTheTomlAnswer) {
    struct Case {
        std::string text;
        int line;
        int column;
    };
    for (const Case& k : {Case{"[&\n", 1, 2}, Case{std::string("[\0\0table]\nkey = 1\n", 18), 1, 2},
                          Case{std::string("t = 1979-05-27T\0\x19"
                                           "2:00Z\n",
                                           23),
                               1, 16}}) {
        const auto r = parse_config_text(k.text, "t.toml");
        ASSERT_TRUE(r.issue);
        EXPECT_EQ(r.issue->at.line, k.line) << r.issue->message;
        EXPECT_EQ(r.issue->at.column, k.column) << r.issue->message;
    }
    auto utf8 = [](char32_t c) {
        std::string s;
        if (c < 0x800) {
            s += static_cast<char>(0xC0 | (c >> 6));
        } else {
            s += static_cast<char>(0xE0 | (c >> 12));
            s += static_cast<char>(0x80 | ((c >> 6) & 0x3F));
        }
        s += static_cast<char>(0x80 | (c & 0x3F));
        return s;
    };
    int wrong = 0;
    for (char32_t c = 0xA0; c <= 0xFEFF; ++c) {
        if (c >= 0xD800 && c <= 0xDFFF) continue;  // surrogates: not UTF-8
        // TOML 1.0 whitespace is space and tab only. After a bare key every other code point is an error at
        // its column...
        // Appended rather than written `"k" + utf8(c) + ...`: for `const char* + std::string&&` GCC 12 at -O3
        // inlines the insert at position 0 and reports a false -Wrestrict (a memcpy "overlapping" by an
        // unbounded size): the literal and the string's own buffer are distinct objects and never overlap.
        std::string key_line = "k";
        key_line += utf8(c);
        key_line += "= 1\n";
        const auto after_key = parse_config_text(key_line, "t.toml");
        if (!after_key.issue || after_key.issue->at.line != 1 || after_key.issue->at.column != 2) ++wrong;
        // ...and after a line-ending backslash in a multi-line string it is kept, except that toml++ 3.3 trims
        // these 20 too (Unicode's space separators and U+180E, U+200B, U+2060, U+FEFF): an extension of it.
        const bool extension_whitespace = c == 0xA0 || c == 0x1680 || c == 0x180E || (c >= 0x2000 && c <= 0x200B) ||
                                          c == 0x202F || c == 0x205F || c == 0x2060 || c == 0x3000 || c == 0xFEFF;
        const auto in_string = parse_config_text("s = \"\"\"\\\n" + utf8(c) + "\"\"\"\n", "t.toml");
        const std::string kept = extension_whitespace ? "" : utf8(c);
        if (in_string.issue || in_string.entries.size() != 1 || in_string.entries[0].values[0].text != kept) ++wrong;
        if (wrong > 0) {
            ADD_FAILURE() << "code point U+" << std::hex << static_cast<unsigned>(c);
            break;
        }
    }
}

// ---------------------------------------------------------------------------------------------------------
// The config file as `hapticd --config F` loads it.

TEST_F(ConfigFileTest, NewUserSyntaxLoads) {
    const auto r = load_config(
        "wall = [\n  \"axis=0 position=0.0 direction=+1\",\n"
        "  \"axis=0 position=0.05 direction=-1 mode=bilateral\",\n]\n"
        "rate = 1_000.0\ncriterion = \"\"\"CE1\"\"\"\ntrace-capacity = 0x1000\n");
    ASSERT_EQ(r.code, -1) << r.message;
    EXPECT_EQ(r.options.rate, 1000.0);
    EXPECT_EQ(r.options.criterion, hapticopt::Criterion::CE1);
    EXPECT_EQ(r.options.trace_capacity, 4096);
    ASSERT_EQ(r.options.walls.size(), 2U);
    std::string err;
    const auto second = parse_wall_spec(r.options.walls[1], err);
    ASSERT_TRUE(second) << err;
    EXPECT_EQ(second->position, 0.05);
    EXPECT_EQ(second->direction, -1.0);
}

TEST_F(ConfigFileTest, ValuesOfEveryTypeLoadAndTheCommandLineWins) {
    const auto r = load_config(
        "rate = 500\nlockstep = true\nmlock = false\ndelay-buffer = 3\n"
        "wall = \"axis=0 position=0.01 direction=+1\"\nstep-force = -2\n",
        {"--rate", "250"});
    ASSERT_EQ(r.code, -1) << r.message;
    EXPECT_EQ(r.options.rate, 250.0);
    EXPECT_TRUE(r.options.lockstep);
    EXPECT_FALSE(r.options.mlock);
    EXPECT_EQ(r.options.delay_buffer, 3);
    EXPECT_EQ(r.options.step_force, -2.0);
    ASSERT_EQ(r.options.walls.size(), 1U);  // one string for a list of walls
    EXPECT_EQ(r.options.walls[0], "axis=0 position=0.01 direction=+1");
}

// wall = [] starts an empty scene (for clients of --serve); --wall on the command line still wins.
TEST_F(ConfigFileTest, EmptyWallArrayMeansNoWallsAndTheCommandLineWins) {
    const auto none = load_config("wall = []\n");
    ASSERT_EQ(none.code, -1) << none.message;
    EXPECT_TRUE(none.options.walls.empty());
    const auto cli = load_config("wall = []\n", {"--wall", "axis=1 position=0.0 direction=-1"});
    ASSERT_EQ(cli.code, -1) << cli.message;
    ASSERT_EQ(cli.options.walls.size(), 1U);
    EXPECT_EQ(cli.options.walls[0], "axis=1 position=0.0 direction=-1");
    const auto flag = load_config("", {"--no-walls"});
    ASSERT_EQ(flag.code, -1) << flag.message;
    EXPECT_TRUE(flag.options.walls.empty());
    const auto empty_other = load_config("rate = []\n");  // other keys still need a value
    EXPECT_EQ(empty_other.code, 3) << empty_other.message;
}

TEST_F(ConfigFileTest, SyntaxErrorIsBadConfigWithLineAndColumn) {
    const auto r = load_config("rate = 1000.0\nmass = 0.3.2\n");
    EXPECT_EQ(r.code, kExitBadConfig);
    EXPECT_CONTAINS(r.message, "is malformed: line 2, column 11: ");
    EXPECT_CONTAINS(r.message, "mass = 0.3.2");
    const auto table = load_config("[loop]\nrate = 1000.0\n");
    EXPECT_EQ(table.code, kExitBadConfig);
    EXPECT_CONTAINS(table.message, "line 1, column 1: ");
    EXPECT_CONTAINS(table.message, "[loop]");
}

// A file's text, the exit code it must give and the parts its message must contain.
struct BadFile {
    std::string text;
    int code;
    std::vector<std::string> parts;
};

TEST_F(ConfigFileTest, UnknownKeysAndRejectedValuesNameTheirPlace) {
    std::vector<BadFile> cases{
        {"rate = 1000.0\n  stiffnes = 3.0\n", kExitBadConfig, {"line 2, column 3: unknown key 'stiffnes'"}},
        {"criterion = \"CE9\"\n",
         kExitBadConfig,
         {"line 1, column 1: criterion = \"CE9\": --criterion: CE9 not in "
          "{amax,OV,CE0,CE1,CE2,CE0+OV,CE1+OV,CE2+OV}"}},
        {"\nrt-priority = 10000000000\n", kExitBadConfig, {"line 2, column 1: rt-priority = 10000000000"}},
        {"rate = [1, 2]\n", kExitBadConfig, {"rate = [1, 2] is an array; accepted: a number"}}};
    for (const std::string pass_one_only : {"config", "dry-run", "list-devices", "help", "version"}) {
        cases.push_back({pass_one_only + " = true\n", kExitBadConfig, {"unknown key '" + pass_one_only + "'"}});
    }
    for (const BadFile& c : cases) {
        const auto r = load_config(c.text);
        EXPECT_EQ(r.code, c.code) << c.text;
        for (const auto& part : c.parts) EXPECT_CONTAINS(r.message, part);
    }
}

// The options hapticd --help lists, with the type CLI11 shows beside each ("" for a flag).
std::map<std::string, std::string> options_from_help() {
    std::ostringstream help;
    std::streambuf* const old = std::cout.rdbuf(help.rdbuf());
    const char* argv[] = {"hapticd", "--help"};
    try {
        (void)parse_options(2, argv);
    } catch (const StartupError&) {
    }
    std::cout.rdbuf(old);
    std::map<std::string, std::string> options;
    const std::regex option_re(R"(^\s+(?:-\w,)?--([A-Za-z0-9_-]+)(?: ([A-Z]+))?)");
    std::istringstream lines(help.str());
    std::string line;
    while (std::getline(lines, line)) {
        std::smatch m;
        if (std::regex_search(line, m, option_re)) options[m[1]] = m[2];
    }
    return options;
}

// Every key of the config file (every option of --help but the six of the command line alone): a value of
// the wrong type is an error naming file, line, column, key and value. The expected kinds come from
// --help (CLI11's type names), not from the reader.
TEST_F(ConfigFileTest, EveryKeyRejectsTheWrongType) {
    const auto options = options_from_help();
    ASSERT_GT(options.size(), 30U) << "hapticd --help lists fewer options than expected";
    const std::set<std::string> command_line_only{"config", "dry-run", "list-devices", "replay", "help", "version"};
    int checked = 0;
    for (const auto& [key, type] : options) {
        if (command_line_only.count(key) != 0) continue;
        SCOPED_TRACE(key + " " + type);
        std::vector<std::string> wrong;
        if (type == "FLOAT")
            wrong = {"\"1\"", "true"};
        else if (type == "INT")
            wrong = {"\"1\"", "1.5", "true"};
        else if (type == "TEXT")
            wrong = {"1", "true"};
        else if (type.empty() || type == "BOOLEAN")
            wrong = {"1", "\"true\""};  // a flag or a bool
        else
            ADD_FAILURE() << "type " << type << " is new: teach takes_of() in config/apply_config_file.cpp";
        for (const std::string& value : wrong) {
            const auto r = load_config("# first line\n" + key + " = " + value + "\n");
            EXPECT_EQ(r.code, kExitBadConfig);
            EXPECT_CONTAINS(r.message, "config file '");
            EXPECT_CONTAINS(r.message, "line 2, column 1: " + key + " = " + value + " has the wrong type");
            EXPECT_CONTAINS(r.message, "accepted: ");
        }
        ++checked;
    }
    EXPECT_GT(checked, 30);
}

// The range checks of validate_options name the config file's line when the value is the file's, and not
// when the command line gave it.
TEST_F(ConfigFileTest, RangeErrorsOfFileValuesNameLineAndColumn) {
    const std::pair<const char*, const char*> out_of_range[] = {
        {"rate", "-5"},
        {"delay-buffer", "-2"},
        {"duration", "inf"},
        {"rt-priority", "100"},
        {"cpu", "-2"},
        {"watchdog-overruns", "-1"},
        {"watchdog-stall-periods", "-1"},
        {"trace-capacity", "1"},
        {"step-force", "nan"},
        {"push-speed", "-1"},
        {"push-distance", "-1"},
        {"push-force", "1e7"},
        {"hold-force", "-1e7"},
        {"hold-distance", "-1"},
        {"identify-force", "-1"},
        {"identify-distance", "-1"},
        {"identify-duration", "0.01"},
        {"spin-us", "-1"},
        {"spin-us", "1000"}};  // 1000 us: a whole period at 1 kHz
    for (const auto& [key, value] : out_of_range) {
        SCOPED_TRACE(key);
        const auto r = load_config("\n\n   " + std::string(key) + " = " + value + "\n");
        EXPECT_EQ(r.code, kExitInvalidParameter) << r.message;
        EXPECT_CONTAINS(r.message, "config file '");
        EXPECT_CONTAINS(r.message, "line 3, column 4: " + std::string(key) + " = ");
        EXPECT_CONTAINS(r.message, "accepted range");
    }
    const auto gains = load_config("stiffness = -1.0\ndamping = 1.0\n");
    EXPECT_EQ(gains.code, kExitInvalidParameter);
    EXPECT_CONTAINS(gains.message, "line 1, column 1: stiffness = -1 is invalid; accepted range");
    const auto overridden = load_config("rate = -5\n", {"--rate", "-3"});
    EXPECT_EQ(overridden.code, kExitInvalidParameter);
    EXPECT_EQ(overridden.message.rfind("rate = -3 is invalid; accepted range", 0), 0U) << overridden.message;
}

// ---------------------------------------------------------------------------------------------------------
// Device profiles.

TEST_F(ConfigFileTest, ProfileLoadsNewUserSyntax) {
    const auto r = load_profile(
        "mass = 0.3\nmax_force = 10.0\ndescription = \"\"\"\nmy device,\nsecond line\"\"\"\n"
        "mass_range = [\n  0.2,\n  0.4,\n]\nstiffness = 1_000.0\n");
    ASSERT_EQ(r.code, -1) << r.message;
    EXPECT_EQ(r.profile.description, "my device,\nsecond line");
    EXPECT_EQ(r.profile.stiffness, 1000.0);
    EXPECT_EQ(r.profile.mass_range, (std::vector<double>{0.2, 0.4}));
}

TEST_F(ConfigFileTest, ProfileErrorsNameLineAndColumn) {
    const std::vector<BadFile> cases{
        {"max_force = 10.0\nmass = -0.3\n",
         kExitInvalidParameter,
         {"device profile '", "line 2, column 1: mass = -0.3 is invalid; accepted range"}},
        {kMinimalProfile + "mas = 1\n", kExitBadConfig, {"line 3, column 1: unknown key 'mas'"}},
        {"max_force = 10.0\n", kExitBadConfig, {"missing key 'mass'"}},
        {"mass = 0.3\nmax_force = 10.0.0\n", kExitBadConfig, {"device profile '", "is malformed: line 2, column "}},
        {kMinimalProfile + "mass_range = [0.2, 0.3, 0.4]\n",
         kExitInvalidParameter,
         {"line 3, column 1: mass_range = 3 values is invalid"}},
        {kMinimalProfile + "driver = \"usb\"\n", kExitBadConfig, {"line 3, column 1: driver = \"usb\": "}},
        // the real-device keys (config/profile_keys.cpp)
        {kMinimalProfile + "homing_timeout = 0.0\n",
         kExitInvalidParameter,
         {"line 3, column 1: homing_timeout = 0.000000 is invalid; accepted range"}},
        {kMinimalProfile + "driver = \"hid\"\n", kExitBadConfig, {"line 3, column 1: driver = \"hid\" needs usb_vid"}}};
    for (const BadFile& c : cases) {
        const auto r = load_profile(c.text);
        EXPECT_EQ(r.code, c.code) << c.text;
        for (const auto& part : c.parts) EXPECT_CONTAINS(r.message, part);
    }
}

// coulomb_friction: one value for every axis or one per axis (as position_resolution), 0 when absent; a wrong
// count or a negative value names the key's place.
TEST_F(ConfigFileTest, ProfileCoulombFrictionIsOneValueOrOnePerAxis) {
    const auto none = load_profile(kMinimalProfile + "axes = 3\n");
    ASSERT_EQ(none.code, -1) << none.message;
    EXPECT_EQ(none.profile.coulomb_friction, (AxisVector{0.0, 0.0, 0.0}));
    const auto one = load_profile(kMinimalProfile + "axes = 3\ncoulomb_friction = 0.05\n");
    ASSERT_EQ(one.code, -1) << one.message;
    EXPECT_EQ(one.profile.coulomb_friction, (AxisVector{0.05, 0.05, 0.05}));
    const auto each = load_profile(kMinimalProfile + "axes = 3\ncoulomb_friction = [0.01, 0.02, 0.03]\n");
    ASSERT_EQ(each.code, -1) << each.message;
    EXPECT_EQ(each.profile.coulomb_friction, (AxisVector{0.01, 0.02, 0.03}));
    const auto count = load_profile(kMinimalProfile + "axes = 3\ncoulomb_friction = [0.01, 0.02]\n");
    EXPECT_EQ(count.code, kExitInvalidParameter);
    EXPECT_CONTAINS(count.message, "line 4, column 1: coulomb_friction = 2 values is invalid");
    const auto negative = load_profile(kMinimalProfile + "axes = 3\ncoulomb_friction = -0.1\n");
    EXPECT_EQ(negative.code, kExitInvalidParameter);
    EXPECT_CONTAINS(negative.message, "line 4, column 1: coulomb_friction = ");
}

// force_noise_budget (N): optional, finite and > 0, and only with an encoder step (position_resolution > 0 on some
// axis; tune_wall checks the wall's own axis). The error names the line, the key and what is accepted.
TEST_F(ConfigFileTest, ForceNoiseBudgetIsPositiveAndNeedsAnEncoderStep) {
    const auto none = load_profile(kMinimalProfile);
    EXPECT_EQ(none.code, -1) << none.message;
    EXPECT_FALSE(none.profile.force_noise_budget.has_value());
    const auto given = load_profile(kMinimalProfile + "position_resolution = 1e-5\nforce_noise_budget = 0.05\n");
    EXPECT_EQ(given.code, -1) << given.message;
    ASSERT_TRUE(given.profile.force_noise_budget.has_value());
    EXPECT_EQ(*given.profile.force_noise_budget, 0.05);
    for (const char* bad : {"0.0", "-0.1", "inf"}) {
        const auto r = load_profile(kMinimalProfile + "position_resolution = 1e-5\nforce_noise_budget = " + bad + "\n");
        EXPECT_EQ(r.code, kExitInvalidParameter) << bad;
        EXPECT_CONTAINS(r.message, "line 4, column 1: force_noise_budget = ");
        EXPECT_CONTAINS(r.message, "accepted range: finite, > 0 N");
    }
    const auto no_step = load_profile(kMinimalProfile + "force_noise_budget = 0.05\n");
    EXPECT_EQ(no_step.code, kExitInvalidParameter);
    EXPECT_CONTAINS(no_step.message, "line 3, column 1: force_noise_budget = 0.05 is invalid");
    EXPECT_CONTAINS(no_step.message, "position_resolution > 0");
}

// Every key the shipped profiles use, given a value of another type: an error naming line, column and key.
// The wrong value is chosen from the type of the shipped value (read by the reader under test, whose typing
// ReadsScalarsWithTheirTypesAndTextsInFileOrder checks separately).
TEST_F(ConfigFileTest, EveryShippedProfileKeyRejectsTheWrongType) {
    std::map<std::string, ConfigEntry> keys;
    for (const auto& file : fs::directory_iterator(fs::path(HAPTICD_SOURCE_CONFIG_DIR) / "devices")) {
        if (file.path().extension() != ".toml") continue;
        for (const ConfigEntry& e : read_config_file(file.path().string()).entries) keys.emplace(e.key, e);
    }
    ASSERT_GT(keys.size(), 15U);
    for (const auto& [key, shipped] : keys) {
        if (key == "mass" || key == "max_force") continue;  // below: the two required keys go first
        SCOPED_TRACE(key);
        const ConfigValueType type = shipped.values.empty() ? ConfigValueType::Float : shipped.values[0].type;
        const std::string wrong = type == ConfigValueType::String ? "1" : "\"text\"";
        const auto r = load_profile(kMinimalProfile + key + " = " + wrong + "\n");
        EXPECT_EQ(r.code, kExitBadConfig);
        EXPECT_CONTAINS(r.message, "line 3, column 1: " + key + " = " + wrong + " has the wrong type");
    }
    const auto mass = load_profile("mass = \"0.3\"\nmax_force = 10.0\n");
    EXPECT_EQ(mass.code, kExitBadConfig);
    EXPECT_CONTAINS(mass.message,
                    "line 1, column 1: mass = \"0.3\" has the wrong type (a string); accepted: an array of "
                    "numbers ([a, b, ...]) or a number");  // one mass, or one per axis
}

// --instance NAME (or `instance` in the file) names the socket, the state segment and (config_locations) the config
// file; no instance keeps today's names; --serve-socket / --serve-shm, on the command line or in the file, win; a
// name outside [a-z0-9][a-z0-9_-]{0,31} is refused naming the option and the accepted form.
TEST_F(ConfigFileTest, InstanceNamesItsSocketAndStateUnlessTheyAreGiven) {
    const char* saved = std::getenv("RUNTIME_DIRECTORY");
    const std::string saved_value = saved != nullptr ? saved : "";
    ::setenv("RUNTIME_DIRECTORY", "/run/test-instances", 1);
    const auto none = load_config("");
    EXPECT_EQ(none.code, -1) << none.message;
    EXPECT_EQ(none.options.instance, "");
    EXPECT_EQ(none.options.serve_socket, "");  // the server's default: $RUNTIME_DIRECTORY/hapticd.sock
    EXPECT_EQ(none.options.serve_shm, "/hapticd-state");

    const auto cli = load_config("", {"--instance", "left"});
    EXPECT_EQ(cli.code, -1) << cli.message;
    EXPECT_EQ(cli.options.serve_socket, "/run/test-instances/hapticd-left.sock");
    EXPECT_EQ(cli.options.serve_shm, "/hapticd-left-state");
    const auto file = load_config("instance = \"right-2\"\n");
    EXPECT_EQ(file.code, -1) << file.message;
    EXPECT_EQ(file.options.serve_socket, "/run/test-instances/hapticd-right-2.sock");
    EXPECT_EQ(file.options.serve_shm, "/hapticd-right-2-state");
    const auto cli_over_file = load_config("instance = \"right\"\n", {"--instance", "left"});
    EXPECT_EQ(cli_over_file.options.serve_shm, "/hapticd-left-state");

    const auto given = load_config("", {"--instance", "left", "--serve-socket", "/tmp/x.sock", "--serve-shm", "/x"});
    EXPECT_EQ(given.code, -1) << given.message;
    EXPECT_EQ(given.options.serve_socket, "/tmp/x.sock");
    EXPECT_EQ(given.options.serve_shm, "/x");
    const auto given_in_file = load_config("serve-shm = \"/y\"\n", {"--instance", "left"});
    EXPECT_EQ(given_in_file.options.serve_shm, "/y");
    EXPECT_EQ(given_in_file.options.serve_socket, "/run/test-instances/hapticd-left.sock");

    ::unsetenv("RUNTIME_DIRECTORY");
    ::setenv("XDG_RUNTIME_DIR", "/run/user/test", 1);
    EXPECT_EQ(load_config("", {"--instance", "a"}).options.serve_socket, "/run/user/test/hapticd-a.sock");
    ::unsetenv("XDG_RUNTIME_DIR");
    EXPECT_EQ(load_config("", {"--instance", "a"}).options.serve_socket, "/run/hapticd/hapticd-a.sock");
    if (saved != nullptr) ::setenv("RUNTIME_DIRECTORY", saved_value.c_str(), 1);

    const std::string form = "1 to 32 characters of a-z, 0-9, '_' and '-', starting with a letter or a digit";
    for (const std::string& bad :
         std::vector<std::string>{"Left", "-left", "_x", "le/ft", "../x", "a.b", "left right", std::string(33, 'a')}) {
        SCOPED_TRACE(bad);
        const auto r = load_config("", {"--instance", bad});
        EXPECT_EQ(r.code, kExitInvalidParameter);
        EXPECT_CONTAINS(r.message, "instance = " + bad + " is invalid; accepted range: " + form);
    }
    EXPECT_EQ(load_config("", {"--instance", std::string(32, 'a')}).code, -1);
    EXPECT_EQ(load_config("", {"--instance", "0_a-b"}).code, -1);
    const auto bad_file = load_config("rate = 1000.0\ninstance = \"Left\"\n");
    EXPECT_EQ(bad_file.code, kExitInvalidParameter);
    EXPECT_CONTAINS(bad_file.message, "line 2, column 1: instance = Left is invalid; accepted range: " + form);
}

}  // namespace
}  // namespace hapticd
