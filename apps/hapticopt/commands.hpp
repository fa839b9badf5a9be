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
CommandRunner add_limit_cycle_command(CLI::App& app);  // limit_cycle_command.cpp
CommandRunner add_plot_command(CLI::App& app);         // plot_command.cpp: SVG figures

// The plot subcommands (plot_region.cpp, plot_costs.cpp, plot_step.cpp, plot_overshoot.cpp,
// plot_collision.cpp, plot_noise_pareto.cpp), grouped under `hapticopt plot` by plot_command.cpp.
CommandRunner add_plot_region(CLI::App& plot);
CommandRunner add_plot_costs(CLI::App& plot);
CommandRunner add_plot_step(CLI::App& plot);
CommandRunner add_plot_overshoot(CLI::App& plot);
CommandRunner add_plot_collision(CLI::App& plot);
CommandRunner add_plot_noise_pareto(CLI::App& plot);

}  // namespace hapticopt::cli
