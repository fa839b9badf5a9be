// SPDX-License-Identifier: Apache-2.0
#include "emulated_falcon.hpp"

#include <linux/usbdevice_fs.h>
#include <sys/ioctl.h>
#include <umockdev.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstddef>
#include <cstdlib>
#include <cstring>

#include "devices/ftdi_protocol.hpp"

namespace hapticd::test {

namespace {

gboolean falcon_handle_ioctl(UMockdevIoctlBase*, UMockdevIoctlClient* client, gpointer self) {
    return static_cast<EmulatedFalcon*>(self)->on_ioctl(client) ? TRUE : FALSE;
}

// FT232R with the Falcon's ids: device descriptor (bcdUSB 2.00, max packet 64, VID 0403, PID cb48,
// bcdDevice 6.00) and configuration 1 with one vendor interface, bulk IN 0x81 and bulk OUT 0x02 of 64 bytes.
constexpr const char* kDescriptorsHex =
    "1201000200000040030448cb000601020301"  // device
    "09022000010100802d"                    // configuration 1, 32 bytes, 90 mA
    "0904000002ffffff02"                    // interface 0, 2 endpoints, vendor class
    "07058102400000"                        // bulk IN 0x81, 64 bytes
    "07050202400000";                       // bulk OUT 0x02, 64 bytes

}  // namespace

EmulatedFalcon::EmulatedFalcon() {
    const char* preload = std::getenv("LD_PRELOAD");
    if (preload == nullptr || std::string(preload).find("umockdev") == std::string::npos) {
        error_ = "not running under libumockdev-preload";
        return;
    }
    model_ = falcon_.open();
    testbed_ = umockdev_testbed_new();
    handler_ = umockdev_ioctl_base_new();
    g_signal_connect(handler_, "handle-ioctl", G_CALLBACK(falcon_handle_ioctl), this);
    GError* err = nullptr;
    if (!umockdev_testbed_attach_ioctl(testbed_, "/dev/bus/usb/001/002", handler_, &err)) {
        error_ = std::string("umockdev_testbed_attach_ioctl: ") + (err != nullptr ? err->message : "?");
        g_clear_error(&err);
        return;
    }
    const std::string device = std::string(
                                   "P: /devices/pci0000:00/usb1/1-1\n"
                                   "N: bus/usb/001/002\n"
                                   "E: SUBSYSTEM=usb\n"
                                   "E: DRIVER=usb\n"
                                   "E: BUSNUM=001\n"
                                   "E: DEVNUM=002\n"
                                   "E: DEVNAME=/dev/bus/usb/001/002\n"
                                   "E: DEVTYPE=usb_device\n"
                                   "E: PRODUCT=403/cb48/600\n"
                                   "A: bConfigurationValue=1\\n\n"
                                   "A: busnum=1\\n\n"
                                   "A: devnum=2\\n\n"
                                   "A: speed=12\\n\n"
                                   "A: idVendor=0403\\n\n"
                                   "A: idProduct=cb48\\n\n"
                                   "H: descriptors=") +
                               kDescriptorsHex + "\n";
    if (!umockdev_testbed_add_from_string(testbed_, device.c_str(), &err)) {
        error_ = std::string("umockdev_testbed_add_from_string: ") + (err != nullptr ? err->message : "?");
        g_clear_error(&err);
        return;
    }
    ok_ = true;
}

EmulatedFalcon::~EmulatedFalcon() {
    if (testbed_ != nullptr) {
        GError* err = nullptr;
        umockdev_testbed_detach_ioctl(testbed_, "/dev/bus/usb/001/002", &err);
        g_clear_error(&err);
    }
    for (auto* list : {&flying_, &discarded_}) {
        for (Flying& f : *list) g_object_unref(f.urb);
    }
    if (testbed_ != nullptr) g_object_unref(testbed_);
    if (handler_ != nullptr) g_object_unref(handler_);
}

std::string EmulatedFalcon::root_dir() const {
    if (testbed_ == nullptr) return {};
    gchar* root = umockdev_testbed_get_root_dir(testbed_);
    std::string out = root != nullptr ? root : "";
    g_free(root);
    return out;
}

// Bytes from the host: to the scripted Falcon, except that a slow loader does not hear them while it
// wakes up, and holds back the echo of a firmware chunk while it burns it.
void EmulatedFalcon::loader_write(std::span<const std::uint8_t> data, std::chrono::steady_clock::time_point now) {
    auto& model = static_cast<ScriptedTransport&>(*model_.transport);
    const bool loader = !falcon_.firmware_running;
    if (loader && slow_.wake_up.count() > 0 && dtr_high_ != std::chrono::steady_clock::time_point{} &&
        now < dtr_high_ + slow_.wake_up) {
        ++log_.ignored_while_waking;
        return;
    }
    const std::size_t before = model.rx.size();
    const int answers_before = falcon_.upload_attempts;  // the scripted loader counts its handshake answers
    model.write(data, 0);
    if (loader && falcon_.upload_attempts != answers_before) {
        loader_answered_ = true;
        log_.handshake_answered = now;
    }
    if (loader && slow_.burn_per_chunk.count() > 0 && falcon_.uploaded > 0 && model.rx.size() > before) {
        HeldEcho h{now + slow_.burn_per_chunk,
                   std::vector<std::uint8_t>(model.rx.begin() + static_cast<std::ptrdiff_t>(before), model.rx.end())};
        model.rx.erase(model.rx.begin() + static_cast<std::ptrdiff_t>(before), model.rx.end());
        held_.push_back(std::move(h));
        ++log_.chunks_held;
    }
}

void EmulatedFalcon::unplug() {
    auto l = lock();
    unplugged_ = true;
}

// An IN URB completes with 2 FTDI status bytes per 64-byte packet followed by up to 62 payload bytes,
// or with the status bytes alone once the latency timer ran out (ftdi_protocol.hpp: strip_ftdi_status()).
bool EmulatedFalcon::complete_in(Flying& f, std::chrono::steady_clock::time_point now) {
    auto* urb = reinterpret_cast<usbdevfs_urb*>(f.urb->data);
    if (stalled_) {
        urb->status = -EPIPE;
        urb->actual_length = 0;
        return true;
    }
    auto& rx = static_cast<ScriptedTransport&>(*model_.transport).rx;
    // A slow loader's echo, burned, and answered status-only at least once meanwhile (emulated_falcon.hpp: the
    // lockstep).
    while (!held_.empty() && held_.front().release <= now && held_.front().status_only_sent) {
        rx.insert(rx.end(), held_.front().bytes.begin(), held_.front().bytes.end());
        held_.pop_front();
        log_.last_echo_released = now;
    }
    const int latency_ms = std::max<int>(1, falcon_.latency_ms);
    const bool timer_expired = now - f.submitted >= std::chrono::milliseconds(latency_ms);
    if (rx.empty() && !timer_expired) return false;
    if (rx.empty()) {  // this packet carries the status bytes alone
        if (!held_.empty()) {
            ++log_.status_only_while_burning;
            held_.front().status_only_sent = true;
        } else if (dtr_high_ != std::chrono::steady_clock::time_point{} && !loader_answered_ &&
                   !falcon_.firmware_running) {
            ++log_.status_only_while_waking;
        }
    }
    auto* out = f.buffer->data;  // the local copy of the client's buffer, synced back when it is reaped
    int written = 0;
    const int capacity = urb->buffer_length;
    do {
        if (written + 2 > capacity) break;
        out[written++] = 0x01;  // modem status
        out[written++] = 0x60;  // line status: transmitter empty
        for (int i = 0; i < 62 && !rx.empty() && written < capacity; ++i) {
            out[written++] = rx.front();
            rx.pop_front();
        }
    } while (!rx.empty() && written + 2 <= capacity);
    urb->actual_length = written;
    urb->status = 0;
    ++in_completed_;
    return true;
}

bool EmulatedFalcon::on_ioctl(UMockdevIoctlClient* client) {
    std::lock_guard lock(mutex_);
    const unsigned long request = umockdev_ioctl_client_get_request(client);
    UMockdevIoctlData* arg = umockdev_ioctl_client_get_arg(client);
    switch (request) {
        case USBDEVFS_GET_CAPABILITIES: {
            UMockdevIoctlData* d = umockdev_ioctl_data_resolve(arg, 0, sizeof(guint32), nullptr);
            *reinterpret_cast<guint32*>(d->data) = USBDEVFS_CAP_BULK_CONTINUATION | USBDEVFS_CAP_NO_PACKET_SIZE_LIM |
                                                   USBDEVFS_CAP_REAP_AFTER_DISCONNECT | USBDEVFS_CAP_ZERO_PACKET;
            umockdev_ioctl_client_complete(client, 0, 0);
            return true;
        }
        case USBDEVFS_CLAIMINTERFACE:
        case USBDEVFS_RELEASEINTERFACE:
        case USBDEVFS_CLEAR_HALT:
        case USBDEVFS_RESET:
        case USBDEVFS_RESETEP:
        case USBDEVFS_SETINTERFACE:
            umockdev_ioctl_client_complete(client, unplugged_ ? -1 : 0, unplugged_ ? ENODEV : 0);
            return true;
        case USBDEVFS_GETDRIVER:
        case USBDEVFS_IOCTL:
            umockdev_ioctl_client_complete(client, -1, ENODATA);  // no kernel driver bound
            return true;
        case USBDEVFS_SUBMITURB: {
            if (unplugged_) {
                umockdev_ioctl_client_complete(client, -1, ENODEV);
                return true;
            }
            UMockdevIoctlData* urb_data = umockdev_ioctl_data_resolve(arg, 0, sizeof(usbdevfs_urb), nullptr);
            auto* urb = reinterpret_cast<usbdevfs_urb*>(urb_data->data);
            // The client may be another process (hapticd run by a test): never dereference its pointers,
            // resolve them (umockdev copies the memory and syncs it back).
            UMockdevIoctlData* buffer_data = umockdev_ioctl_data_resolve(
                urb_data, offsetof(usbdevfs_urb, buffer), static_cast<gsize>(std::max(urb->buffer_length, 1)), nullptr);
            const std::uint8_t* buffer = buffer_data->data;
            Flying f;
            f.urb = static_cast<UMockdevIoctlData*>(g_object_ref(urb_data));
            f.buffer = buffer_data;
            f.client_addr = *reinterpret_cast<unsigned long*>(arg->data);
            f.submitted = std::chrono::steady_clock::now();
            auto& model = static_cast<ScriptedTransport&>(*model_.transport);
            if (urb->type == USBDEVFS_URB_TYPE_CONTROL) {
                // Setup packet: bmRequestType, bRequest, wValue, wIndex, wLength (USB 2.0 Sect. 9.3).
                const std::uint8_t request_type = buffer[0];
                const std::uint8_t req = buffer[1];
                const auto value = static_cast<std::uint16_t>(buffer[2] | (buffer[3] << 8));
                const auto index = static_cast<std::uint16_t>(buffer[4] | (buffer[5] << 8));
                if (request_type == 0x40) {
                    model.control(req, value, index);
                    if (req == ftdi::kRequestLatency) falcon_.latency_ms = value;
                    if (req == ftdi::kRequestModemCtrl && value == ftdi::modem_dtr(true)) {  // the loader restarts
                        dtr_high_ = f.submitted;
                        if (log_.first_dtr_high == std::chrono::steady_clock::time_point{})
                            log_.first_dtr_high = dtr_high_;
                        loader_answered_ = false;
                        held_.clear();
                    }
                    if (req == ftdi::kRequestReset && (value == ftdi::kPurgeRx || value == ftdi::kResetSio))
                        model.rx.clear();
                }
                urb->actual_length = 0;
                urb->status = 0;
                f.done = true;
            } else if ((urb->endpoint & 0x80) == 0) {
                if (!silent_)
                    loader_write(std::span<const std::uint8_t>(buffer, static_cast<std::size_t>(urb->buffer_length)),
                                 f.submitted);
                urb->actual_length = urb->buffer_length;
                urb->status = 0;
                f.done = true;
            } else {
                f.in = true;
            }
            flying_.push_back(f);
            umockdev_ioctl_client_complete(client, 0, 0);
            return true;
        }
        case USBDEVFS_REAPURB:
        case USBDEVFS_REAPURBNDELAY: {
            Flying ready{};
            bool have = false;
            if (!discarded_.empty()) {
                ready = discarded_.front();
                discarded_.pop_front();
                reinterpret_cast<usbdevfs_urb*>(ready.urb->data)->status = -ENOENT;
                have = true;
            } else if (unplugged_) {
                // As the kernel after a disconnect: the URBs in flight complete with -ESHUTDOWN (reapable,
                // USBDEVFS_CAP_REAP_AFTER_DISCONNECT), which libusb turns into LIBUSB_TRANSFER_NO_DEVICE.
                if (!flying_.empty()) {
                    ready = flying_.front();
                    flying_.pop_front();
                    auto* urb = reinterpret_cast<usbdevfs_urb*>(ready.urb->data);
                    urb->status = -ESHUTDOWN;
                    urb->actual_length = 0;
                    have = true;
                }
            } else {
                const auto now = std::chrono::steady_clock::now();
                for (auto it = flying_.begin(); it != flying_.end(); ++it) {
                    if (it->done || (it->in && complete_in(*it, now))) {
                        ready = *it;
                        flying_.erase(it);
                        have = true;
                        break;
                    }
                }
            }
            if (!have) {
                umockdev_ioctl_client_complete(client, -1, EAGAIN);
                return true;
            }
            UMockdevIoctlData* urb_ptr = umockdev_ioctl_data_resolve(arg, 0, sizeof(gpointer), nullptr);
            umockdev_ioctl_data_set_ptr(urb_ptr, 0, ready.urb);
            g_object_unref(ready.urb);
            umockdev_ioctl_client_complete(client, 0, 0);
            return true;
        }
        case USBDEVFS_DISCARDURB: {
            const unsigned long addr = *reinterpret_cast<unsigned long*>(arg->data);
            const auto it =
                std::find_if(flying_.begin(), flying_.end(), [addr](const Flying& f) { return f.client_addr == addr; });
            if (it == flying_.end()) {
                umockdev_ioctl_client_complete(client, -1, EINVAL);
            } else {
                discarded_.push_back(*it);
                flying_.erase(it);
                umockdev_ioctl_client_complete(client, 0, 0);
            }
            return true;
        }
        default:
            umockdev_ioctl_client_complete(client, -1, ENOTTY);
            return true;
    }
}

}  // namespace hapticd::test
