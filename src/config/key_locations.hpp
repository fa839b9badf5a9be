// SPDX-License-Identifier: Apache-2.0
// Where the keys of a config or profile file were written, so that a value's range error can say
// "config file 'F', line 3, column 1: rate = -5 is invalid; accepted range: ...".
#pragma once

#include <map>
#include <string>

#include "config/config_file.hpp"

namespace hapticd {

class KeyLocations {
  public:
    KeyLocations() = default;  // no file: prefix() is always ""
    // file: what messages call the file ("device profile 'P'"). name_file_always: also prefix keys that
    // are not written in it with the file's name (a profile: each of its values is the file's or a default).
    KeyLocations(std::string file, bool name_file_always)
        : file_(std::move(file)), name_file_always_(name_file_always) {}

    void add(const std::string& key, FilePosition at) { positions_[key] = at; }
    void forget(const std::string& key) { positions_.erase(key); }  // e.g. overridden on the command line
    [[nodiscard]] const std::map<std::string, FilePosition>& positions() const { return positions_; }

    // "F, line 3, column 1: " for a key written in the file, "F: " (name_file_always) or "" otherwise.
    [[nodiscard]] std::string prefix(const std::string& key) const {
        const auto it = positions_.find(key);
        if (it != positions_.end()) {
            return file_ + ", line " + std::to_string(it->second.line) + ", column " +
                   std::to_string(it->second.column) + ": ";
        }
        return name_file_always_ ? file_ + ": " : "";
    }

  private:
    std::string file_;
    bool name_file_always_ = false;
    std::map<std::string, FilePosition> positions_;
};

}  // namespace hapticd
