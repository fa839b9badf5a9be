// SPDX-License-Identifier: Apache-2.0
#include "emulated_hid_device.hpp"

#include <linux/hidraw.h>
#include <sys/ioctl.h>
#include <umockdev.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstdlib>
#include <cstring>

#include "pid_descriptor.hpp"

namespace hapticd::test {

namespace {

gboolean hid_handle_ioctl(UMockdevIoctlBase*, UMockdevIoctlClient* client, gpointer self) {
    return static_cast<EmulatedHidDevice*>(self)->on_ioctl(client) ? TRUE : FALSE;
}
gboolean hid_handle_read(UMockdevIoctlBase*, UMockdevIoctlClient* client, gpointer self) {
    return static_cast<EmulatedHidDevice*>(self)->on_read(client) ? TRUE : FALSE;
}
gboolean hid_handle_write(UMockdevIoctlBase*, UMockdevIoctlClient* client, gpointer self) {
    return static_cast<EmulatedHidDevice*>(self)->on_write(client) ? TRUE : FALSE;
}

constexpr std::uint8_t kBlockLoadId = 0x12;

}  // namespace

EmulatedHidDevice::EmulatedHidDevice() : descriptor_(openffboard_like_descriptor()) {
    if (!umockdev_in_mock_environment() && std::getenv("UMOCKDEV_DIR") == nullptr &&
        std::string(std::getenv("LD_PRELOAD") != nullptr ? std::getenv("LD_PRELOAD") : "").find("umockdev") ==
            std::string::npos) {
        error_ = "not running under libumockdev-preload";
        return;
    }
    testbed_ = umockdev_testbed_new();
    gchar* usb = umockdev_testbed_add_device(testbed_, "usb", "usb1", nullptr, "idVendor", "1209", "idProduct", "ffb0",
                                             "manufacturer", "Open FFBoard", "product", "FFBoard (emulated)", "serial",
                                             "EMU1", "bcdDevice", "0100", "busnum", "1", "devnum", "2", nullptr,
                                             "DEVTYPE", "usb_device", "PRODUCT", "1209/ffb0/100", nullptr);
    gchar* iface = umockdev_testbed_add_device(testbed_, "usb", "1-1:1.0", usb, "bInterfaceNumber", "00",
                                               "bInterfaceClass", "03", nullptr, "DEVTYPE", "usb_interface", nullptr);
    gchar* hid = umockdev_testbed_add_device(testbed_, "hid", "0003:1209:FFB0.0001", iface, nullptr, "HID_ID",
                                             "0003:00001209:0000FFB0", "HID_NAME", "Open FFBoard FFBoard", "HID_PHYS",
                                             "usb-emulated-1/input0", "HID_UNIQ", "EMU1", nullptr);
    umockdev_testbed_set_attribute_binary(testbed_, hid, "report_descriptor", descriptor_.data(),
                                          static_cast<int>(descriptor_.size()));
    g_free(usb);
    g_free(iface);
    handler_ = umockdev_ioctl_base_new();
    g_signal_connect(handler_, "handle-ioctl", G_CALLBACK(hid_handle_ioctl), this);
    g_signal_connect(handler_, "handle-read", G_CALLBACK(hid_handle_read), this);
    g_signal_connect(handler_, "handle-write", G_CALLBACK(hid_handle_write), this);
    GError* err = nullptr;
    // As libusb's umockdev test: attach the handler first, then add the node with add_from_string ("N:"),
    // which creates the emulated device file (add_device does not).
    if (!umockdev_testbed_attach_ioctl(testbed_, "/dev/hidraw0", handler_, &err)) {
        error_ = std::string("umockdev_testbed_attach_ioctl: ") + (err != nullptr ? err->message : "?");
        g_clear_error(&err);
        g_free(hid);
        return;
    }
    const std::string node = std::string("P: ") + (hid + 4) +
                             "/hidraw/hidraw0\nN: hidraw0\nE: SUBSYSTEM=hidraw\n"
                             "E: DEVNAME=/dev/hidraw0\nA: dev=243:0\n";  // hid + 4: without the leading "/sys"
    g_free(hid);
    if (!umockdev_testbed_add_from_string(testbed_, node.c_str(), &err)) {
        error_ = std::string("umockdev_testbed_add_from_string: ") + (err != nullptr ? err->message : "?");
        g_clear_error(&err);
        return;
    }
    const int master = umockdev_testbed_get_dev_fd(testbed_, "/dev/hidraw0");
    const char poke = 'x';
    if (master < 0 || ::write(master, &poke, 1) != 1) {
        error_ = "cannot make the emulated hidraw node readable";
        return;
    }
    ok_ = true;
}

EmulatedHidDevice::~EmulatedHidDevice() {
    if (testbed_ != nullptr) {
        GError* err = nullptr;
        if (handler_ != nullptr) umockdev_testbed_detach_ioctl(testbed_, "/dev/hidraw0", &err);
        g_clear_error(&err);
        g_object_unref(testbed_);
    }
    if (handler_ != nullptr) g_object_unref(handler_);
}

void EmulatedHidDevice::set_position(std::int16_t x) {
    std::lock_guard lock(mutex_);
    x_ = x;
}
void EmulatedHidDevice::set_silent(bool silent) {
    std::lock_guard lock(mutex_);
    silent_ = silent;
}
void EmulatedHidDevice::set_unplugged(bool unplugged) {
    std::lock_guard lock(mutex_);
    unplugged_ = unplugged;
}
std::string EmulatedHidDevice::root_dir() const {
    if (testbed_ == nullptr) return {};
    gchar* root = umockdev_testbed_get_root_dir(testbed_);
    std::string out = root != nullptr ? root : "";
    g_free(root);
    return out;
}
std::vector<std::vector<std::uint8_t>> EmulatedHidDevice::output_reports() const {
    std::lock_guard lock(mutex_);
    return outputs_;
}
std::vector<std::vector<std::uint8_t>> EmulatedHidDevice::feature_reports() const {
    std::lock_guard lock(mutex_);
    return features_;
}
int EmulatedHidDevice::input_reports_sent() const {
    std::lock_guard lock(mutex_);
    return inputs_sent_;
}

std::vector<std::uint8_t> EmulatedHidDevice::input_report_locked() const {
    // Report 1: 64 button bits (all clear), X int16 at byte 9, Y = 0 (pid_descriptor.hpp).
    std::vector<std::uint8_t> r(13, 0);
    r[0] = 1;
    const auto x = static_cast<std::uint16_t>(x_);
    r[9] = static_cast<std::uint8_t>(x & 0xFF);
    r[10] = static_cast<std::uint8_t>(x >> 8);
    return r;
}

bool EmulatedHidDevice::on_ioctl(UMockdevIoctlClient* client) {
    std::lock_guard lock(mutex_);
    if (unplugged_) {
        umockdev_ioctl_client_complete(client, -1, ENODEV);
        return true;
    }
    const unsigned long request = umockdev_ioctl_client_get_request(client);
    UMockdevIoctlData* arg = umockdev_ioctl_client_get_arg(client);
    GError* err = nullptr;
    if (request == HIDIOCGRDESCSIZE) {
        UMockdevIoctlData* d = umockdev_ioctl_data_resolve(arg, 0, sizeof(int), &err);
        const int size = static_cast<int>(descriptor_.size());
        if (d != nullptr) std::memcpy(d->data, &size, sizeof size);
        umockdev_ioctl_client_complete(client, d != nullptr ? 0 : -1, d != nullptr ? 0 : EFAULT);
    } else if (request == HIDIOCGRDESC) {
        UMockdevIoctlData* d = umockdev_ioctl_data_resolve(arg, 0, sizeof(hidraw_report_descriptor), &err);
        if (d != nullptr) {
            auto* rd = reinterpret_cast<hidraw_report_descriptor*>(d->data);
            rd->size = static_cast<std::uint32_t>(descriptor_.size());
            std::memcpy(rd->value, descriptor_.data(), descriptor_.size());
        }
        umockdev_ioctl_client_complete(client, d != nullptr ? 0 : -1, d != nullptr ? 0 : EFAULT);
    } else if (request == HIDIOCGRAWINFO) {
        UMockdevIoctlData* d = umockdev_ioctl_data_resolve(arg, 0, sizeof(hidraw_devinfo), &err);
        if (d != nullptr) {
            hidraw_devinfo info{};
            info.bustype = 3;  // BUS_USB
            info.vendor = 0x1209;
            info.product = static_cast<__s16>(0xFFB0);
            std::memcpy(d->data, &info, sizeof info);
        }
        umockdev_ioctl_client_complete(client, d != nullptr ? 0 : -1, d != nullptr ? 0 : EFAULT);
    } else if (_IOC_TYPE(request) == 'H' && (_IOC_NR(request) == 0x06 || _IOC_NR(request) == 0x07)) {
        // HIDIOCSFEATURE(len) = nr 6, HIDIOCGFEATURE(len) = nr 7; the argument is the report buffer.
        const std::size_t len = _IOC_SIZE(request);
        UMockdevIoctlData* d = umockdev_ioctl_data_resolve(arg, 0, len, &err);
        if (d == nullptr || len == 0) {
            umockdev_ioctl_client_complete(client, -1, EFAULT);
        } else if (_IOC_NR(request) == 0x06) {
            features_.emplace_back(d->data, d->data + len);
            umockdev_ioctl_client_complete(client, static_cast<long>(len), 0);
        } else if (d->data[0] == kBlockLoadId) {
            // PID Block Load: block 1, status Success (first of the status array: 1), RAM pool 0x1000.
            const std::uint8_t answer[5] = {kBlockLoadId, 1, 1, 0x00, 0x10};
            const std::size_t n = std::min(len, sizeof answer);
            std::memcpy(d->data, answer, n);
            umockdev_ioctl_client_complete(client, static_cast<long>(n), 0);
        } else {
            umockdev_ioctl_client_complete(client, -1, EINVAL);
        }
    } else {
        umockdev_ioctl_client_complete(client, -1, ENOTTY);
    }
    g_clear_error(&err);
    return true;
}

bool EmulatedHidDevice::on_read(UMockdevIoctlClient* client) {
    std::lock_guard lock(mutex_);
    if (unplugged_) {
        umockdev_ioctl_client_complete(client, -1, ENODEV);
        return true;
    }
    const auto now = std::chrono::steady_clock::now();
    const bool due =
        !silent_ && (!sent_any_ || x_ != last_sent_x_ || now - last_sent_ >= std::chrono::milliseconds(100));
    if (!due) {
        umockdev_ioctl_client_complete(client, -1, EAGAIN);
        return true;
    }
    UMockdevIoctlData* arg = umockdev_ioctl_client_get_arg(client);
    const std::vector<std::uint8_t> r = input_report_locked();
    const std::size_t n = std::min<std::size_t>(arg->data_len, r.size());
    std::memcpy(arg->data, r.data(), n);
    sent_any_ = true;
    last_sent_x_ = x_;
    last_sent_ = now;
    ++inputs_sent_;
    umockdev_ioctl_client_complete(client, static_cast<long>(n), 0);
    return true;
}

bool EmulatedHidDevice::on_write(UMockdevIoctlClient* client) {
    std::lock_guard lock(mutex_);
    if (unplugged_) {
        umockdev_ioctl_client_complete(client, -1, ENODEV);
        return true;
    }
    UMockdevIoctlData* arg = umockdev_ioctl_client_get_arg(client);
    outputs_.emplace_back(arg->data, arg->data + arg->data_len);
    umockdev_ioctl_client_complete(client, static_cast<long>(arg->data_len), 0);
    return true;
}

}  // namespace hapticd::test
