// SPDX-License-Identifier: Apache-2.0
// The hapticopt subcommands; each registers itself on the app and runs when selected.
#pragma once

#include <CLI/CLI.hpp>
#include <functional>

namespace hapticopt::cli {

/// Registers a subcommand; the returned function runs it (after parsing) and returns the exit code.
using CommandRunner = std::function<int()>;

CommandRunner add_cost_command(CLI::App& app);
CommandRunner add_optimum_command(CLI::App& app);
CommandRunner add_boundary_command(CLI::App& app);
CommandRunner add_table_command(CLI::App& app);
CommandRunner add_plot_command(CLI::App& app);  // plot_command.cpp: SVG figures

}  // namespace hapticopt::cli
