// SPDX-License-Identifier: Apache-2.0
#include "config/profile_keys.hpp"

#include <algorithm>
#include <cmath>

#include <CLI/CLI.hpp>
#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>

#include "common/number_text.hpp"
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

[[noreturn]] void invalid_key(const KeyLocations& where, const std::string& key, const std::string& value,
                              const std::string& range) {
    throw StartupError(ErrorKind::InvalidParameter,
                       where.prefix(key) + key + " = " + value + " is invalid; accepted range: " + range);
}

void check_int(const KeyLocations& where, const std::string& key, long long v, long long lo, long long hi) {
    if (v < lo || v > hi) invalid_key(where, key, std::to_string(v), std::to_string(lo) + " .. " + std::to_string(hi));
}

void check_real(const KeyLocations& where, const std::string& key, double v, double lo, double hi, bool nonzero) {
    if (!std::isfinite(v) || v < lo || v > hi || (nonzero && v == 0.0)) {
        invalid_key(where, key, std::to_string(v),
                    "finite" + std::string(nonzero ? ", non-zero" : "") + ", " + std::to_string(lo) + " .. " +
                        std::to_string(hi));
    }
}

}  // namespace

void validate_real_device_keys(const KeyLocations& where, const std::string& driver, const RealDeviceKeys& k) {
    check_real(where, "homing_timeout", k.homing_timeout, 0.001, 3600.0, false);
    check_int(where, "device_index", k.device_index, 0, 127);
    if (!k.origin.empty() && k.origin.size() != 3) {
        invalid_key(where, "origin", std::to_string(k.origin.size()) + " values", "3 values (x, y, z in m)");
    }
    for (double v : k.origin) check_real(where, "origin", v, -1.0, 1.0, false);
    if (k.force_sign.size() > 3)
        invalid_key(where, "force_sign", std::to_string(k.force_sign.size()) + " values",
                    "1 to 3 values, one per axis");
    for (double v : k.force_sign) {
        if (v != 1.0 && v != -1.0) invalid_key(where, "force_sign", std::to_string(v), "+1 or -1 per axis");
    }
    if (driver == "hid") {
        if (k.usb_vid < 0 || k.usb_pid < 0) {
            throw StartupError(ErrorKind::BadConfig,
                               where.prefix("driver") + "driver = \"hid\" needs usb_vid and usb_pid");
        }
        check_int(where, "usb_vid", k.usb_vid, 0, 0xFFFF);
        check_int(where, "usb_pid", k.usb_pid, 0, 0xFFFF);
    }
    check_real(where, "position_scale", k.position_scale, -1e6, 1e6, true);
    check_real(where, "position_zero", k.position_zero, -4.3e9, 4.3e9, false);
    check_real(where, "force_scale", k.force_scale, -1e9, 1e9, true);
}

// ---- the plant's mass keys ---------------------------------------------------------------------------

void add_mass_keys(CLI::App& app, MassKeys& k) {
    app.add_option("--mass", k.mass);
    app.add_option("--mass_matrix", k.mass_matrix);
    app.add_option("--max_stiffness", k.max_stiffness);
}

void read_mass_keys_given(const CLI::App& app, MassKeys& k) {
    k.mass_given = app.get_option("--mass")->count() > 0;
    k.mass_matrix_given = app.get_option("--mass_matrix")->count() > 0;
    k.max_stiffness_given = app.get_option("--max_stiffness")->count() > 0;
}

ProfileMass validate_mass_keys(const KeyLocations& where, std::size_t axes, const MassKeys& k, double damping,
                               double stiffness) {
    const std::string n_axes = std::to_string(axes);
    if (!k.mass_given && !k.mass_matrix_given) {
        throw StartupError(ErrorKind::BadConfig, where.prefix("mass") +
                                                     "missing key 'mass'; accepted: mass = M (kg, every axis), "
                                                     "mass = [one value per axis] or mass_matrix = [" +
                                                     n_axes + " x " + n_axes + " values, row by row]");
    }
    if (k.mass_given && k.mass_matrix_given) {
        throw StartupError(ErrorKind::BadConfig,
                           where.prefix("mass_matrix") + "mass and mass_matrix are both given; accepted: one of them");
    }
    ProfileMass out;
    if (k.mass_given) {
        if (k.mass.size() != 1 && k.mass.size() != axes) {
            invalid_key(where, "mass", number_list(k.mass), "one value (every axis) or one per axis (" + n_axes + ")");
        }
        for (double v : k.mass) {
            if (!std::isfinite(v) || v <= 0.0 || v > 1e6) {
                invalid_key(where, "mass", k.mass.size() == 1 ? short_number(v) : number_list(k.mass),
                            "finite, > 0 and <= 1e6 kg (kg m^2 for rotary devices)" +
                                std::string(k.mass.size() == 1 ? "" : " per value"));
            }
        }
        MassMatrix M{};
        for (std::size_t a = 0; a < axes; ++a) M[a][a] = k.mass.size() == 1 ? k.mass[0] : k.mass[a];
        out.mass = DeviceMass::from_matrix(M, axes);
    } else {
        const std::string shape = n_axes + " x " + n_axes + " = " + std::to_string(axes * axes) + " values, row by row";
        if (k.mass_matrix.size() != axes * axes) {
            invalid_key(where, "mass_matrix", std::to_string(k.mass_matrix.size()) + " values", shape);
        }
        double largest_entry = 0.0;
        for (double v : k.mass_matrix) {
            if (!std::isfinite(v) || std::abs(v) > 1e6)
                invalid_key(where, "mass_matrix", number_list(k.mass_matrix), "finite entries, |M_ij| <= 1e6 kg");
            largest_entry = std::max(largest_entry, std::abs(v));
        }
        MassMatrix M{};
        for (std::size_t i = 0; i < axes; ++i) {
            for (std::size_t j = 0; j < axes; ++j) M[i][j] = k.mass_matrix[i * axes + j];
        }
        for (std::size_t i = 0; i < axes; ++i) {
            for (std::size_t j = i + 1; j < axes; ++j) {
                // Symmetric to 1e-9 of the largest entry: values written alike are exactly symmetric; the
                // tolerance only forgives a last-digit difference, never a real asymmetry.
                if (std::abs(M[i][j] - M[j][i]) > 1e-9 * largest_entry) {
                    invalid_key(where, "mass_matrix",
                                "M[" + std::to_string(i) + "][" + std::to_string(j) + "] = " + short_number(M[i][j]) +
                                    " but M[" + std::to_string(j) + "][" + std::to_string(i) +
                                    "] = " + short_number(M[j][i]),
                                "a symmetric matrix (|M_ij - M_ji| <= 1e-9 max |M_kl|)");
                }
            }
        }
        const auto n = static_cast<Eigen::Index>(axes);
        const Eigen::MatrixXd m = mass_matrix_eigen(M, axes).topLeftCorner(n, n);
        const Eigen::LLT<Eigen::MatrixXd> cholesky(0.5 * (m + m.transpose()));
        const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> es(0.5 * (m + m.transpose()), Eigen::EigenvaluesOnly);
        const double lo = es.eigenvalues().minCoeff(), hi = es.eigenvalues().maxCoeff();
        if (cholesky.info() != Eigen::Success || !(lo > 0.0) || lo < 1e-9 * hi || hi > 1e6) {
            invalid_key(
                where, "mass_matrix",
                number_list(k.mass_matrix) + " (eigenvalues " + short_number(lo) + " .. " + short_number(hi) + " kg)",
                "positive definite (Cholesky), eigenvalues in (0, 1e6] kg, smallest / largest >= 1e-9");
        }
        out.mass = DeviceMass::from_matrix(M, axes);
    }
    if (!out.mass.isotropic && (damping != 0.0 || stiffness != 0.0)) {
        throw StartupError(
            ErrorKind::InvalidParameter,
            where.prefix(k.mass_given ? "mass" : "mass_matrix") + "an anisotropic mass (" + out.mass.describe() +
                ") with damping = " + short_number(damping) + " N s/m, stiffness = " + short_number(stiffness) +
                " N/m is not supported: the plant along a direction is then not one scalar loop, and the "
                "stability checks would use a wrong model; accepted: damping = 0 and stiffness = 0 with a mass "
                "per axis or mass_matrix, or one mass for every axis (docs/devices.md)");
    }
    if (k.max_stiffness_given) {
        if (!std::isfinite(k.max_stiffness) || k.max_stiffness <= 0.0 || k.max_stiffness > 1e12) {
            invalid_key(where, "max_stiffness", short_number(k.max_stiffness),
                        "finite, > 0 and <= 1e12 N/m (N m/rad); omit it for no limit");
        }
        out.max_stiffness = k.max_stiffness;
    }
    return out;
}

}  // namespace hapticd
