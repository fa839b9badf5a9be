// SPDX-License-Identifier: Apache-2.0
// Corpus-replay driver for the fuzz targets when built without libFuzzer (GCC, the normal ctest run):
// runs LLVMFuzzerTestOneInput once on every file of the directories or files named on the command
// line. A target aborts on a violated invariant, so a failing input fails the test.
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <vector>

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size);

int main(int argc, char** argv) {
    namespace fs = std::filesystem;
    std::size_t files = 0;
    auto run = [&](const fs::path& p) {
        std::ifstream in(p, std::ios::binary);
        const std::vector<char> bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
        std::vector<std::uint8_t> buf(bytes.begin(), bytes.end());  // exact size, like libFuzzer
        LLVMFuzzerTestOneInput(buf.data(), buf.size());
        ++files;
    };
    for (int i = 1; i < argc; ++i) {
        const fs::path arg(argv[i]);
        if (fs::is_directory(arg)) {
            for (const auto& e : fs::recursive_directory_iterator(arg))
                if (e.is_regular_file()) run(e.path());
        } else {
            run(arg);
        }
    }
    std::printf("replayed %zu inputs\n", files);
    return files > 0 ? 0 : 1;
}
