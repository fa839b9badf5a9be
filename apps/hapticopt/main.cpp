// SPDX-License-Identifier: Apache-2.0
// hapticopt: stability, step-response costs and optimal virtual-wall gains from the command line.
#include <iostream>
#include <vector>

#include <hapticopt/errors.hpp>
#include <hapticopt/version.hpp>

#include "cli_output.hpp"
#include "commands.hpp"

int main(int argc, char** argv) {
    using namespace hapticopt::cli;
    CLI::App app{"hapticopt " HAPTICOPT_VERSION_STRING
                 ": optimal virtual-wall gains for sampled-data haptic rendering "
                 "(Hulin et al., IROS 2011). Normalised units unless physical options are given."};
    app.footer("Exit codes: 0 ok, 2 usage error, 3 invalid parameter value, 4 computation failed.");
    app.require_subcommand(1);
    app.set_version_flag("--version", HAPTICOPT_VERSION_STRING);
    std::vector<std::pair<CLI::App*, CommandRunner>> commands;
    for (auto add : {add_cost_command, add_optimum_command, add_boundary_command, add_table_command,
                     add_limit_cycle_command, add_plot_command}) {
        const std::size_t before = app.get_subcommands({}).size();
        CommandRunner run = add(app);
        commands.emplace_back(app.get_subcommands({})[before], std::move(run));
    }
    try {
        app.parse(argc, argv);
    } catch (const CLI::Success& e) {
        return app.exit(e);
    } catch (const CLI::ParseError& e) {
        app.exit(e);
        return kUsage;
    }
    try {
        for (auto& [sub, run] : commands) {
            if (sub->parsed()) return run();
        }
    } catch (const hapticopt::InvalidParameter& e) {
        std::cerr << "hapticopt: " << e.what() << '\n';
        return kInvalidParameter;
    } catch (const std::exception& e) {
        std::cerr << "hapticopt: computation failed: " << e.what() << '\n';
        return kComputationFailed;
    }
    return kUsage;
}
