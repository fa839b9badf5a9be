// SPDX-License-Identifier: Apache-2.0
#include "devices/check_device.hpp"

#include <CLI/CLI.hpp>

#include <chrono>
#include <cmath>
#include <iostream>
#include <sstream>
#include <thread>

#include "config/options.hpp"
#include "common/exit_codes.hpp"
#include "devices/device_factory.hpp"
#include "devices/first_run.hpp"
#include "devices/sim_device.hpp"
#include "common/stop_flag.hpp"

namespace hapticd {

namespace {

class Ticker {
public:
    Ticker(double period, bool lockstep)
        : period_(std::chrono::nanoseconds(static_cast<std::int64_t>(std::llround(period * 1e9)))),
          lockstep_(lockstep),
          next_(std::chrono::steady_clock::now()) {}
    void wait() {
        if (lockstep_) return;
        next_ += period_;
        std::this_thread::sleep_until(next_);
    }

private:
    std::chrono::nanoseconds period_;
    bool lockstep_;
    std::chrono::steady_clock::time_point next_;
};

void require(bool ok, const std::string& name, double value, const std::string& range) {
    if (!ok) throw StartupError(kExitInvalidParameter, name + " = " + std::to_string(value) + " is invalid; accepted range: " + range);
}

struct Stop {
    DeviceStatus status = DeviceStatus::Ok;
    std::string message;
};

}  // namespace

ForceSignResult measure_force_sign(Device& device, const ForceSignSettings& s) {
    ForceSignResult result;
    const std::size_t axes = device.capabilities().axes;
    const auto ticks = [&s](double seconds) { return std::max<long>(1, std::lround(seconds / s.period)); };
    Ticker ticker(s.period, s.lockstep);
    AxisVector position{};
    AxisVector zero{};
    Stop stop;
    // One tick: read, check the limit, write `force` on `axis` (0 on the others).
    auto tick = [&](std::size_t axis, double force, double start) -> bool {
        ticker.wait();
        if (const DeviceStatus st = device.read_position(position); st != DeviceStatus::Ok) {
            stop = {st, "reading the position failed: " + device.last_error()};
            return false;
        }
        if (!std::isfinite(position[axis])) {
            stop = {DeviceStatus::HardwareFault, "the device reported a non-finite position"};
            return false;
        }
        if (std::isfinite(start) && std::abs(position[axis] - start) > s.position_limit) {
            stop = {DeviceStatus::Ok, "axis " + std::to_string(axis) + " moved more than " + std::to_string(s.position_limit) +
                                          " from its start: stopped with zero force (is the handle free to move?)"};
            return false;
        }
        AxisVector f{};
        f[axis] = force;
        if (const DeviceStatus st = device.write_force(f); st != DeviceStatus::Ok) {
            stop = {st, "writing the force failed: " + device.last_error()};
            return false;
        }
        if (stop_requested()) {
            stop = {DeviceStatus::Ok, "interrupted by a stop request"};
            return false;
        }
        return true;
    };
    auto finish = [&](bool ok) {
        device.write_force(zero);
        result.ok = ok;
        result.status = stop.status;
        result.message = stop.message;
        return result;
    };
    for (std::size_t axis = 0; axis < axes; ++axis) {
        // Rest: mean and spread of the position with zero force.
        const long rest = ticks(s.rest_time);
        double sum = 0.0, sum2 = 0.0;
        for (long i = 0; i < rest; ++i) {
            if (!tick(axis, 0.0, NAN)) return finish(false);
            sum += position[axis];
            sum2 += position[axis] * position[axis];
        }
        const double mean = sum / static_cast<double>(rest);
        const double spread = std::sqrt(std::max(0.0, sum2 / static_cast<double>(rest) - mean * mean));
        AxisSign a;
        a.threshold = std::max(s.min_motion, 20.0 * spread);
        const long t = ticks(s.push_time);
        // The first tick's force acts from the next period on (zero-order hold): the displacement of the
        // first phase is read one tick after its last force.
        for (long i = 0; i < t; ++i) {
            if (!tick(axis, s.push_force, mean)) return finish(false);
        }
        if (!tick(axis, -s.push_force, mean)) return finish(false);
        a.displacement = position[axis] - mean;
        for (long i = 1; i < 2 * t; ++i) {
            if (!tick(axis, -s.push_force, mean)) return finish(false);
        }
        for (long i = 0; i < t; ++i) {
            if (!tick(axis, s.push_force, mean)) return finish(false);
        }
        for (long i = 0; i < rest; ++i) {
            if (!tick(axis, 0.0, mean)) return finish(false);
        }
        a.sign = std::abs(a.displacement) <= a.threshold ? 0 : (a.displacement > 0 ? 1 : -1);
        result.axes.push_back(a);
    }
    return finish(true);
}

int check_device_main(int argc, const char* const* argv) noexcept {
    clear_stop_request();
    try {
        Options o;
        double push_force = NAN;
        double push_time = 0.05;
        CLI::App app{"hapticd check-device: push the device gently along each axis and report the measured force sign "
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
        require(std::isfinite(o.rate) && o.rate >= 10 && o.rate <= 20000, "--rate", o.rate, "10 .. 20000 Hz");
        require(std::isfinite(push_time) && push_time >= 0.005 && push_time <= 1.0, "--push-time", push_time, "0.005 .. 1 s");
        const double T = 1.0 / o.rate;
        SimScenario scenario;
        scenario.kind = Scenario::Step;
        scenario.step_force = 0.0;  // no simulated hand: only the push moves the handle
        std::unique_ptr<Device> device = make_device(profile, o, scenario, T);
        const double max_force = device->capabilities().max_force;
        if (std::isnan(push_force)) push_force = std::min(0.5, 0.1 * max_force);
        require(std::isfinite(push_force) && push_force > 0 && push_force <= max_force, "--push-force", push_force,
                "0 < F <= max_force (" + std::to_string(max_force) + ")");
        install_stop_signal_handlers();
        if (device->open() != DeviceStatus::Ok) {
            throw StartupError(kExitDeviceError, "device '" + profile.name + "': open failed: " + device->last_error());
        }
        if (device->home() != DeviceStatus::Ok) {
            const std::string e = device->last_error();
            device->close();
            throw StartupError(kExitDeviceError, "device '" + profile.name + "': homing failed: " + e);
        }
        if (!o.quiet) {
            std::cout << "hapticd check-device: device '" << profile.name << "': hold the handle loosely (or let go); pushing "
                      << push_force << (profile.rotary ? " N m" : " N") << " along each axis (+F " << push_time * 1e3
                      << " ms, -F " << 2 * push_time * 1e3 << " ms, +F " << push_time * 1e3 << " ms)" << std::endl;
        }
        ForceSignSettings s;
        s.push_force = push_force;
        s.push_time = push_time;
        s.period = T;
        s.lockstep = profile.driver == "sim" || o.simulate;
        const ForceSignResult r = measure_force_sign(*device, s);
        device->close();
        if (!r.ok) {
            throw StartupError(r.status == DeviceStatus::Ok ? kExitRunFault : kExitDeviceError,
                               "device '" + profile.name + "': " + r.message);
        }
        bool all_positive = true;
        std::ostringstream details;
        const char* unit = profile.rotary ? " rad" : " m";
        for (std::size_t a = 0; a < r.axes.size(); ++a) {
            const AxisSign& x = r.axes[a];
            std::cout << "axis " << a << ": +F moved the handle " << x.displacement << unit << " (threshold " << x.threshold
                      << unit << "): "
                      << (x.sign > 0 ? "sign +1, force and position agree"
                                     : x.sign < 0 ? "sign -1, the force acts AGAINST the position axis"
                                                  : "inconclusive, the handle did not move (held or blocked?)")
                      << "\n";
            details << "axis " << a << " sign " << x.sign << " displacement " << x.displacement << "\n";
            all_positive = all_positive && x.sign > 0;
        }
        if (all_positive) {
            std::string error;
            if (!o.simulate && profile.driver != "sim") {
                if (!record_force_sign_confirmed(profile.name, details.str(), error)) throw StartupError(kExitInternal, error);
                std::cout << "hapticd check-device: force sign confirmed; recorded in "
                          << force_sign_confirmation_file(profile.name).string() << " (the first-run limit of "
                          << kFirstRunMaxForce << " no longer applies)\n";
            } else {
                std::cout << "hapticd check-device: force sign +1 on every axis\n";
            }
            return kExitOk;
        }
        std::cerr << "hapticd check-device: error: the force sign is not confirmed. For a sign of -1 set `force_sign` in "
                     "the profile (one entry per axis, -1 where it was measured -1; HID devices may instead negate "
                     "force_scale), for an inconclusive axis let go of the handle, then run check-device again. Until "
                     "then forces stay limited to " << kFirstRunMaxForce << " (docs/devices.md)\n";
        return kExitDeviceError;
    } catch (const StartupError& e) {
        if (e.what()[0] != '\0') std::cerr << "hapticd check-device: error: " << e.what() << "\n";
        return e.code();
    } catch (const std::exception& e) {
        std::cerr << "hapticd check-device: internal error: " << e.what() << "\n";
        return kExitInternal;
    } catch (...) {
        std::cerr << "hapticd check-device: internal error (unknown exception)\n";
        return kExitInternal;
    }
}

}  // namespace hapticd
