#include "config/config_file.hpp"

#include <cctype>
#include <fstream>
#include <regex>
#include <set>

namespace hapticd {

namespace {

// Scalar TOML values that hapticd uses.
const std::regex& scalar_re() {
    static const std::regex re(
        R"((?:"(?:[^"\\]|\\.)*")|(?:'[^']*')|(?:true|false)|)"
        R"((?:[+-]?(?:inf|nan))|)"
        R"((?:[+-]?(?:0|[1-9](?:_?[0-9])*)(?:\.[0-9](?:_?[0-9])*)?(?:[eE][+-]?[0-9](?:_?[0-9])*)?))");
    return re;
}

std::string trim(const std::string& s) {
    std::size_t b = 0;
    std::size_t e = s.size();
    while (b < e && std::isspace(static_cast<unsigned char>(s[b]))) ++b;
    while (e > b && std::isspace(static_cast<unsigned char>(s[e - 1]))) --e;
    return s.substr(b, e - b);
}

// Removes a trailing comment that is not inside a string.
std::string strip_comment(const std::string& s) {
    char quote = 0;
    for (std::size_t i = 0; i < s.size(); ++i) {
        const char c = s[i];
        if (quote != 0) {
            if (c == '\\' && quote == '"') {
                ++i;
            } else if (c == quote) {
                quote = 0;
            }
        } else if (c == '"' || c == '\'') {
            quote = c;
        } else if (c == '#') {
            return s.substr(0, i);
        }
    }
    return s;
}

// Splits the inside of an array at top-level commas (strings may contain commas).
bool split_array(const std::string& inner, std::vector<std::string>& items) {
    char quote = 0;
    std::string cur;
    for (std::size_t i = 0; i < inner.size(); ++i) {
        const char c = inner[i];
        if (quote != 0) {
            cur += c;
            if (c == '\\' && quote == '"' && i + 1 < inner.size()) {
                cur += inner[++i];
            } else if (c == quote) {
                quote = 0;
            }
        } else if (c == '"' || c == '\'') {
            quote = c;
            cur += c;
        } else if (c == ',') {
            items.push_back(trim(cur));
            cur.clear();
        } else {
            cur += c;
        }
    }
    if (quote != 0) return false;
    const std::string last = trim(cur);
    if (!last.empty()) items.push_back(last);  // a trailing comma is allowed
    return true;
}

bool valid_value(const std::string& v, std::string& why) {
    if (!v.empty() && v.front() == '[') {
        if (v.back() != ']') {
            why = "unterminated array";
            return false;
        }
        std::vector<std::string> items;
        if (!split_array(v.substr(1, v.size() - 2), items)) {
            why = "unterminated string in array";
            return false;
        }
        for (const auto& item : items) {
            if (item.empty() || !std::regex_match(item, scalar_re())) {
                why = "invalid array element '" + item + "'";
                return false;
            }
        }
        return true;
    }
    if (!std::regex_match(v, scalar_re())) {
        why = "invalid value '" + v + "' (expected a number, true/false, a quoted string or an array)";
        return false;
    }
    return true;
}

}  // namespace

std::vector<ConfigFileIssue> check_config_file(const std::string& path) {
    std::vector<ConfigFileIssue> issues;
    std::ifstream in(path);
    if (!in) {
        issues.push_back({0, "cannot open file"});
        return issues;
    }
    static const std::regex key_re(R"([A-Za-z0-9_-]+)");
    std::set<std::string> seen;
    std::string raw;
    int line_no = 0;
    while (std::getline(in, raw)) {
        ++line_no;
        const int start_line = line_no;
        std::string line = trim(strip_comment(raw));
        if (line.empty()) continue;
        if (line.front() == '[') {
            issues.push_back({line_no, "tables/sections ('" + line + "') are not used in hapticd files; "
                                       "write every key at the top level"});
            continue;
        }
        const auto eq = line.find('=');
        if (eq == std::string::npos) {
            issues.push_back({line_no, "expected 'key = value', got '" + line + "'"});
            continue;
        }
        const std::string key = trim(line.substr(0, eq));
        std::string value = trim(line.substr(eq + 1));
        if (!std::regex_match(key, key_re)) {
            issues.push_back({line_no, "invalid key '" + key + "' (bare keys: letters, digits, '-', '_')"});
            continue;
        }
        if (value.empty()) {
            issues.push_back({line_no, "missing value for key '" + key + "'"});
            continue;
        }
        if (value.front() == '[') {  // an array may continue on the following lines
            int depth_guard = 0;
            while (value.back() != ']' && std::getline(in, raw) && ++depth_guard < 10000) {
                ++line_no;
                value += " " + trim(strip_comment(raw));
                value = trim(value);
            }
        }
        std::string why;
        if (!valid_value(value, why)) {
            issues.push_back({start_line, "key '" + key + "': " + why});
            continue;
        }
        if (!seen.insert(key).second) {
            issues.push_back({start_line, "duplicate key '" + key + "'"});
        }
    }
    return issues;
}

}  // namespace hapticd
