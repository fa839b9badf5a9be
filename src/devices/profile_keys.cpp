#include "devices/profile_keys.hpp"

#include <cmath>

#include <CLI/CLI.hpp>

#include "config/options.hpp"

namespace hapticd {

void add_real_device_keys(CLI::App& app, RealDeviceKeys& k) {
    app.add_option("--firmware", k.firmware);
    app.add_option("--homing_timeout", k.homing_timeout);
    app.add_option("--origin", k.origin);
    app.add_option("--device_index", k.device_index);
    app.add_option("--force_sign", k.force_sign);
    app.add_option("--usb_vid", k.usb_vid);
    app.add_option("--usb_pid", k.usb_pid);
    app.add_option("--position_scale", k.position_scale);
    app.add_option("--position_zero", k.position_zero);
    app.add_option("--force_scale", k.force_scale);
}

namespace {

[[noreturn]] void invalid(const KeyLocations& where, const std::string& key, const std::string& value, const std::string& range) {
    throw StartupError(kExitInvalidParameter, where.prefix(key) + key + " = " + value + " is invalid; accepted range: " + range);
}

void check_int(const KeyLocations& where, const std::string& key, long long v, long long lo, long long hi) {
    if (v < lo || v > hi) invalid(where, key, std::to_string(v), std::to_string(lo) + " .. " + std::to_string(hi));
}

void check_real(const KeyLocations& where, const std::string& key, double v, double lo, double hi, bool nonzero) {
    if (!std::isfinite(v) || v < lo || v > hi || (nonzero && v == 0.0)) {
        invalid(where, key, std::to_string(v), "finite" + std::string(nonzero ? ", non-zero" : "") + ", " +
                                                   std::to_string(lo) + " .. " + std::to_string(hi));
    }
}

}  // namespace

void validate_real_device_keys(const KeyLocations& where, const std::string& driver, const RealDeviceKeys& k) {
    check_real(where, "homing_timeout", k.homing_timeout, 0.001, 3600.0, false);
    check_int(where, "device_index", k.device_index, 0, 127);
    if (!k.origin.empty() && k.origin.size() != 3) {
        invalid(where, "origin", std::to_string(k.origin.size()) + " values", "3 values (x, y, z in m)");
    }
    for (double v : k.origin) check_real(where, "origin", v, -1.0, 1.0, false);
    if (k.force_sign.size() > 3) invalid(where, "force_sign", std::to_string(k.force_sign.size()) + " values", "1 to 3 values, one per axis");
    for (double v : k.force_sign) {
        if (v != 1.0 && v != -1.0) invalid(where, "force_sign", std::to_string(v), "+1 or -1 per axis");
    }
    if (driver == "hid") {
        if (k.usb_vid < 0 || k.usb_pid < 0) {
            throw StartupError(kExitBadConfig, where.prefix("driver") + "driver = \"hid\" needs usb_vid and usb_pid");
        }
        check_int(where, "usb_vid", k.usb_vid, 0, 0xFFFF);
        check_int(where, "usb_pid", k.usb_pid, 0, 0xFFFF);
    }
    check_real(where, "position_scale", k.position_scale, -1e6, 1e6, true);
    check_real(where, "position_zero", k.position_zero, -4.3e9, 4.3e9, false);
    check_real(where, "force_scale", k.force_scale, -1e9, 1e9, true);
}

}  // namespace hapticd
