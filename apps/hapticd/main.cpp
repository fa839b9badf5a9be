// SPDX-License-Identifier: Apache-2.0
// hapticd: renders a virtual wall at a fixed rate with optimally tuned K and B (see docs/hapticd.md).
#include "daemon/hapticd_main.hpp"

int main(int argc, char** argv) { return hapticd::hapticd_main(argc, argv); }
