// SPDX-License-Identifier: Apache-2.0
// hapticd's entry (hapticd_main.hpp): the subcommands, --replay, or the run (run.hpp); a StartupError becomes its
// exit code (exit_codes.hpp).
#include "daemon/hapticd_main.hpp"

#include <exception>
#include <iostream>
#include <string_view>

#include "common/startup_error.hpp"
#include "common/stop_flag.hpp"
#include "daemon/check_device_main.hpp"
#include "daemon/exit_codes.hpp"
#include "daemon/experiment_main.hpp"
#include "daemon/replay_main.hpp"
#include "daemon/run.hpp"

namespace hapticd {

int hapticd_main(int argc, const char* const* argv) noexcept {
    // `hapticd experiment boundary|optimal ...`: the Sect. V experiments (docs/experiments.md).
    if (argc > 1 && std::string_view(argv[1]) == "experiment") return experiment_main(argc - 1, argv + 1);
    // `hapticd check-device`: the measured force sign, before the first real run (docs/devices.md).
    if (argc > 1 && std::string_view(argv[1]) == "check-device") return check_device_main(argc - 1, argv + 1);
    clear_stop_request();
    try {
        for (int i = 1; i < argc; ++i) {
            const std::string_view a = argv[i];
            if (a == "--replay" || a.starts_with("--replay=")) return replay_main(argc, argv);
        }
        return run_main(argc, argv);
    } catch (const StartupError& e) {
        if (e.what()[0] != '\0') std::cerr << "hapticd: error: " << e.what() << "\n";
        return exit_code(e.kind());
    } catch (const std::exception& e) {
        std::cerr << "hapticd: internal error: " << e.what() << "\n";
        return kExitInternal;
    } catch (...) {
        std::cerr << "hapticd: internal error (unknown exception)\n";
        return kExitInternal;
    }
}

}  // namespace hapticd
