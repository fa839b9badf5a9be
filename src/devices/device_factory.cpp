// SPDX-License-Identifier: Apache-2.0
#include "devices/device_factory.hpp"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <iostream>
#include <limits>
#include <stdexcept>

#include "devices/falcon_device.hpp"
#include "devices/first_run.hpp"
#include "devices/force_sign_device.hpp"
#include "devices/hid_device.hpp"
#include "devices/transport_libusb.hpp"
#include "common/stop_flag.hpp"

namespace hapticd {

DeviceCapabilities capabilities_from_profile(const DeviceProfile& p) {
    DeviceCapabilities c;
    c.axes = static_cast<std::size_t>(p.axes);
    c.max_force = p.max_force;
    c.inherent_delay = p.inherent_delay;
    c.rotary = p.rotary;
    for (std::size_t a = 0; a < kMaxAxes; ++a) {
        c.workspace_min[a] = a < p.workspace_min.size() ? p.workspace_min[a] : -std::numeric_limits<double>::infinity();
        c.workspace_max[a] = a < p.workspace_max.size() ? p.workspace_max[a] : std::numeric_limits<double>::infinity();
    }
    return c;
}

bool apply_first_run_limit(DeviceCapabilities& c, const std::string& profile_name, bool quiet) {
    if (force_sign_confirmed(profile_name) || c.max_force <= kFirstRunMaxForce) return false;
    if (!quiet) {
        std::cerr << "hapticd: warning: device '" << profile_name
                  << "': first run, the force sign is not confirmed yet: "
                  << "forces limited to " << kFirstRunMaxForce << " (instead of max_force " << c.max_force
                  << ") until `hapticd check-device --device " << profile_name << "` has measured it (docs/devices.md, "
                  << "\"First run\")" << std::endl;
    }
    c.max_force = kFirstRunMaxForce;
    return true;
}

namespace {

// A relative firmware path in a profile is relative to the profile's directory (when it exists there).
std::string resolve_firmware(const DeviceProfile& p, const Options& o) {
    if (!o.falcon_firmware.empty()) return o.falcon_firmware;
    if (p.real.firmware.empty()) return {};
    const std::filesystem::path fw(p.real.firmware);
    if (fw.is_relative()) {
        const auto beside = std::filesystem::path(p.path).parent_path() / fw;
        if (std::filesystem::exists(beside)) return beside.string();
    }
    return p.real.firmware;
}

std::unique_ptr<Device> make_falcon_device(const DeviceProfile& p, const Options& o) {
    FalconDeviceConfig cfg;
    cfg.capabilities = capabilities_from_profile(p);
    apply_first_run_limit(cfg.capabilities, p.name, o.quiet);
    cfg.firmware_path = resolve_firmware(p, o);
    if (p.real.origin.size() == 3) cfg.origin = {p.real.origin[0], p.real.origin[1], p.real.origin[2]};
    cfg.homing_timeout = p.real.homing_timeout;
    const int index = static_cast<int>(p.real.device_index);
    cfg.open_transport = [index] { return LibusbFtdiTransport::open_falcon(index); };
    const bool quiet = o.quiet;
    cfg.notify = [quiet](const std::string& message) {
        if (!quiet) std::cerr << "hapticd: " << message << std::endl;
    };
    cfg.cancel = [] { return stop_requested(); };
    return std::make_unique<FalconDevice>(std::move(cfg));
}

std::unique_ptr<Device> make_hid_device(const DeviceProfile& p, const Options& o, double period) {
    HidDeviceConfig cfg;
    cfg.capabilities = capabilities_from_profile(p);
    apply_first_run_limit(cfg.capabilities, p.name, o.quiet);
    const RealDeviceKeys& k = p.real;
    hid::Layout& l = cfg.layout;
    l.vendor_id = static_cast<std::uint16_t>(k.usb_vid);
    l.product_id = static_cast<std::uint16_t>(k.usb_pid);
    l.position_scale = k.position_scale;
    l.position_zero = k.position_zero;
    l.force_scale = k.force_scale;
    cfg.device_index = static_cast<int>(k.device_index);
    // 0.5 s without an input report: 5x the ~100 ms keep-alive of a device that reports only on change.
    cfg.max_stale_reads = static_cast<int>(std::ceil(0.5 / period));
    return std::make_unique<HidFfbDevice>(std::move(cfg));
}

}  // namespace

Scenario scenario_kind(const Options& o) {
    if (o.scenario == "push") return Scenario::Push;
    if (o.scenario == "hold") return Scenario::Hold;
    if (o.scenario == "rest") return Scenario::Rest;
    if (o.scenario == "path") return Scenario::Path;
    if (o.scenario == "step") return Scenario::Step;
    return o.serve ? Scenario::Rest : Scenario::Step;
}

SimHand simulated_hand(const Options& o, const DeviceProfile& p) {
    SimHand hand;
    hand.mass = o.hand_mass;
    hand.damping = o.hand_damping >= 0.0 ? o.hand_damping : kHandDampingPerMass * p.mass;
    hand.stiffness = o.hand_stiffness >= 0.0 ? o.hand_stiffness : kHandStiffnessPerMass * p.mass;
    if (o.hand_release_mass >= 0.0) {
        hand.release_mass = o.hand_release_mass;
    } else if (!p.mass_range.empty()) {
        hand.release_mass = std::max(0.0, p.mass - *std::min_element(p.mass_range.begin(), p.mass_range.end()));
    }
    return hand;
}

std::unique_ptr<Device> make_device(const DeviceProfile& p, const Options& o, const SimScenario& scenario,
                                    double period) {
    if ((p.driver == "falcon" || p.driver == "hid") && !o.simulate) {
        std::unique_ptr<Device> d = p.driver == "falcon" ? make_falcon_device(p, o) : make_hid_device(p, o, period);
        AxisVector sign{1.0, 1.0, 1.0};
        bool flipped = false;
        for (std::size_t a = 0; a < p.real.force_sign.size() && a < kMaxAxes; ++a) {
            sign[a] = p.real.force_sign[a];
            flipped = flipped || sign[a] < 0;
        }
        if (!flipped) return d;
        return std::make_unique<ForceSignDevice>(std::move(d), sign);
    }
    if (p.driver != "sim" && !o.simulate) {
        throw StartupError(
            ErrorKind::Device,
            "device '" + p.name + "': driver '" + p.driver +
                "' is not available in this build; run with --simulate to simulate this profile's physics");
    }
    SimDeviceConfig cfg;
    cfg.capabilities = capabilities_from_profile(p);
    cfg.capabilities.measures_external_force = true;
    cfg.plant = PlantParameters{p.mass, p.damping, p.stiffness};
    if (!p.mass_model.isotropic) cfg.mass_matrix = p.mass_model.matrix;  // per axis or coupled (sim_device.hpp)
    cfg.period = period;
    cfg.position_noise = p.position_noise;
    cfg.position_resolution = p.position_resolution;
    cfg.coulomb_friction = p.coulomb_friction;
    cfg.noise_seed = static_cast<std::uint64_t>(p.noise_seed);
    cfg.fail_at_tick = p.fail_at_tick;
    cfg.scenario = scenario;
    try {
        return std::make_unique<SimDevice>(cfg);
    } catch (const std::invalid_argument& e) {  // e.g. coulomb_friction with a coupled mass_matrix
        throw StartupError(ErrorKind::InvalidParameter, "device profile '" + p.path + "': " + e.what());
    }
}

}  // namespace hapticd
