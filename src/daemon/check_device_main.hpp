// SPDX-License-Identifier: Apache-2.0
// `hapticd check-device`: the command line of the force-sign check (devices/check_device.hpp, measure_force_sign).
#pragma once

namespace hapticd {

// argv[0] is "check-device". Returns the process exit code (daemon/exit_codes.hpp); never throws.
int check_device_main(int argc, const char* const* argv) noexcept;

}  // namespace hapticd
