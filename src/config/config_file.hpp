// Strict syntax check of hapticd's TOML files (config and device profiles) before CLI11 reads them.
// CLI11's config reader is lenient (a stray word becomes a flag, "1, 2" an array, duplicates append);
// this check makes malformed files an error with a line number. Accepted: comments, blank lines,
// `key = value` with a bare key ([A-Za-z0-9_-]+) and a value that is a basic or literal string, an
// integer, a float (incl. inf/nan, which the range checks then reject), a boolean, or an array of those
// (may span lines). Tables ([section]) are not used by hapticd and are rejected; so are duplicate keys.
#pragma once

#include <string>
#include <vector>

namespace hapticd {

struct ConfigFileIssue {
    int line = 0;
    std::string message;
};

// Returns the issues found (empty: well-formed). Reading errors are reported as an issue at line 0.
std::vector<ConfigFileIssue> check_config_file(const std::string& path);

}  // namespace hapticd
