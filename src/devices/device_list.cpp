// SPDX-License-Identifier: Apache-2.0
#include "devices/device_list.hpp"

#include <hidapi.h>
#include <libusb.h>

#include <fcntl.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <map>
#include <set>

#include "devices/ftdi_protocol.hpp"
#include "devices/transport_libusb.hpp"

namespace hapticd {

namespace fs = std::filesystem;

namespace {

std::string usb_id(unsigned vid, unsigned pid) {
    char buf[16];
    std::snprintf(buf, sizeof buf, "%04x:%04x", vid & 0xFFFFU, pid & 0xFFFFU);
    return buf;
}

void list_falcons(std::vector<ListedDevice>& out, std::vector<std::string>& notes) {
    libusb_context* ctx = nullptr;
    if (const int rc = libusb_init(&ctx); rc != 0) {
        notes.push_back(std::string("libusb unavailable (") + libusb_error_name(rc) + "): Falcons not listed");
        return;
    }
    libusb_device** list = nullptr;
    const ssize_t n = libusb_get_device_list(ctx, &list);
    for (ssize_t i = 0; i < n; ++i) {
        libusb_device_descriptor desc{};
        if (libusb_get_device_descriptor(list[i], &desc) != 0) continue;
        if (desc.idVendor != ftdi::kFalconVendorId || desc.idProduct != ftdi::kFalconProductId) continue;
        ListedDevice d;
        d.driver = "falcon";
        d.profiles = "falcon, falcon_nohuman";
        d.usb_id = usb_id(desc.idVendor, desc.idProduct);
        d.location = "USB bus " + std::to_string(libusb_get_bus_number(list[i])) + " device " +
                     std::to_string(libusb_get_device_address(list[i]));
        libusb_device_handle* h = nullptr;
        const int rc = libusb_open(list[i], &h);
        d.accessible = rc == 0;
        if (rc == LIBUSB_ERROR_ACCESS) {
            d.problem = std::string("permission denied: ") + kUdevHint;
        } else if (rc != 0) {
            d.problem = std::string("cannot open: ") + libusb_error_name(rc);
        }
        if (h != nullptr) libusb_close(h);
        out.push_back(d);
    }
    if (list != nullptr) libusb_free_device_list(list, 1);
    libusb_exit(ctx);
}

// Why hid_open_path() failed: hidapi 0.13 keeps errno only in a wide-character message, so the node is
// opened once more (hidapi's own open(O_RDWR), linux/hid.c) to get the errno. Only EACCES / EPERM are a
// missing udev rule; anything else is named as it is.
std::string hid_open_problem(const char* path) {
    const int fd = ::open(path, O_RDWR | O_CLOEXEC);
    if (fd >= 0) {
        ::close(fd);
        return "cannot open through hidapi (the node itself opens; is it a HID device?)";
    }
    const int e = errno;
    if (e == EACCES || e == EPERM) return std::string("permission denied: ") + kUdevHint;
    return std::string("cannot open: ") + std::strerror(e);
}

void list_hid(const std::vector<DeviceProfile>& profiles, std::vector<ListedDevice>& out,
              std::vector<std::string>& notes) {
    if (hid_init() != 0) {
        notes.push_back("hidapi unavailable: HID devices not listed");
        return;
    }
    std::map<std::pair<long long, long long>, std::string> wanted;  // VID:PID -> profile names
    for (const auto& p : profiles) {
        auto& names = wanted[{p.real.usb_vid, p.real.usb_pid}];
        names += (names.empty() ? "" : ", ") + p.name;
    }
    for (const auto& [ids, names] : wanted) {
        // All devices, filtered here: hidapi 0.13's own VID:PID filter misses devices that the unfiltered
        // enumeration reports with these ids (seen on the umockdev-emulated device of the usb tests).
        hid_device_info* list = hid_enumerate(0, 0);
        std::set<std::string> seen;
        for (hid_device_info* it = list; it != nullptr; it = it->next) {
            if (it->vendor_id != ids.first || it->product_id != ids.second) continue;
            if (it->path == nullptr || !seen.insert(it->path).second) continue;
            ListedDevice d;
            d.driver = "hid";
            d.profiles = names;
            d.usb_id = usb_id(it->vendor_id, it->product_id);
            d.location = it->path;
            hid_device* h = hid_open_path(it->path);
            d.accessible = h != nullptr;
            if (h == nullptr) d.problem = hid_open_problem(it->path);
            if (h != nullptr) hid_close(h);
            out.push_back(d);
        }
        hid_free_enumeration(list);
    }
}

}  // namespace

std::vector<DeviceProfile> discover_hid_profiles(const Options& o, std::vector<std::string>& warnings) {
    const std::vector<std::string> dirs = device_profile_dirs(o);
    std::vector<DeviceProfile> found;
    std::set<std::string> names;
    for (const auto& dir : dirs) {
        std::error_code ec;
        if (!fs::is_directory(dir, ec)) continue;
        for (const auto& entry : fs::directory_iterator(dir, ec)) {
            if (entry.path().extension() != ".toml") continue;
            Options one = o;
            one.device = entry.path().string();
            try {
                DeviceProfile p = load_device_profile(one);
                if (p.driver == "hid" && names.insert(p.name).second) found.push_back(p);
            } catch (const StartupError& e) {
                warnings.push_back(e.what());
            }
        }
    }
    return found;
}

std::vector<ListedDevice> enumerate_devices(const std::vector<DeviceProfile>& hid_profiles,
                                            std::vector<std::string>& notes) {
    std::vector<ListedDevice> out;
    list_falcons(out, notes);
    list_hid(hid_profiles, out, notes);
    return out;
}

int list_devices(std::ostream& out, const Options& o) {
    std::vector<std::string> notes;
    const std::vector<DeviceProfile> hid_profiles = discover_hid_profiles(o, notes);
    const std::vector<ListedDevice> devices = enumerate_devices(hid_profiles, notes);
    for (const auto& n : notes) out << "hapticd: note: " << n << "\n";
    std::string looked_for =
        "Novint Falcon (USB " + usb_id(ftdi::kFalconVendorId, ftdi::kFalconProductId) + ", libusb)";
    for (const auto& p : hid_profiles) {
        looked_for += ", " + p.name + " (HID " +
                      usb_id(static_cast<unsigned>(p.real.usb_vid), static_cast<unsigned>(p.real.usb_pid)) +
                      ", hidapi)";
    }
    if (devices.empty()) {
        out << "hapticd: no supported device found; looked for: " << looked_for << "\n";
        return 0;
    }
    out << "hapticd: " << devices.size() << " supported device(s):\n";
    for (const auto& d : devices) {
        out << "  " << d.driver << "  " << d.usb_id << "  " << d.location << "  profiles: " << d.profiles << "  "
            << (d.accessible ? "ok" : d.problem) << "\n";
    }
    return 0;
}

}  // namespace hapticd
