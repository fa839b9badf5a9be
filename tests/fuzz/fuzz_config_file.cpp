// libFuzzer target: hapticd's strict TOML checker (src/config_file.*). The checker reads a path, so
// the input is written to a per-process temporary file first. Invariants: no crash, no exception
// other than std::bad_alloc/regex_error is expected (none is documented: any exception aborts), every
// issue carries a line number in [0, lines + 1] and a non-empty message.
#include <unistd.h>

#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <string>

#include "config/config_file.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    static const std::string path = [] {
        const char* dir = std::getenv("TMPDIR");
        return std::string(dir != nullptr && *dir != '\0' ? dir : "/tmp") + "/hapticd-fuzz-config-" +
               std::to_string(static_cast<long>(getpid())) + ".toml";
    }();
    std::FILE* f = std::fopen(path.c_str(), "wb");
    if (f == nullptr) std::abort();
    if (size > 0 && std::fwrite(data, 1, size, f) != size) std::abort();
    std::fclose(f);
    long lines = 1;
    for (std::size_t i = 0; i < size; ++i) lines += data[i] == '\n' ? 1 : 0;
    const auto issues = hapticd::check_config_file(path);
    for (const auto& issue : issues) {
        if (issue.line < 0 || issue.line > lines + 1 || issue.message.empty()) std::abort();
    }
    return 0;
}
