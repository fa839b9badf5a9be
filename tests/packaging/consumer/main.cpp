// SPDX-License-Identifier: Apache-2.0
// Outside consumer of the installed hapticopt package (see CMakeLists.txt).
#include <hapticopt/hapticopt.hpp>
#include <hapticopt/version.hpp>

#include <cstdio>

int main() {
    std::printf("hapticopt %s\n", HAPTICOPT_VERSION_STRING);
    return 0;
}
