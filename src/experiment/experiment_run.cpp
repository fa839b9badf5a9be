// SPDX-License-Identifier: Apache-2.0
#include "experiment/experiment_run.hpp"

#include <cmath>
#include <cstdio>
#include <iostream>
#include <memory>
#include <sstream>

#include <hapticopt/errors.hpp>

#include "devices/device_factory.hpp"
#include "experiment/experiment_output.hpp"
#include "config/options.hpp"
#include "common/stop_flag.hpp"

namespace hapticd::experiment {

void require(bool ok, const std::string& name, double value, const std::string& range) {
    if (ok && !std::isnan(value)) return;
    std::ostringstream s;
    s << name << " = " << value << " is invalid; accepted range: " << range;
    throw StartupError(ErrorKind::InvalidParameter, s.str());
}

namespace {

std::string g(double v) {
    char b[48];
    std::snprintf(b, sizeof b, "%.6g", v);
    return b;
}

struct DeviceCloser {
    Device* device = nullptr;
    ~DeviceCloser() {
        if (device != nullptr) device->close();
    }
};

// Every parameter that does not depend on the analysis.
void validate_common(const ExperimentOptions& o, const DeviceProfile& p) {
    require(std::isfinite(o.rate) && o.rate >= 1.0 && o.rate <= 100000.0, "--rate", o.rate, "1 <= rate <= 100000 Hz");
    require(o.delay_buffer >= 0 && o.delay_buffer <= 10000, "--delay-buffer", static_cast<double>(o.delay_buffer),
            "0 .. 10000 samples");
    require(o.axis >= 0 && o.axis < p.axes, "--axis", static_cast<double>(o.axis),
            "0 .. " + std::to_string(p.axes - 1) + " (device axes)");
    require(std::isfinite(o.position_limit) && o.position_limit > 0.0 && o.position_limit <= 1.0, "--position-limit",
            o.position_limit, "0 < limit <= 1 m");
    require(std::isfinite(o.settle) && o.settle >= 0.05 && o.settle <= 60.0, "--settle", o.settle,
            "0.05 <= settle <= 60 s");
    require(o.window >= 10 && o.window <= 100000, "--window", static_cast<double>(o.window), "10 .. 100000 ticks");
    require(std::isfinite(o.growth) && o.growth > 1.0 && o.growth <= 100.0, "--growth", o.growth, "1 < growth <= 100");
    require(o.consecutive >= 1 && o.consecutive <= 100, "--consecutive", static_cast<double>(o.consecutive),
            "1 .. 100");
    require(std::isfinite(o.energy_cap) && o.energy_cap > 1.0 && o.energy_cap <= 1e12, "--energy-cap", o.energy_cap,
            "1 < cap <= 1e12");
    require(o.force_cap == 0.0 || (std::isfinite(o.force_cap) && o.force_cap > 0.0 && o.force_cap <= p.max_force),
            "--force-cap", o.force_cap, "0 < cap <= max_force = " + g(p.max_force) + " N");
    require(o.trial_time == 0.0 || (std::isfinite(o.trial_time) && o.trial_time > 0.0 && o.trial_time <= 600.0),
            "--trial-time", o.trial_time, "0 < time <= 600 s");
}

}  // namespace

ErrorKind run_experiment(const ExperimentOptions& o, bool boundary, BoundarySettings bs, OptimalSettings os) {
    Options device_options;
    device_options.device = o.device;
    device_options.simulate = o.simulate;
    device_options.quiet = o.quiet;
    const DeviceProfile profile = load_device_profile(device_options);
    validate_common(o, profile);
    // The wall acts along axis o.axis: its loop's mass is 1 / (M^-1)_aa (the profile's one mass when isotropic).
    const double mass = profile.mass_model.of_axis(static_cast<std::size_t>(o.axis));
    const bool simulated = o.simulate || profile.driver == "sim";
    const double T = 1.0 / o.rate;
    const double delay = profile.inherent_delay + static_cast<double>(o.delay_buffer) * T;
    std::unique_ptr<Theory> theory;
    try {
        theory = std::make_unique<Theory>(TheoryPlant{mass, profile.damping, profile.stiffness, T, delay});
    } catch (const hapticopt::InvalidParameter& e) {
        throw StartupError(ErrorKind::InvalidParameter, e.what());
    }
    const double k_max_theory = theory->max_stiffness();
    const auto [b_lo_theory, b_hi_theory] = theory->damping_extent();

    // Limits and the step.
    const double force_cap = o.force_cap > 0.0 ? o.force_cap : 0.5 * profile.max_force;
    const double step_force = o.step_force != 0.0 ? o.step_force : std::min(0.05 * profile.max_force, force_cap / 10.0);
    require(std::isfinite(step_force) && step_force > 0.0 && step_force <= force_cap / 2.0, "--step-force", step_force,
            "0 < F <= force-cap / 2 = " + g(force_cap / 2.0) + " N");
    const double trial_time = o.trial_time > 0.0 ? o.trial_time : (boundary ? 2.0 : 3.0);
    const auto trial_ticks = static_cast<std::size_t>(std::llround(trial_time * o.rate));
    const auto min_ticks = static_cast<std::size_t>(o.window * (o.consecutive + 2));
    require(trial_ticks >= min_ticks && trial_ticks <= 10'000'000, "--trial-time", trial_time,
            g(static_cast<double>(min_ticks) / o.rate) + " s (window x (consecutive + 2) ticks) .. 10^7 ticks");

    if (boundary) {
        if (bs.b_values.empty()) {
            for (int i = 0; i < 8; ++i)
                bs.b_values.push_back(b_lo_theory + (b_hi_theory - b_lo_theory) * (0.1 + 0.8 * i / 7.0));
        }
        for (const double B : bs.b_values)
            require(std::isfinite(B) && B >= 0.0 && B <= 1e9, "--b-values/--b-range value", B, "0 <= B <= 1e9 N s/m");
        bs.k_step = o.k_step != 0.0 ? o.k_step : k_max_theory / 20.0;
        require(std::isfinite(bs.k_step) && bs.k_step > 0.0, "--k-step", bs.k_step, "k-step > 0 N/m");
        bs.k_min = o.k_min != 0.0 ? o.k_min : bs.k_step;
        bs.k_max = o.k_max != 0.0 ? o.k_max : 2.0 * k_max_theory;
        bs.k_resolution = o.k_resolution != 0.0 ? o.k_resolution : bs.k_step / 64.0;
        require(std::isfinite(bs.k_min) && bs.k_min > 0.0, "--k-min", bs.k_min, "k-min > 0 N/m");
        require(std::isfinite(bs.k_max) && bs.k_max >= bs.k_min && bs.k_max <= 1e12, "--k-max", bs.k_max,
                "k-min = " + g(bs.k_min) + " <= k-max <= 1e12 N/m");
        require((bs.k_max - bs.k_min) / bs.k_step <= 100000, "--k-step", bs.k_step, ">= (k-max - k-min) / 100000 N/m");
        require(std::isfinite(bs.k_resolution) && bs.k_resolution > 0.0 && bs.k_resolution <= bs.k_step,
                "--k-resolution", bs.k_resolution, "0 < resolution <= k-step = " + g(bs.k_step) + " N/m");
    } else {
        if (os.k_values.empty()) {
            for (int i = 0; i < 5; ++i) os.k_values.push_back(k_max_theory * (0.1 + 0.7 * i / 4.0));
        }
        for (const double K : os.k_values) {
            require(std::isfinite(K) && K > 0.0 && K < k_max_theory, "--k-values/--k-range value", K,
                    "0 < K < analysed K_max = " + g(k_max_theory) + " N/m");
        }
        require(o.b_points >= 3 && o.b_points <= 1000, "--b-points", static_cast<double>(o.b_points), "3 .. 1000");
        require(std::isfinite(o.b_margin) && o.b_margin >= 0.0 && o.b_margin <= 0.45, "--b-margin", o.b_margin,
                "0 <= margin <= 0.45");
        require(std::isfinite(o.overshoot_tol) && o.overshoot_tol > 0.0 && o.overshoot_tol <= 1.0, "--overshoot-tol",
                o.overshoot_tol, "0 < tol <= 1");
        os.b_points = static_cast<int>(o.b_points);
        os.b_margin = o.b_margin;
        os.overshoot_tolerance = o.overshoot_tol;
    }

    ExperimentSetup setup;
    TrialSettings& t = setup.trial;
    t.axis = static_cast<std::size_t>(o.axis);
    t.period = T;
    t.delay_buffer = static_cast<std::size_t>(o.delay_buffer);
    t.mass = mass;
    t.stiffness = profile.stiffness;
    t.step_force = step_force;
    t.ticks = trial_ticks;
    t.detection =
        DetectionSettings{static_cast<std::size_t>(o.window), o.growth, static_cast<int>(o.consecutive), o.energy_cap};
    t.force_cap = force_cap;
    t.position_limit = o.position_limit;
    const auto [K_return, B_return] = theory->ce2_optimum();
    SettleSettings& st = setup.settle;
    st.axis = t.axis;
    st.period = T;
    st.delay_buffer = t.delay_buffer;
    st.K = K_return;
    st.B = B_return;
    const auto settle_ticks = static_cast<std::size_t>(std::llround(o.settle * o.rate));
    st.zero_ticks = std::max<std::size_t>(1, settle_ticks / 5);
    st.ticks = settle_ticks - st.zero_ticks;
    st.force_cap = force_cap;
    st.position_limit = 2.0 * o.position_limit;
    setup.model = CostModel{mass, profile.damping, profile.stiffness, T, profile.inherent_delay};

    // The device: external force zero (the step is applied through the actuator), spring rest at 0.
    SimScenario scenario;
    scenario.kind = Scenario::Step;
    scenario.axis = t.axis;
    scenario.step_force = 0.0;
    Options device_run_options = device_options;
    device_run_options.rate = o.rate;
    std::unique_ptr<Device> device = make_device(profile, device_run_options, scenario, T);
    install_stop_signal_handlers();
    DeviceCloser closer;
    if (device->open() != DeviceStatus::Ok) {
        throw StartupError(ErrorKind::Device, "device '" + profile.name + "': open failed: " + device->last_error());
    }
    closer.device = device.get();
    if (device->home() != DeviceStatus::Ok) {
        throw StartupError(ErrorKind::Device, "device '" + profile.name + "': homing failed: " + device->last_error());
    }
    const FigureCaption caption{"m = " + g(mass) + " kg, T = " + g(T * 1e3) + " ms, t_d = " + g(delay * 1e3) +
                                " ms, k = " + g(profile.stiffness) + " N/m, b = " + g(profile.damping) + " N s/m"};
    if (!o.quiet) {
        std::cout << "hapticd experiment " << (boundary ? "boundary" : "optimal") << ": device '" << profile.name << "'"
                  << (simulated ? " (simulated, lockstep)" : "") << ", " << caption.text
                  << "; step F = " << g(step_force) << " N, force cap " << g(force_cap) << " N, position limit "
                  << g(o.position_limit) << " m; analysed K_max = " << g(k_max_theory)
                  << " N/m; return gains K = " << g(K_return) << " N/m, B = " << g(B_return) << " N s/m" << std::endl;
    }
    const std::int64_t period_ns = std::llround(1e9 / o.rate);
    TrialRunner runner(*device, period_ns, simulated);
    st.home = runner.read_position(t.axis);
    if (!std::isfinite(st.home)) {
        throw StartupError(ErrorKind::Device,
                           "device '" + profile.name + "': reading the start position failed: " + device->last_error());
    }
    Progress progress(std::cerr, Progress::stderr_is_terminal(), o.quiet);

    Abort abort;
    std::vector<std::string> files;
    std::ostringstream summary;
    try {
        if (boundary) {
            const BoundaryResult r = run_boundary(runner, setup, bs, *theory, progress);
            abort = r.abort;
            device->close();
            closer.device = nullptr;
            files = write_boundary_outputs(o.out_dir, r, *theory, caption);
            for (const auto& p : r.points) {
                summary << "B = " << g(p.B) << " N s/m: K boundary measured " << g(p.K_boundary) << " N/m (stable "
                        << g(p.K_last_stable) << ", unstable " << g(p.K_first_unstable) << "), analysis "
                        << g(p.K_theory) << " N/m, " << p.trials << " trials\n";
            }
        } else {
            const OptimalResult r = run_optimal(runner, setup, os, *theory, progress);
            abort = r.abort;
            device->close();
            closer.device = nullptr;
            files = write_optimal_outputs(o.out_dir, r, os, *theory, caption);
            for (const auto& p : r.points) {
                summary << "K = " << g(p.K) << " N/m, " << p.criterion_name() << ": optimal B measured "
                        << g(p.B_refined) << (p.on_edge ? " (grid edge)" : "") << " N s/m, analysis " << g(p.B_theory)
                        << " N s/m (grid step " << g(p.b_step) << ")\n";
            }
        }
    } catch (const std::runtime_error& e) {
        throw StartupError(ErrorKind::Usage, std::string("--out-dir: ") + e.what());
    }
    if (!o.quiet) {
        std::cout << summary.str();
        for (const auto& f : files) std::cout << "wrote " << f << "\n";
    }
    switch (abort.outcome) {
        case TrialOutcome::Stable:
            return ErrorKind::Ok;
        case TrialOutcome::Stopped:
            std::cerr << "hapticd experiment: " << abort.detail << "; partial results written\n";
            return ErrorKind::Ok;
        case TrialOutcome::DeviceFault:  // as the daemon: a device error during the run is exit 6
            std::cerr << "hapticd experiment: error: " << abort.detail << "; partial results written\n";
            return ErrorKind::Device;
        default:
            std::cerr << "hapticd experiment: error: " << abort.detail << "; partial results written\n";
            return ErrorKind::RunFault;
    }
}

}  // namespace hapticd::experiment
