// SPDX-License-Identifier: Apache-2.0
// The error start-up code throws: what() is the message the user sees, code() the exit code (common/exit_codes.hpp)
// of its kind.
#pragma once

#include <stdexcept>
#include <string>

#include "common/exit_codes.hpp"

namespace hapticd {

// An error that ends the program with `code` after printing what().
class StartupError : public std::runtime_error {
public:
    StartupError(int code, const std::string& message) : std::runtime_error(message), code_(code) {}
    [[nodiscard]] int code() const noexcept { return code_; }

private:
    int code_;
};

}  // namespace hapticd
