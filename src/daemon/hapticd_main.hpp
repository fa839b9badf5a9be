// SPDX-License-Identifier: Apache-2.0
// The whole hapticd program (apps/hapticd/main.cpp only calls this; tests call it in-process too).
#pragma once

namespace hapticd {

// Returns the process exit code (common/exit_codes.hpp). Never throws.
int hapticd_main(int argc, const char* const* argv) noexcept;

}  // namespace hapticd
