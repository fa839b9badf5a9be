// SPDX-License-Identifier: Apache-2.0
// Paths a test reaches at run time (the daemon, the clients, the repository's config/ and data files), resolved
// from the directory of the running test program. hapticopt_test_paths() in tests/CMakeLists.txt defines each
// path macro (HAPTICD_BINARY, HAPTICOPT_TEST_DATA_DIR, ...) as a call of path_from_test_program() with the path
// relative to the program: the compile command is then the same in every checkout of the repository, so the
// compiler cache serves one checkout's objects to another (an absolute path in a definition would differ).
#pragma once

#include <filesystem>
#include <string>

namespace hapticd::test {

/// `relative` (a path relative to the directory of this test program, as hapticopt_test_paths() wrote it)
/// resolved against that directory (/proc/self/exe's); lexically normal, absolute.
inline std::string path_from_test_program(const char* relative) {
    static const std::filesystem::path program_directory =
        std::filesystem::read_symlink("/proc/self/exe").parent_path();
    return (program_directory / relative).lexically_normal().string();
}

}  // namespace hapticd::test
