// SPDX-License-Identifier: Apache-2.0
#include "daemon/check_device_main.hpp"

#include <CLI/CLI.hpp>

#include <cmath>
#include <iostream>
#include <memory>
#include <sstream>

#include "common/stop_flag.hpp"
#include "config/options.hpp"
#include "daemon/exit_codes.hpp"
#include "devices/check_device.hpp"
#include "devices/device_factory.hpp"
#include "devices/first_run.hpp"
#include "devices/sim_device.hpp"

namespace hapticd {

namespace {

void require_range(bool ok, const std::string& name, double value, const std::string& range) {
    if (!ok)
        throw StartupError(ErrorKind::InvalidParameter,
                           name + " = " + std::to_string(value) + " is invalid; accepted range: " + range);
}

}  // namespace

int check_device_main(int argc, const char* const* argv) noexcept {
    clear_stop_request();
    try {
        Options o;
        double push_force = NAN;
        double push_time = 0.05;
        CLI::App app{
            "hapticd check-device: push the device gently along each axis and report the measured force sign "
            "(docs/devices.md, \"First run\")",
            "hapticd check-device"};
        app.footer(kExitCodeHelp);
        app.add_option("--device", o.device, "Device profile name or .toml path (default sim)");
        app.add_flag("--simulate", o.simulate, "Simulate the profile's physics even when its driver is a real device");
        app.add_option("--rate", o.rate, "Loop rate, Hz (default 1000)");
        app.add_option("--push-force", push_force, "Push force, N (N m) (default: min(0.5, 10 % of max_force))");
        app.add_option("--push-time", push_time, "Length t of the +F phase of the +F, -F, +F push, s (default 0.05)");
        app.add_flag("--quiet", o.quiet, "Print only the result line per axis");
        try {
            app.parse(argc, argv);
        } catch (const CLI::CallForHelp&) {
            std::cout << app.help();
            return kExitOk;
        } catch (const CLI::ParseError& e) {
            std::cerr << "hapticd check-device: error: " << e.what() << "\n";
            return kExitUsage;
        }
        const DeviceProfile profile = load_device_profile(o);
        require_range(std::isfinite(o.rate) && o.rate >= 10 && o.rate <= 20000, "--rate", o.rate, "10 .. 20000 Hz");
        require_range(std::isfinite(push_time) && push_time >= 0.005 && push_time <= 1.0, "--push-time", push_time,
                      "0.005 .. 1 s");
        const double T = 1.0 / o.rate;
        SimScenario scenario;
        scenario.kind = Scenario::Step;
        scenario.step_force = 0.0;  // no simulated hand: only the push moves the handle
        std::unique_ptr<Device> device = make_device(profile, o, scenario, T);
        const double max_force = device->capabilities().max_force;
        if (std::isnan(push_force)) push_force = std::min(0.5, 0.1 * max_force);
        require_range(std::isfinite(push_force) && push_force > 0 && push_force <= max_force, "--push-force",
                      push_force, "0 < F <= max_force (" + std::to_string(max_force) + ")");
        install_stop_signal_handlers();
        if (device->open() != DeviceStatus::Ok) {
            throw StartupError(ErrorKind::Device,
                               "device '" + profile.name + "': open failed: " + device->last_error());
        }
        if (device->home() != DeviceStatus::Ok) {
            const std::string e = device->last_error();
            device->close();
            throw StartupError(ErrorKind::Device, "device '" + profile.name + "': homing failed: " + e);
        }
        if (!o.quiet) {
            std::cout << "hapticd check-device: device '" << profile.name
                      << "': hold the handle loosely (or let go); pushing " << push_force
                      << (profile.rotary ? " N m" : " N") << " along each axis (+F " << push_time * 1e3 << " ms, -F "
                      << 2 * push_time * 1e3 << " ms, +F " << push_time * 1e3 << " ms)" << std::endl;
        }
        ForceSignSettings s;
        s.push_force = push_force;
        s.push_time = push_time;
        s.period = T;
        s.lockstep = profile.driver == "sim" || o.simulate;
        const ForceSignResult r = measure_force_sign(*device, s);
        device->close();
        if (!r.ok) {
            throw StartupError(r.status == DeviceStatus::Ok ? ErrorKind::RunFault : ErrorKind::Device,
                               "device '" + profile.name + "': " + r.message);
        }
        bool all_positive = true;
        std::ostringstream details;
        const char* unit = profile.rotary ? " rad" : " m";
        for (std::size_t a = 0; a < r.axes.size(); ++a) {
            const AxisSign& x = r.axes[a];
            std::cout << "axis " << a << ": +F moved the handle " << x.displacement << unit << " (threshold "
                      << x.threshold << unit << "): "
                      << (x.sign > 0   ? "sign +1, force and position agree"
                          : x.sign < 0 ? "sign -1, the force acts AGAINST the position axis"
                                       : "inconclusive, the handle did not move (held or blocked?)")
                      << "\n";
            details << "axis " << a << " sign " << x.sign << " displacement " << x.displacement << "\n";
            all_positive = all_positive && x.sign > 0;
        }
        if (all_positive) {
            std::string error;
            if (!o.simulate && profile.driver != "sim") {
                if (!record_force_sign_confirmed(profile.name, details.str(), error))
                    throw StartupError(ErrorKind::Internal, error);
                std::cout << "hapticd check-device: force sign confirmed; recorded in "
                          << force_sign_confirmation_file(profile.name).string() << " (the first-run limit of "
                          << kFirstRunMaxForce << " no longer applies)\n";
            } else {
                std::cout << "hapticd check-device: force sign +1 on every axis\n";
            }
            return kExitOk;
        }
        std::cerr
            << "hapticd check-device: error: the force sign is not confirmed. For a sign of -1 set `force_sign` in "
               "the profile (one entry per axis, -1 where it was measured -1; HID devices may instead negate "
               "force_scale), for an inconclusive axis let go of the handle, then run check-device again. Until "
               "then forces stay limited to "
            << kFirstRunMaxForce << " (docs/devices.md)\n";
        return kExitDeviceError;
    } catch (const StartupError& e) {
        if (e.what()[0] != '\0') std::cerr << "hapticd check-device: error: " << e.what() << "\n";
        return exit_code(e.kind());
    } catch (const std::exception& e) {
        std::cerr << "hapticd check-device: internal error: " << e.what() << "\n";
        return kExitInternal;
    } catch (...) {
        std::cerr << "hapticd check-device: internal error (unknown exception)\n";
        return kExitInternal;
    }
}

}  // namespace hapticd
