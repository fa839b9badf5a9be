// SPDX-License-Identifier: Apache-2.0
// hapticopt plot: the paper's figures as SVG files (region: Fig. 3, costs: Fig. 4, step: Fig. 5,
// overshoot: Fig. 6; collision: step against collision optima; noise-pareto: cost against force noise per
// velocity estimator; both beyond the paper). Each figure is its own subcommand in plot_<name>.cpp.
#include <vector>

#include "commands.hpp"
#include "svg/svg_figure.hpp"

namespace hapticopt::cli {

CommandRunner add_plot_command(CLI::App& app) {
    CLI::App* plot = app.add_subcommand("plot", "write a figure of the paper as an SVG file (opens in a browser)");
    plot->require_subcommand(1);
    std::vector<std::pair<CLI::App*, CommandRunner>> figures;
    for (auto add : {add_plot_region, add_plot_costs, add_plot_step, add_plot_overshoot, add_plot_collision,
                     add_plot_noise_pareto}) {
        const std::size_t before = plot->get_subcommands({}).size();
        CommandRunner run = add(*plot);
        figures.emplace_back(plot->get_subcommands({})[before], std::move(run));
    }
    return [figures]() {
        for (const auto& [sub, run] : figures) {
            if (sub->parsed()) return run();
        }
        return int{2};
    };
}

}  // namespace hapticopt::cli
