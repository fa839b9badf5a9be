// SPDX-License-Identifier: Apache-2.0
#include "daemon/experiment_main.hpp"

#include <CLI/CLI.hpp>

#include <cmath>
#include <iostream>
#include <limits>
#include <memory>
#include <sstream>

#include "devices/device_factory.hpp"
#include "daemon/exit_codes.hpp"
#include "experiment/experiment_run.hpp"
#include "config/options.hpp"
#include "common/stop_flag.hpp"

namespace hapticd {

using namespace experiment;  // this file is the command line of the experiment namespace

namespace {

// "MIN:MAX:N" -> N values from MIN to MAX (N >= 2; N = 1: MIN).
std::vector<double> parse_range(const std::string& option, const std::string& text) {
    std::vector<double> parts;
    std::size_t begin = 0;
    for (int i = 0; i < 3; ++i) {
        const std::size_t end = i < 2 ? text.find(':', begin) : text.size();
        if (end == std::string::npos) break;
        const std::string field = text.substr(begin, end - begin);
        std::size_t used = 0;
        double v = 0.0;
        try {
            v = std::stod(field, &used);
        } catch (const std::exception&) {
            used = 0;
        }
        if (used == 0 || used != field.size()) break;
        parts.push_back(v);
        begin = end + 1;
    }
    if (parts.size() != 3 || parts[2] != std::floor(parts[2])) {
        throw StartupError(ErrorKind::Usage,
                           option + " = '" + text + "' is invalid; accepted: MIN:MAX:N (numbers, N an integer)");
    }
    require(std::isfinite(parts[0]) && std::isfinite(parts[1]) && parts[1] >= parts[0], option + " MAX", parts[1],
            "MIN <= MAX, finite");
    require(parts[2] >= 1 && parts[2] <= 10000, option + " N", parts[2], "1 <= N <= 10000");
    const auto n = static_cast<int>(parts[2]);
    std::vector<double> out;
    for (int i = 0; i < n; ++i) out.push_back(n == 1 ? parts[0] : parts[0] + (parts[1] - parts[0]) * i / (n - 1));
    return out;
}

void add_common(CLI::App& app, ExperimentOptions& o) {
    app.add_option("--device", o.device, "Device profile name or .toml path (default sim)");
    app.add_flag("--simulate", o.simulate, "Simulate the profile's physics even when its driver is a real device");
    app.add_option("--rate", o.rate, "Loop rate, Hz (default 1000)");
    app.add_option("--delay-buffer", o.delay_buffer, "Extra delay of the wall force, samples (default 0)");
    app.add_option("--axis", o.axis, "Device axis of the wall (default 0)");
    app.add_option("--step-force", o.step_force,
                   "Step input F through the actuator, N (default: min(5 % max_force, force-cap/10))");
    app.add_option("--force-cap", o.force_cap,
                   "Force limit: above it a trial counts as unstable, N (default 50 % max_force)");
    app.add_option("--position-limit", o.position_limit,
                   "Position limit about the trial's start: beyond it a trial counts as unstable, m (default 0.01)");
    app.add_option("--settle", o.settle, "Return phase + zero force between trials, s (default 0.5)");
    app.add_option("--trial-time", o.trial_time, "Length of one trial, s (default boundary 2, optimal 3)");
    app.add_option("--window", o.window, "Energy window of the instability detection, ticks (default 100)");
    app.add_option("--growth", o.growth, "Window energy ratio counted as growth (default 1.05)");
    app.add_option("--consecutive", o.consecutive, "Windows of growth in a row that mean unstable (default 3)");
    app.add_option("--energy-cap", o.energy_cap, "Window energy above this many times W E(0): unstable (default 100)");
    app.add_option("--out-dir", o.out_dir, "Directory of the CSV and SVG files (default .)");
    app.add_flag("--quiet", o.quiet, "No progress display and no summary (errors only)");
}

}  // namespace

int experiment_main(int argc, const char* const* argv) noexcept {
    clear_stop_request();
    try {
        ExperimentOptions o;
        CLI::App app{
            "hapticd experiment: the stability boundary and the optimal curves measured on the device "
            "(Hulin et al., IROS 2011, Sect. V); see docs/experiments.md",
            "hapticd experiment"};
        app.footer(kExitCodeHelp);
        app.require_subcommand(1);
        CLI::App* b = app.add_subcommand("boundary", "For each B raise K until the loop is unstable, then bisect");
        CLI::App* p =
            app.add_subcommand("optimal", "For each K a grid of B: step responses, C_E0..2 and C_OV, optimal B");
        add_common(*b, o);
        add_common(*p, o);
        b->add_option("--b-values", o.b_values, "Damping values B, N s/m");
        b->add_option("--b-range", o.b_range,
                      "Damping values MIN:MAX:N, N s/m (default 8 values over 10-90 % of the analysed B range)");
        b->add_option("--k-min", o.k_min, "First K, N/m (default: k-step)");
        b->add_option("--k-max", o.k_max, "Last K of the steps, N/m (default 2 x analysed K_max)");
        b->add_option("--k-step", o.k_step, "K step, N/m (default analysed K_max / 20)");
        b->add_option("--k-resolution", o.k_resolution, "Bisection down to this K interval, N/m (default k-step / 64)");
        p->add_option("--k-values", o.k_values, "Stiffness values K, N/m");
        p->add_option("--k-range", o.k_range,
                      "Stiffness values MIN:MAX:N, N/m (default 5 values over 10-80 % of analysed K_max)");
        p->add_option("--b-points", o.b_points, "B values per K across the analysed stable interval (default 11)");
        p->add_option("--b-margin", o.b_margin, "Fraction of the stable B interval left out at each end (default 0.1)");
        p->add_option("--overshoot-tol", o.overshoot_tol, "C_OV at most this counts as no overshoot (default 1e-6)");
        try {
            app.parse(argc, argv);
        } catch (const CLI::CallForHelp&) {
            std::cout << app.help();
            return kExitOk;
        } catch (const CLI::CallForAllHelp&) {
            std::cout << app.help("", CLI::AppFormatMode::All);
            return kExitOk;
        } catch (const CLI::ParseError& e) {
            std::cerr << "hapticd experiment: error: " << e.what() << "\n";
            return kExitUsage;
        }
        if (!o.b_range.empty() && !o.b_values.empty()) {
            throw StartupError(ErrorKind::Usage, "--b-values and --b-range are exclusive; give one of them");
        }
        if (!o.k_range.empty() && !o.k_values.empty()) {
            throw StartupError(ErrorKind::Usage, "--k-values and --k-range are exclusive; give one of them");
        }
        BoundarySettings bs;
        OptimalSettings os;
        if (!o.b_range.empty())
            bs.b_values = parse_range("--b-range", o.b_range);
        else
            bs.b_values = o.b_values;
        if (!o.k_range.empty())
            os.k_values = parse_range("--k-range", o.k_range);
        else
            os.k_values = o.k_values;
        return exit_code(run_experiment(o, b->parsed(), std::move(bs), std::move(os)));
    } catch (const StartupError& e) {
        if (e.what()[0] != '\0') std::cerr << "hapticd experiment: error: " << e.what() << "\n";
        return exit_code(e.kind());
    } catch (const std::exception& e) {
        std::cerr << "hapticd experiment: internal error: " << e.what() << "\n";
        return kExitInternal;
    } catch (...) {
        std::cerr << "hapticd experiment: internal error (unknown exception)\n";
        return kExitInternal;
    }
}

}  // namespace hapticd
