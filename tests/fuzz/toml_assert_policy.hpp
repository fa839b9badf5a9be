// SPDX-License-Identifier: Apache-2.0
// Force-included (clang -include) into the config_file target by scripts/fuzz.sh, before toml++. toml++ 3.3.0
// (Debian 12's) has debug-only assertions that malformed input reaches: "[&" or "[\0" enters parse_key()
// with a character that cannot start a key (upstream issue #294, fixed by pull request #301), a NUL inside
// a date-time enters parse_time() on a non-digit, and more of that kind. Debian's release build of the
// library compiles them out (NDEBUG; GCC 12 has no __builtin_assume to make them assumptions) and the
// parser then reports an ordinary parse error. So that fuzzing tests the code as it ships, an assertion here
// is printed once per distinct expression (in build/fuzz/fuzz_config_file.log) and does not abort;
// ASan and UBSan findings still do. The replay test runs the seeds corpus/config_file/toml_issue_*.toml, and
// test_config_file.cpp checks their parse errors.
#pragma once

#include <cstdio>
#include <set>
#include <string>

namespace hapticd_fuzz {

inline void toml_assert_failed(const char* expression, const char* file, int line) {
    static std::set<std::string> seen;
    if (seen.insert(expression).second) {
        std::fprintf(stderr, "%s:%d: toml++ debug assertion not met (compiled out in the shipped library): %s\n", file,
                     line, expression);
    }
}

}  // namespace hapticd_fuzz

#define TOML_ASSERT(expr) \
    ((expr) ? static_cast<void>(0) : ::hapticd_fuzz::toml_assert_failed(#expr, __FILE__, __LINE__))
