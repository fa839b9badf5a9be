// SPDX-License-Identifier: Apache-2.0
// The Falcon driver through the REAL libusb-1.0 on a Falcon emulated under umockdev (emulated_falcon.hpp):
// enumeration by VID:PID, the FTDI control requests, homing (the firmware upload through bulk transfers
// with status-only packets is test_usb_falcon_loader.cpp), then the asynchronous streaming of the 1 kHz loop, which
// must not block; unplug (ENODEV) and a stalled endpoint end the stream with a device error, and nothing hangs; the
// fatal-signal handler's zero-torque command is the last one the Falcon takes. Label
// usb (the binary re-executes itself under libumockdev-preload, test_usb_hid.cpp).
#include <gtest/gtest.h>

#include <sys/resource.h>

#include <sys/wait.h>

#include <algorithm>
#include <csignal>
#include <cstdio>
#include <string>
#include <chrono>
#include <filesystem>
#include <functional>
#include <thread>
#include <vector>

#include "common/test_paths.hpp"
#include "daemon/fatal_signal.hpp"
#include "devices/falcon_device.hpp"
#include "devices/transport_libusb.hpp"
#include "emulated_falcon.hpp"

namespace hapticd {
namespace {

using Clock = std::chrono::steady_clock;

FalconDeviceConfig falcon_usb_config() {
    FalconDeviceConfig c;
    c.capabilities.axes = 3;
    c.capabilities.max_force = 9.0;
    c.homing_poll_ms = 1;
    c.homing_timeout = 10.0;
    c.open_transport = [] { return LibusbFtdiTransport::open_falcon(0); };
    return c;
}

class UsbFalcon : public ::testing::Test {
  protected:
    void SetUp() override {
        if (!emulated.ok()) GTEST_SKIP() << "umockdev emulation unavailable: " << emulated.error();
        auto l = emulated.lock();
        emulated.falcon().firmware_running = true;
        emulated.falcon().packets_until_homed = 5;
    }
    test::EmulatedFalcon emulated;
};

// Runs `ticks` ticks at 1 kHz; returns the time each read_position + write_force took, in ns. With
// `switches`: per tick, the thread's voluntary context switches during the two calls (the thread slept:
// it waited for something) and whether it was preempted (an involuntary switch: the scheduler's doing).
struct TickSwitches {
    std::vector<long> voluntary;
    std::vector<bool> preempted;
};
std::vector<std::int64_t> run_ticks(FalconDevice& dev, int ticks, DeviceStatus& status,
                                    TickSwitches* switches = nullptr) {
    std::vector<std::int64_t> took;
    took.reserve(static_cast<std::size_t>(ticks));
    const auto start = Clock::now();
    AxisVector p{};
    status = DeviceStatus::Ok;
    for (int i = 0; i < ticks && status == DeviceStatus::Ok; ++i) {
        std::this_thread::sleep_until(start + std::chrono::microseconds(1000 * (i + 1)));
        rusage before{}, after{};
        if (switches != nullptr) ::getrusage(RUSAGE_THREAD, &before);
        const auto t0 = Clock::now();
        status = dev.read_position(p);
        if (status == DeviceStatus::Ok) status = dev.write_force({0.0, 0.0, 0.5});
        took.push_back(std::chrono::duration_cast<std::chrono::nanoseconds>(Clock::now() - t0).count());
        if (switches != nullptr) {
            ::getrusage(RUSAGE_THREAD, &after);
            switches->voluntary.push_back(after.ru_nvcsw - before.ru_nvcsw);
            switches->preempted.push_back(after.ru_nivcsw != before.ru_nivcsw);
        }
    }
    return took;
}

TEST_F(UsbFalcon, HomesThenTheLoopNeverWaitsForTheDevice) {
    FalconDeviceConfig c = falcon_usb_config();
    // Under umockdev every URB is an IPC round trip to the handler thread, and on the loaded 2-core VM the
    // handler was starved for > 100 ms now and then (1 run in 4 under ctest): this test is about the tick
    // not waiting, so it tolerates 1 s without a status packet instead of the default 100 ticks.
    c.max_stale_reads = 1000;
    FalconDevice dev(c);
    ASSERT_EQ(dev.open(), DeviceStatus::Ok) << dev.last_error();
    ASSERT_EQ(dev.home(), DeviceStatus::Ok) << dev.last_error();
    DeviceStatus s = DeviceStatus::Ok;
    TickSwitches switches;
    const std::vector<std::int64_t> all = run_ticks(dev, 1000, s, &switches);
    ASSERT_EQ(s, DeviceStatus::Ok) << dev.last_error();
    // Not waiting: a driver that waits for the device (a blocking read or write) puts the loop's thread to
    // sleep in every tick, which the kernel counts as a voluntary context switch. The streaming driver only
    // moves bytes between atomics and writes an eventfd; under umockdev that write goes through its preload
    // library, whose lock is shared with its handler thread, so a rare sleep remains (1 in 1000 ticks
    // measured): the bound is 1 % of the ticks, against ~100 % for a waiting driver.
    long voluntary = 0;
    std::vector<std::int64_t> took;  // the ticks the scheduler did not interrupt
    for (std::size_t i = 0; i < all.size(); ++i) {
        voluntary += switches.voluntary[i];
        if (!switches.preempted[i]) took.push_back(all[i]);
    }
    EXPECT_LE(voluntary, static_cast<long>(all.size() / 100))
        << "the device calls slept (waited) " << voluntary << " times";
    ASSERT_GT(took.size(), all.size() / 2) << "preempted in most ticks: the machine is too loaded to time the calls";
    std::sort(took.begin(), took.end());
    const double p90_us = static_cast<double>(took[took.size() * 90 / 100]) * 1e-3;
    const double p99_us = static_cast<double>(took[took.size() * 99 / 100]) * 1e-3;
    std::printf(
        "MEASURED emulated Falcon tick (read_position + write_force), %zu of %zu ticks not preempted: p50 %.1f us, "
        "p90 %.1f us, p99 %.1f us, max %.1f us; voluntary switches %ld; status packets %llu, stale ticks %llu, late "
        "commands %llu\n",
        took.size(), all.size(), static_cast<double>(took[took.size() / 2]) * 1e-3, p90_us, p99_us,
        static_cast<double>(took.back()) * 1e-3, voluntary, static_cast<unsigned long long>(dev.counters().packets_ok),
        static_cast<unsigned long long>(dev.counters().stale_reads),
        static_cast<unsigned long long>(dev.late_commands()));
    // And in time: a synchronous driver waits for the device's next packet in every tick, on average half
    // the period (500 us) and up to the read timeout (1 ms), so its p90 is ~900 us. Criterion: p90 below
    // 10 % of the period over the ticks that were not preempted. The 90th, not the 99th, percentile: the
    // p99 of this driver reached 105 us (load 5) and 113 us (ctest -j2, no tick preempted and no voluntary
    // switch) — stalls the thread's rusage does not see (the hypervisor, umockdev's handler thread on the
    // other core) in 1-2 % of the ticks; p50 is 2-3 us.
    EXPECT_LT(p90_us, 100.0);
    // And the Falcon did answer, one status packet per command it took. Under umockdev every URB is an
    // IPC round trip to the handler thread; on the loaded 2-core VM 540-958 of the 1000 ticks saw a new
    // packet (three runs), so the bound is loose: at least a fifth.
    EXPECT_GT(dev.counters().packets_ok, 200U);
    {
        auto l = emulated.lock();
        EXPECT_GT(emulated.falcon().commands.size(), 200U);
        bool torque = false;
        for (const auto& c : emulated.falcon().commands) torque = torque || c.torque[0] != 0;
        EXPECT_TRUE(torque);  // the 0.5 N along z reached the motors
    }
    dev.close();
}

// The fatal-signal path (daemon/fatal_signal.hpp) through the real libusb: the handler's call hands a zero-torque
// command to the transport's event thread, which sends it; the call returns once the Falcon has taken it, and
// the loop's later commands are ignored. The timeout is the test's generous deadline (the handler's is 50 ms).
TEST_F(UsbFalcon, TheSignalSafeZeroIsTheLastCommandTheFalconTakes) {
    FalconDeviceConfig c = falcon_usb_config();
    c.max_stale_reads = 1000;
    c.signal_zero_timeout_ms = 30000;
    FalconDevice dev(c);
    ASSERT_EQ(dev.open(), DeviceStatus::Ok) << dev.last_error();
    ASSERT_EQ(dev.home(), DeviceStatus::Ok) << dev.last_error();
    DeviceStatus s = DeviceStatus::Ok;
    run_ticks(dev, 50, s);
    ASSERT_EQ(s, DeviceStatus::Ok) << dev.last_error();
    const auto zero_torque = [](const falcon::Command& command) {
        return command.torque[0] == 0 && command.torque[1] == 0 && command.torque[2] == 0;
    };
    {
        auto l = emulated.lock();
        ASSERT_FALSE(emulated.falcon().commands.empty());
        EXPECT_FALSE(zero_torque(emulated.falcon().commands.back())) << "the 0.5 N along z never reached the motors";
    }
    const auto t0 = Clock::now();
    EXPECT_TRUE(dev.zero_force_from_signal_handler());
    std::printf("MEASURED the signal-safe zero on the emulated Falcon: confirmed after %.3f ms\n",
                std::chrono::duration<double, std::milli>(Clock::now() - t0).count());
    std::size_t taken = 0;
    {
        auto l = emulated.lock();
        taken = emulated.falcon().commands.size();
        EXPECT_TRUE(zero_torque(emulated.falcon().commands.back()));
    }
    run_ticks(dev, 20, s);  // the loop goes on writing 0.5 N: ignored
    {
        auto l = emulated.lock();
        EXPECT_EQ(emulated.falcon().commands.size(), taken);
        EXPECT_TRUE(zero_torque(emulated.falcon().commands.back()));
    }
    dev.close();
}

// And from a real fatal signal with the daemon's handlers installed (a death test in a re-executed child, which
// builds its own emulated Falcon): the handler reports the zero as written.
TEST_F(UsbFalcon, AFatalSignalZeroesTheFalcon) {
    GTEST_FLAG_SET(death_test_style, "threadsafe");
    FalconDeviceConfig c = falcon_usb_config();
    c.max_stale_reads = 1000;
    c.signal_zero_timeout_ms = 30000;
    FalconDevice dev(c);
    ASSERT_EQ(dev.open(), DeviceStatus::Ok) << dev.last_error();
    ASSERT_EQ(dev.home(), DeviceStatus::Ok) << dev.last_error();
    DeviceStatus s = DeviceStatus::Ok;
    run_ticks(dev, 20, s);
    ASSERT_EQ(s, DeviceStatus::Ok) << dev.last_error();
    EXPECT_EXIT(
        {
            install_fatal_signal_handlers(&dev, nullptr);
            std::raise(SIGSEGV);
        },
        ::testing::KilledBySignal(SIGSEGV), "hapticd: fatal: signal 11; zero force written to the device");
    dev.close();
}

TEST_F(UsbFalcon, UnplugDuringTheRunIsADeviceErrorAndNothingHangs) {
    FalconDevice dev(falcon_usb_config());
    ASSERT_EQ(dev.open(), DeviceStatus::Ok) << dev.last_error();
    ASSERT_EQ(dev.home(), DeviceStatus::Ok) << dev.last_error();
    DeviceStatus s = DeviceStatus::Ok;
    run_ticks(dev, 50, s);
    ASSERT_EQ(s, DeviceStatus::Ok);
    emulated.unplug();
    const std::vector<std::int64_t> took = run_ticks(dev, 200, s);
    EXPECT_EQ(s, DeviceStatus::Disconnected) << dev.last_error();
    EXPECT_LT(took.size(), 50U);  // noticed within a few ticks
    const auto t0 = Clock::now();
    dev.close();
    EXPECT_LT(Clock::now() - t0, std::chrono::seconds(2));
}

TEST_F(UsbFalcon, StalledEndpointIsAHardwareFault) {
    FalconDevice dev(falcon_usb_config());
    ASSERT_EQ(dev.open(), DeviceStatus::Ok) << dev.last_error();
    ASSERT_EQ(dev.home(), DeviceStatus::Ok) << dev.last_error();
    emulated.set_stalled(true);
    DeviceStatus s = DeviceStatus::Ok;
    const std::vector<std::int64_t> took = run_ticks(dev, 200, s);
    EXPECT_EQ(s, DeviceStatus::HardwareFault) << dev.last_error();
    EXPECT_LT(took.size(), 50U);
    dev.close();
}

TEST_F(UsbFalcon, SilentFalconTimesOut) {
    FalconDevice dev(falcon_usb_config());
    ASSERT_EQ(dev.open(), DeviceStatus::Ok) << dev.last_error();
    ASSERT_EQ(dev.home(), DeviceStatus::Ok) << dev.last_error();
    emulated.set_silent(true);  // the FTDI chip still sends status-only packets; the Falcon says nothing
    DeviceStatus s = DeviceStatus::Ok;
    const std::vector<std::int64_t> took = run_ticks(dev, 300, s);
    EXPECT_EQ(s, DeviceStatus::Timeout) << dev.last_error();
    EXPECT_GE(took.size(), 100U);  // max_stale_reads = 100 ticks without a packet
    EXPECT_LE(took.size(), 105U);
    dev.close();
}

// The daemon itself, as a child process that inherits the testbed: hapticd homes the emulated Falcon,
// renders a wall along z, and exits 6 with a clear message when the Falcon is unplugged mid-run.
// `on_line` (optional) sees each line of the child's output as it is printed.
std::string run_child(const std::string& args, int& rc,
                      const std::function<void(const std::string&)>& on_line = nullptr) {
    const std::string cmd = "timeout -s KILL 20 " + std::string(HAPTICD_BINARY) + " " + args + " 2>&1";
    FILE* pipe = popen(cmd.c_str(), "r");
    if (pipe == nullptr) {
        rc = -1;
        return {};
    }
    std::string out;
    char buf[512];
    while (std::fgets(buf, sizeof buf, pipe) != nullptr) {
        out += buf;
        if (on_line) on_line(buf);
    }
    const int status = pclose(pipe);
    rc = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
    return out;
}

TEST_F(UsbFalcon, HapticdRendersAWallOnTheEmulatedFalconAndExits6OnUnplug) {
    const auto state = std::filesystem::temp_directory_path() / "hapticd_test_usb_state";
    setenv("HAPTICD_STATE_DIR", state.c_str(), 1);  // a fresh first run: forces limited to 1 N
    const std::string args = "--device falcon --wall 'axis=2 position=0.0 direction=+1' --duration 0.5";
    int rc = -1;
    std::string out = run_child(args, rc);
    EXPECT_EQ(rc, 0) << out;
    EXPECT_NE(out.find("first run"), std::string::npos) << out;
    EXPECT_NE(out.find("ticks 500"), std::string::npos) << out;
    // The loop's own statistics line (overruns, if any, are the loaded VM's scheduling: the driver's share
    // of a tick is checked by HomesThenTheLoopNeverWaitsForTheDevice).
    if (const auto at = out.find("ticks 500"); at != std::string::npos) {
        std::printf("MEASURED hapticd on the emulated Falcon: %s\n", out.substr(at, out.find('\n', at) - at).c_str());
    }
    {
        auto l = emulated.lock();
        bool torque = false;
        for (const auto& c : emulated.falcon().commands) torque = torque || c.torque[0] != 0;
        EXPECT_TRUE(torque)
            << "the wall (entered in +z at 0; the pulled-out grip at z = +50 mm is inside it) rendered no force";
    }
    // Unplug 0.3 s after the loop has started (hapticd prints "hapticd: running" once tuning, opening and homing
    // are done; their time varies, several times longer under a sanitizer), in a 5 s run: device error, exit 6,
    // well before the run's end.
    std::thread unplug;
    Clock::time_point unplugged{};
    auto on_line = [&](const std::string& line) {
        if (unplug.joinable() || line.rfind("hapticd: running", 0) != 0) return;
        unplug = std::thread([this, &unplugged] {
            std::this_thread::sleep_for(std::chrono::milliseconds(300));
            unplugged = Clock::now();
            emulated.unplug();
        });
    };
    out = run_child("--device falcon --wall 'axis=2 position=0.0 direction=+1' --duration 5", rc, on_line);
    ASSERT_TRUE(unplug.joinable()) << "the loop never started: " << out;
    unplug.join();
    EXPECT_EQ(rc, 6) << out;
    EXPECT_NE(out.find("disconnected"), std::string::npos) << out;
    EXPECT_LT(Clock::now() - unplugged, std::chrono::milliseconds(2500)) << out;
    unsetenv("HAPTICD_STATE_DIR");
    std::filesystem::remove_all(state);
}

TEST_F(UsbFalcon, ListDevicesFindsTheEmulatedFalcon) {
    // A child process inherits the preload and the testbed and talks to this process's handler.
    const std::string cmd = std::string(HAPTICD_BINARY) + " --list-devices 2>&1";
    FILE* pipe = popen(cmd.c_str(), "r");
    ASSERT_NE(pipe, nullptr);
    std::string out;
    char buf[512];
    while (std::fgets(buf, sizeof buf, pipe) != nullptr) out += buf;
    EXPECT_EQ(pclose(pipe), 0) << out;
    EXPECT_NE(out.find("0403:cb48"), std::string::npos) << out;
}

}  // namespace
}  // namespace hapticd
