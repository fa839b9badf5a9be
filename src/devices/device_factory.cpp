#include "devices/device_factory.hpp"

#include <cmath>
#include <filesystem>
#include <iostream>
#include <limits>

#include "devices/falcon_device.hpp"
#include "devices/hid_device.hpp"
#include "devices/transport_libusb.hpp"
#include "scene/safety.hpp"

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

std::unique_ptr<Device> make_hid_device(const DeviceProfile& p, double period) {
    HidDeviceConfig cfg;
    cfg.capabilities = capabilities_from_profile(p);
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

std::unique_ptr<Device> make_device(const DeviceProfile& p, const Options& o, const SimScenario& scenario,
                                    double period) {
    if (p.driver == "falcon" && !o.simulate) return make_falcon_device(p, o);
    if (p.driver == "hid" && !o.simulate) return make_hid_device(p, period);
    if (p.driver != "sim" && !o.simulate) {
        throw StartupError(kExitDeviceError,
                           "device '" + p.name + "': driver '" + p.driver +
                               "' is not available in this build; run with --simulate to simulate this profile's physics");
    }
    SimDeviceConfig cfg;
    cfg.capabilities = capabilities_from_profile(p);
    cfg.capabilities.measures_external_force = true;
    cfg.plant = PlantParameters{p.mass, p.damping, p.stiffness};
    cfg.period = period;
    cfg.position_noise = p.position_noise;
    cfg.position_resolution = p.position_resolution;
    cfg.noise_seed = static_cast<std::uint64_t>(p.noise_seed);
    cfg.fail_at_tick = p.fail_at_tick;
    cfg.scenario = scenario;
    return std::make_unique<SimDevice>(cfg);
}

}  // namespace hapticd
