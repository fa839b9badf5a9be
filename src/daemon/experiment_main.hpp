// SPDX-License-Identifier: Apache-2.0
// `hapticd experiment boundary|optimal ...`: the paper's Sect. V experiments (docs/experiments.md).
#pragma once

namespace hapticd {

// argv[0] is "experiment". Returns the process exit code (common/exit_codes.hpp); never throws.
int experiment_main(int argc, const char* const* argv) noexcept;

}  // namespace hapticd
