// SPDX-License-Identifier: Apache-2.0
// Without hapticd's udev rule the device node refuses the user: `hapticd --list-devices` still lists the
// device and says how to fix it (the udev rule, the plugdev group), exit code 0 (docs/devices.md), and
// `hapticd --device ...` fails to open it with the same hint and exit code 6. Tested through the REAL
// libusb (the emulated Falcon's usbfs node) and the REAL hidapi (the emulated HID device's hidraw node):
// hapticd runs as a child process against a node whose mode refuses it, so its open() fails with EACCES in
// the kernel, not in a mock. As root (CI) the child drops to the unprivileged "nobody" first, because root
// opens any node whatever its mode (node_access.hpp). Each refusal has a control run that differs only in
// the node's mode (0666, what the udev rule gives the user), which must say "ok": the hint comes from the
// mode, not from the privilege drop or the testbed. Label usb.
#include <gtest/gtest.h>

#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <string>
#include <vector>

#include "common/run_child.hpp"
#include "common/test_paths.hpp"
#include "emulated_falcon.hpp"
#include "emulated_hid_device.hpp"
#include "node_access.hpp"

namespace hapticd {
namespace {

using namespace std::chrono_literals;

// A child that hangs fails the test (killed after this long); hapticd answers in well under a second.
constexpr auto kChildLimit = 20s;

// What the hint must name (kUdevHint in src/devices/transport_libusb.hpp, docs/devices.md "Running
// without root"): the rule file to install and the group to join.
void expect_udev_hint(const std::string& out) {
    std::string lower = out;
    std::transform(lower.begin(), lower.end(), lower.begin(),
                   [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
    EXPECT_NE(lower.find("permission denied"), std::string::npos) << out;
    EXPECT_NE(out.find("config/udev/70-hapticd.rules"), std::string::npos) << out;
    EXPECT_NE(out.find("/etc/udev/rules.d/"), std::string::npos) << out;
    EXPECT_NE(out.find("plugdev"), std::string::npos) << out;
}

// The list line of one device: "  <driver>  <vid:pid>  <where>  profiles: ...  <ok | problem>".
std::string line_with(const std::string& out, const std::string& what) {
    const auto at = out.find(what);
    if (at == std::string::npos) return {};
    const auto begin = out.rfind('\n', at);
    const auto end = out.find('\n', at);
    return out.substr(begin == std::string::npos ? 0 : begin + 1,
                      end == std::string::npos ? std::string::npos : end - begin - 1);
}

class StateDir {
  public:
    // One directory per process: ctest -j runs the tests of this binary side by side.
    StateDir()
        : path_(std::filesystem::temp_directory_path() /
                ("hapticd_test_usb_access_state_" + std::to_string(::getpid()))) {
        std::filesystem::create_directories(path_);
        setenv("HAPTICD_STATE_DIR", path_.c_str(), 1);  // a first run, whoever the child runs as
    }
    ~StateDir() {
        unsetenv("HAPTICD_STATE_DIR");
        std::error_code ec;
        std::filesystem::remove_all(path_, ec);
    }

  private:
    std::filesystem::path path_;
};

std::string who(const test::Credentials* as) {
    return as != nullptr ? "uid " + std::to_string(as->uid)
                         : "the test's own uid (not root: mode 000 refuses the owner)";
}

TEST(UsbAccess, ListDevicesGivesTheUdevHintForAFalconNodeThatRefusesTheUser) {
    test::EmulatedFalcon emulated;
    if (!emulated.ok()) GTEST_SKIP() << "umockdev emulation unavailable: " << emulated.error();
    test::NodeAccess access(emulated.root_dir(), test::EmulatedFalcon::kNode);
    ASSERT_TRUE(access.ok()) << access.error();
    const std::vector<std::string> list{HAPTICD_BINARY, "--list-devices"};

    ASSERT_TRUE(access.grant()) << access.error();
    const test::ChildResult allowed = test::run_child(list, kChildLimit, access.child_credentials());
    ASSERT_EQ(allowed.exit_code, 0) << who(access.child_credentials()) << "\n" << allowed.output;
    const std::string ok_line = line_with(allowed.output, "0403:cb48");
    EXPECT_NE(ok_line.find("ok"), std::string::npos) << allowed.output;

    ASSERT_TRUE(access.refuse()) << access.error();
    const test::ChildResult refused = test::run_child(list, kChildLimit, access.child_credentials());
    EXPECT_FALSE(refused.timed_out);
    EXPECT_EQ(refused.exit_code, 0) << refused.output;  // listing is not failing: exit 0 in all cases
    const std::string line = line_with(refused.output, "0403:cb48");
    ASSERT_FALSE(line.empty()) << "the refused Falcon is not listed:\n" << refused.output;
    expect_udev_hint(line);
    EXPECT_EQ(line.find("  ok"), std::string::npos) << line;
    std::printf("MEASURED --list-devices as %s, node mode 000: %s (%.0f ms)\n", who(access.child_credentials()).c_str(),
                line.c_str(), std::chrono::duration<double, std::milli>(refused.took).count());
}

TEST(UsbAccess, OpeningARefusedFalconExits6WithTheUdevHint) {
    test::EmulatedFalcon emulated;
    if (!emulated.ok()) GTEST_SKIP() << "umockdev emulation unavailable: " << emulated.error();
    {
        auto l = emulated.lock();
        emulated.falcon().firmware_running = true;
    }
    test::NodeAccess access(emulated.root_dir(), test::EmulatedFalcon::kNode);
    ASSERT_TRUE(access.ok()) << access.error();
    ASSERT_TRUE(access.refuse()) << access.error();
    StateDir state;
    const test::ChildResult r = test::run_child(
        {HAPTICD_BINARY, "--device", "falcon", "--wall", "axis=2 position=0.0 direction=+1", "--duration", "0.5"},
        kChildLimit, access.child_credentials());
    EXPECT_FALSE(r.timed_out);
    EXPECT_EQ(r.exit_code, 6) << r.output;  // device error (docs/devices.md: "permission denied ... (exit code 6)")
    EXPECT_NE(r.output.find("open failed"), std::string::npos) << r.output;
    EXPECT_NE(r.output.find("LIBUSB_ERROR_ACCESS"), std::string::npos) << r.output;  // from the real libusb_open()
    expect_udev_hint(r.output);
    auto l = emulated.lock();
    EXPECT_TRUE(emulated.falcon().commands.empty());  // nothing reached the Falcon
}

TEST(UsbAccess, ListDevicesGivesTheUdevHintForAHidrawNodeThatRefusesTheUser) {
    test::EmulatedHidDevice emulated;
    if (!emulated.ok()) GTEST_SKIP() << "umockdev emulation unavailable: " << emulated.error();
    test::NodeAccess access(emulated.root_dir(), test::EmulatedHidDevice::kNode);
    ASSERT_TRUE(access.ok()) << access.error();
    const std::vector<std::string> list{HAPTICD_BINARY, "--list-devices"};

    ASSERT_TRUE(access.grant()) << access.error();
    const test::ChildResult allowed = test::run_child(list, kChildLimit, access.child_credentials());
    ASSERT_EQ(allowed.exit_code, 0) << who(access.child_credentials()) << "\n" << allowed.output;
    EXPECT_NE(line_with(allowed.output, "1209:ffb0").find("ok"), std::string::npos) << allowed.output;

    ASSERT_TRUE(access.refuse()) << access.error();
    const test::ChildResult refused = test::run_child(list, kChildLimit, access.child_credentials());
    EXPECT_FALSE(refused.timed_out);
    EXPECT_EQ(refused.exit_code, 0) << refused.output;
    const std::string line = line_with(refused.output, "1209:ffb0");
    ASSERT_FALSE(line.empty()) << "the refused HID device is not listed:\n" << refused.output;
    EXPECT_NE(line.find("hidraw0"), std::string::npos) << line;
    expect_udev_hint(line);
    EXPECT_EQ(line.find("  ok"), std::string::npos) << line;
    std::printf("MEASURED --list-devices as %s, node mode 000: %s (%.0f ms)\n", who(access.child_credentials()).c_str(),
                line.c_str(), std::chrono::duration<double, std::milli>(refused.took).count());
}

TEST(UsbAccess, OpeningARefusedHidDeviceExits6WithTheUdevHint) {
    test::EmulatedHidDevice emulated;
    if (!emulated.ok()) GTEST_SKIP() << "umockdev emulation unavailable: " << emulated.error();
    test::NodeAccess access(emulated.root_dir(), test::EmulatedHidDevice::kNode);
    ASSERT_TRUE(access.ok()) << access.error();
    ASSERT_TRUE(access.refuse()) << access.error();
    StateDir state;
    const test::ChildResult r = test::run_child(
        {HAPTICD_BINARY, "--device", "openffboard", "--wall", "axis=0 position=0.0 direction=+1", "--duration", "0.5"},
        kChildLimit, access.child_credentials());
    EXPECT_FALSE(r.timed_out);
    EXPECT_EQ(r.exit_code, 6) << r.output;
    EXPECT_NE(r.output.find("open failed"), std::string::npos) << r.output;
    EXPECT_NE(r.output.find("Permission denied"), std::string::npos)
        << r.output;  // strerror(EACCES) of the real open()
    expect_udev_hint(r.output);
    EXPECT_TRUE(emulated.output_reports().empty());  // nothing reached the device
}

}  // namespace
}  // namespace hapticd
